"""diagnosis.next_command: the swivel to record when two fitted causes are undecided."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from skidsteer.data.dataset import Group
from skidsteer.diagnosis import causes
from skidsteer.diagnosis.comparison import Comparison, Observed, model_factory
from skidsteer.diagnosis.fit import MIN_GAIN, Z_CONSISTENT
from skidsteer.diagnosis.next_command import (candidate_commands, proposal_note, separation,
                                              separating_commands, undecided_pair)
from skidsteer.features.extract import N_POWER
from skidsteer.robot import Setup
from skidsteer.simulation.backends import LocalBackend
from skidsteer.simulation.cache import SimulationCache
from skidsteer.simulation.sensor_chain import SensorChain

TILE = Setup(build="extended", floor="tile")
CONCRETE = Setup(build="extended", floor="concrete")


def test_separation_is_the_rms_z_of_the_medians_widened_by_both_spreads():
    scale = np.array([0.5, 0.5, 1.0])
    a = np.zeros((3, 2, 3))
    b = np.zeros((3, 2, 3))
    b[:, 0, 0] = 1.5  # command 0: feature 0 three scales apart, no spread
    b[:, 1, 2] = [1.0, 2.0, 3.0]  # command 1: feature 2 a median of 2 with spread 1
    still = np.zeros((2, 3))  # a's starts agree everywhere, and b's on command 0
    spread_b = still.copy()
    spread_b[1, 2] = 1.0  # the standard deviation (ddof 1) of b's 1, 2, 3
    apart, z = separation(a, b, scale, still, spread_b)
    assert z[0] == pytest.approx([-3.0, 0.0, 0.0])
    assert apart[0] == pytest.approx(np.sqrt(9 / 3))
    assert z[1, 2] == pytest.approx(-2.0 / np.sqrt(1.0 + 1.0))
    # symmetric, and zero between a model and itself
    again, _ = separation(b, a, scale, spread_b, still)
    assert again == pytest.approx(apart)
    assert separation(a, a, scale, still, still)[0] == pytest.approx([0.0, 0.0])


def test_separation_ignores_unscored_features_and_checks_shapes():
    scale = np.ones(2)
    a = np.zeros((2, 1, 2))
    b = np.zeros((2, 1, 2))
    b[:, 0, 0] = 2.0
    a[:, 0, 1] = b[:, 0, 1] = np.nan  # neither model scores feature 1
    still = np.zeros((1, 2))
    assert separation(a, b, scale, still, still)[0] == pytest.approx([2.0])
    with pytest.raises(ValueError, match="shapes"):
        separation(a, np.zeros((2, 2, 2)), scale, still, still)
    with pytest.raises(ValueError, match="spreads"):
        separation(a, b, scale, still, np.zeros((2, 2)))


def test_candidates_leave_out_the_rates_a_setup_has_recorded():
    groups = [Group(0.0, 30.0, TILE), Group(0.0, 35.0, TILE), Group(0.0, 50.0, TILE),
              Group(0.0, 60.0, CONCRETE)]
    got = {(g.setup.floor, g.omega_deg_s) for g in candidate_commands(groups)}
    assert got == {("tile", 10.0), ("tile", 20.0), ("tile", 40.0), ("tile", 60.0),
                   ("concrete", 10.0), ("concrete", 20.0), ("concrete", 30.0),
                   ("concrete", 40.0), ("concrete", 50.0)}
    assert all(g.v_mps == 0.0 for g in candidate_commands(groups))


def _fit(cause, removed):
    return SimpleNamespace(cause=cause, removed=removed)


def test_a_pair_is_undecided_only_when_both_remove_most_and_none_is_named():
    a, b = _fit("ground_roughness", 0.87), _fit("wheel_eccentricity", 0.6)
    assert undecided_pair([a, b], None, 3.0, Z_CONSISTENT, MIN_GAIN) == (a, b)
    assert undecided_pair([a, b], a, 3.0, Z_CONSISTENT, MIN_GAIN) is None  # named
    assert undecided_pair([a, b], None, 1.9, Z_CONSISTENT, MIN_GAIN) is None  # quiet held-out
    low = _fit("wheel_eccentricity", MIN_GAIN - 0.01)
    assert undecided_pair([a, low], None, 3.0, Z_CONSISTENT, MIN_GAIN) is None
    assert undecided_pair([a], None, 3.0, Z_CONSISTENT, MIN_GAIN) is None


def test_the_note_proposes_a_command_only_above_the_discrepancy_limit():
    a, b = _fit("ground_roughness", 0.9), _fit("wheel_eccentricity", 0.9)

    def proposal(sep, w):
        return {"command": f"v0-w{w:g} tile extended", "omega_deg_s": w, "separation": sep,
                "feature": "steady_ay_9-12.5Hz", "feature_z": 3.0,
                "predicted": {"ground_roughness": -6.1, "wheel_eccentricity": -7.0}}

    note = proposal_note([proposal(3.4, 40.0), proposal(1.0, 10.0)], a, b, Z_CONSISTENT)
    assert "record a swivel at 40 deg/s" in note and "3.4 RMS z apart" in note
    assert "--hold-out 'v0-w40 tile extended'" in note  # how to test the fits on it
    note = proposal_note([proposal(1.6, 40.0), proposal(1.0, 10.0)], a, b, Z_CONSISTENT)
    assert "no swivel of 10-40 deg/s" in note and "at most 1.6" in note
    assert "--hold-out" not in note
    assert proposal_note([], a, b, Z_CONSISTENT) == ""


def _comparison(groups, rng):
    """A comparison read from made-up records: three trials per group, band powers
    scattered by a tenth of a decade."""
    n = 3 * len(groups)
    features = 10 ** rng.normal(-6.0, 0.1, (n, N_POWER + 1))
    features[:, -1] = rng.normal(0.3, 0.01, n)
    observed = Observed(groups, np.repeat(np.arange(len(groups)), 3),
                        [f"run{i}.csv" for i in range(n)], features, 8.0, [], [])
    return Comparison(observed)


def test_separating_commands_simulates_both_fits_on_the_commands_the_data_lack(tmp_path):
    groups = [Group(0.0, 30.0, CONCRETE)]
    comparison = _comparison(groups, np.random.default_rng(0))
    friction = causes.get("friction_levels")

    def fit(mu_static):
        return SimpleNamespace(cause=f"mu {mu_static}", factory=model_factory(
            friction.edit(friction.parameters(mu_static))))

    low, high, same = fit(0.45), fit(1.1), fit(1.1)
    run = dict(comparison=comparison, groups=groups, duration_s=8.0, chain=SensorChain(),
               backend=LocalBackend(2), rates_deg_s=(20.0, 30.0, 40.0), starts=2,
               cache=SimulationCache(tmp_path))  # the later calls reuse the first's runs
    proposals = separating_commands(low, high, **run)
    assert [p["omega_deg_s"] for p in proposals] != [] and all(
        p["omega_deg_s"] in (20.0, 40.0) for p in proposals)  # 30 is recorded
    seps = [p["separation"] for p in proposals]
    assert seps == sorted(seps, reverse=True) and all(np.isfinite(seps))
    # the friction level moves a swivel's vibration: the two fits are apart somewhere,
    # and by the same amount whichever is first
    assert seps[0] > 0
    swapped = separating_commands(high, low, **run)
    assert [p["separation"] for p in swapped] == pytest.approx(seps)
    # two fits that are one model predict the same everywhere
    assert all(p["separation"] == 0 for p in separating_commands(high, same, **run))
