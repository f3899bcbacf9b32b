"""Golden swivel features: re-simulated reference runs match tests/golden/swivel_features.json.

The golden file (scripts/make_golden_features.py) holds, for a few swivels in
place, the robust Appendix A / Sec. 3.2 features of the reference run (settled
start, no perturbation) and a tolerance per feature: max(3 sigma of seeded
repeat trials, the measurement resolution).  Here the reference runs are
simulated again (the cases sharing a model in one batch: 5 runs of 22 s
simulated) and every feature must land within its tolerance.
"""

from __future__ import annotations

import json
import math

import mujoco
import pytest

from conftest import REPO
import make_golden_features as golden

GOLDEN = REPO / "tests" / "golden" / "swivel_features.json"
MAX_FREQUENCY_TOLERANCE_HZ = 5.0  # wider, and "the peak is somewhere in the band" passes


def _load() -> dict:
    return json.loads(GOLDEN.read_text())


def _regenerate() -> str:
    trials = _load()["provenance"].get("trials", 8) if GOLDEN.is_file() else 8
    return golden.regenerate_command(GOLDEN.relative_to(REPO), trials)


CASE_NAMES = [c["name"] for c in _load()["cases"]] if GOLDEN.is_file() else []


def _entries(case: dict):
    """(feature, axis or None, entry) of a golden case, in the golden file's order."""
    for feature, value in case["features"].items():
        if "reference" in value:
            yield feature, None, value
        else:
            for axis, entry in value.items():
                yield feature, axis, entry


def _label(feature: str, axis: str | None) -> str:
    return feature if axis is None else f"{feature} axis {axis}"


@pytest.fixture(scope="module")
def data() -> dict:
    if not GOLDEN.is_file():
        pytest.fail(f"{GOLDEN} is missing; generate it with: {_regenerate()}")
    return _load()


@pytest.fixture(scope="module")
def resimulated(data) -> dict[str, dict]:
    """robust_features of every case's reference run (seed None), by case name."""
    cases = data["cases"]
    features = golden.simulate_features(cases, [None], nthread=2)
    return {case["name"]: runs[0] for case, runs in zip(cases, features)}


def test_golden_file_is_for_this_engine_and_model(data):
    stored = data["provenance"]["mujoco_version"]
    assert stored == mujoco.__version__, (
        f"{GOLDEN.name} was made with mujoco {stored}, this is mujoco {mujoco.__version__}: "
        f"a changed engine changes the simulated runs; regenerate with: {_regenerate()}")
    for case in data["cases"]:
        m = golden.swivel_model(case["config"], case["surface"], case["mount"], case["variant"])
        assert m.opt.timestep == case["timestep_s"], (
            f"case {case['name']}: {GOLDEN.name} was made with timestep {case['timestep_s']} s, "
            f"the model now has {m.opt.timestep} s: a changed model changes the simulated runs; "
            f"regenerate with: {_regenerate()}")


def test_golden_tolerances_are_meaningful(data):
    problems = []
    for case in data["cases"]:
        for feature, axis, entry in _entries(case):
            tol = entry["tolerance"]
            where = f"case {case['name']}, {_label(feature, axis)}"
            if tol is None or not math.isfinite(tol) or not tol > 0:
                problems.append(f"{where}: tolerance {tol} is not a finite positive number")
            elif feature in golden.FREQUENCY_FEATURES and not tol < MAX_FREQUENCY_TOLERANCE_HZ:
                problems.append(
                    f"{where}: tolerance {tol:.3g} Hz (repeats {entry['repeat_min']:.4g}.."
                    f"{entry['repeat_max']:.4g} Hz, std {entry['repeat_std']:.3g}) >= "
                    f"{MAX_FREQUENCY_TOLERANCE_HZ:g} Hz: the trial-to-trial spread is too large "
                    "for this to be a useful golden value; replace the case (in "
                    "scripts/make_golden_features.py CASES) and regenerate")
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("name", CASE_NAMES)
def test_reference_run_matches_golden_features(name, data, resimulated):
    case = next(c for c in data["cases"] if c["name"] == name)
    now = resimulated[name]
    failures = []
    for feature, axis, entry in _entries(case):
        value = now[feature] if axis is None else now[feature][axis]
        expected, tol = entry["reference"], entry["tolerance"]
        if value is None and expected is None:
            continue
        if value is None or expected is None or not abs(value - expected) <= tol:
            diff = "" if value is None or expected is None else f" (off by {value - expected:+.4g})"
            failures.append(f"case {name}, {_label(feature, axis)}: value {value!r}, golden "
                            f"{expected!r}, tolerance {tol!r}{diff}")
    assert not failures, "\n".join(failures) + (
        f"\nIf the model, tire law or analysis changed on purpose, regenerate with: "
        f"{_regenerate()}")
