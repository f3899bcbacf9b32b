"""The simulation cache that lets a killed diagnose resume: what its keys hold, what it
returns.  (The kill-and-resume test itself is in test_diagnose.py.)"""

from __future__ import annotations

import numpy as np

from skidsteer.diagnosis import causes
from skidsteer.diagnosis.comparison import model_factory
from skidsteer.robot import Setup
from skidsteer.simulation.sensor_chain import SensorChain
from skidsteer.simulation.cache import (SimulationCache, code_fingerprint, model_bytes,
                                        model_digest)

SETUP = Setup(build="extended", floor="concrete")


def test_a_model_compiles_to_the_same_bytes_every_time():
    # the key's model part: two builds of one setup must hit the same entry
    assert model_bytes(model_factory()(SETUP)) == model_bytes(model_factory()(SETUP))


def test_every_input_of_a_simulation_changes_its_key(tmp_path):
    cache = SimulationCache(tmp_path)
    base = model_factory()(SETUP)
    task = (2.0, 0.0, 30.0, 8.0, SensorChain())
    key = cache.key(model_digest(base), *task)
    other_models = [
        model_factory(timestep=5e-5)(SETUP),
        model_factory()(Setup(build="extended", floor="carpet")),
        model_factory()(
            Setup(build="extended", floor="concrete", accel_position_m=(0.0, 0.0, 0.5))),
        model_factory(edit=causes.get("slip_lambda_max").edit({"lambda_max": 0.2}))(SETUP),
    ]
    keys = {cache.key(model_digest(m), *task) for m in other_models}
    keys |= {cache.key(model_digest(base), *t) for t in [
        (1.0, 0.0, 30.0, 8.0, SensorChain()),  # settling time
        (2.0, 0.1, 30.0, 8.0, SensorChain()),  # command
        (2.0, 0.0, 30.0 + 1e-12, 8.0, SensorChain()),  # exact, not rounded
        (2.0, 0.0, 30.0, 20.0, SensorChain()),  # record length
        (2.0, 0.0, 30.0, 8.0, SensorChain(bandwidth_hz=60.0)),  # the sensor chain
    ]}
    assert key not in keys and len(keys) == len(other_models) + 5


def test_the_code_fingerprint_covers_the_plugin_library(tmp_path, monkeypatch):
    from skidsteer.robot import plugin as _plugin

    before = code_fingerprint()
    copy = tmp_path / "libskidsteer_tire.so"
    copy.write_bytes(_plugin.library_path().read_bytes() + b"\0")
    monkeypatch.setenv("SKIDSTEER_PLUGIN_LIBRARY", str(copy))
    code_fingerprint.cache_clear()
    try:
        assert code_fingerprint() != before
    finally:
        monkeypatch.undo()
        code_fingerprint.cache_clear()
    assert code_fingerprint() == before


def test_entries_come_back_exactly_and_bad_ones_are_misses(tmp_path):
    cache = SimulationCache(tmp_path / "c")
    features = np.array([1 / 3, np.nan, 1e-300, -0.0])
    assert cache.get("k") is None
    cache.put("k", features, 12.345678901234567, (0.1, 1 / 7))
    got, yaw, rates = cache.get("k")
    np.testing.assert_array_equal(got, features)  # NaN in place, bits equal
    assert got.tobytes() == features.tobytes() and yaw == 12.345678901234567
    assert rates == (0.1, 1 / 7)
    assert (cache.stores, cache.hits) == (1, 1)
    (tmp_path / "c" / "bad.npz").write_bytes(b"not an npz")
    assert cache.get("bad") is None
    assert not list((tmp_path / "c").glob(".*.part"))


def test_the_installed_plugin_has_no_build_id():
    # the build-id was the one difference between two installs of the same sources
    # (20 bytes), so a reinstall, which the main job does on every run, invalidated every
    # stored simulation; plugin/tire/CMakeLists.txt links without one.  A library
    # with one lists its section, .note.gnu.build-id, in its section-name table
    # (strip keeps the section headers); nothing else in it spells that name.
    from skidsteer.robot import plugin as _plugin

    assert b".note.gnu.build-id" not in _plugin.library_path().read_bytes()
