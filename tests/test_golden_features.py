"""Golden swivel features: re-simulated reference runs match tests/golden/swivel_features.json.

The golden file (scripts/make_golden_features.py) holds, for a few swivels in
place of our model and of the thesis-as-published variant, per case and
accelerometer axis either

  vibrating: the reference run and every seeded repeat reach the report's
    vibration floor (1-50 Hz RMS >= VIBRATION_FLOOR_M_S2): the robust Appendix A
    / Sec. 3.2 band features of the reference run (settled start, no
    perturbation), each with a tolerance max(3 sigma of the repeats, the
    measurement resolution); or
  quiet: no peaks to compare (below the floor they are numerical residue);
    the re-simulated reference must stay below the floor,

and the mean yaw rate of every case.  Here the reference runs are simulated
again (the cases sharing a model in one batch: 8 runs of 22 s simulated).
Features listed under a case's "excluded" (with their measured spread and the
reason) are neither compared nor sanity-checked.
"""

from __future__ import annotations

import json

import mujoco
import pytest

from conftest import REPO
import make_golden_features as golden

GOLDEN = REPO / "tests" / "golden" / "swivel_features.json"


def _load() -> dict:
    return json.loads(GOLDEN.read_text())


def _regenerate() -> str:
    trials = _load()["provenance"].get("trials", 8) if GOLDEN.is_file() else 8
    return golden.regenerate_command(GOLDEN.relative_to(REPO), trials)


CASE_NAMES = [c["name"] for c in _load()["cases"]] if GOLDEN.is_file() else []


def _compared(case: dict):
    """(feature, axis or None, entry) of every compared feature of a golden case:
    the band features of its vibrating axes, then the scalar features."""
    for axis, record in case["axes"].items():
        if record["status"] == "vibrating":
            for feature, entry in record["features"].items():
                yield feature, axis, entry
    for feature, entry in case["features"].items():
        yield feature, None, entry


def _label(feature: str, axis: str | None) -> str:
    return feature if axis is None else f"{feature} axis {axis}"


@pytest.fixture(scope="module")
def data() -> dict:
    if not GOLDEN.is_file():
        pytest.fail(f"{GOLDEN} is missing; generate it with: {_regenerate()}")
    data = _load()
    if data.get("schema") != golden.SCHEMA:
        pytest.fail(f"{GOLDEN.name} has schema {data.get('schema')}, the generator writes "
                    f"{golden.SCHEMA}; regenerate with: {_regenerate()}")
    return data


@pytest.fixture(scope="module")  # 35 s of swivels: the test that uses it is slow
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


def test_golden_file_uses_the_report_vibration_floor(data):
    for case in data["cases"]:
        assert case["vibration_floor_m_s2"] == golden.VIBRATION_FLOOR_M_S2, (
            f"case {case['name']}: vibrating / quiet axes were decided with a floor of "
            f"{case['vibration_floor_m_s2']} m/s^2, skidsteer.reports.reproduction now has "
            f"{golden.VIBRATION_FLOOR_M_S2}; regenerate with: {_regenerate()}")


def test_golden_tolerances_are_meaningful(data):
    """Only the compared features: quiet axes and excluded features have no tolerance."""
    problems = []
    for case in data["cases"]:
        for feature, axis, entry in _compared(case):
            problem = golden.sanity_problem(feature, entry)
            if problem:
                problems.append(
                    f"case {case['name']}, {_label(feature, axis)}: {problem} (repeats "
                    f"{entry['repeat_min']!r}..{entry['repeat_max']!r}, std "
                    f"{entry['repeat_std']!r}); replace the case (scripts/"
                    "make_golden_features.py CASES) or, with the reason, name the feature "
                    "in EXCLUDED, and regenerate")
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("name", CASE_NAMES)
@pytest.mark.slow
def test_reference_run_matches_golden_features(name, data, resimulated):
    case = next(c for c in data["cases"] if c["name"] == name)
    now = resimulated[name]
    floor = case["vibration_floor_m_s2"]
    failures = []
    for axis, record in case["axes"].items():
        rms = now[golden.RMS][axis]
        if record["status"] == "quiet" and not (rms is not None and rms < floor):
            failures.append(
                f"case {name}, axis {axis}: golden quiet (reference RMS "
                f"{record['rms_reference_m_s2']:.3g}, repeats up to "
                f"{record['rms_repeat_max_m_s2']:.3g} m/s^2), now vibrates: 1-50 Hz RMS "
                f"{rms!r} >= the {floor} m/s^2 floor")
    for feature, axis, entry in _compared(case):
        value = now[feature] if axis is None else now[feature][axis]
        expected, tol = entry["reference"], entry["tolerance"]
        if value is None or expected is None or not abs(value - expected) <= tol:
            diff = "" if value is None or expected is None else f" (off by {value - expected:+.4g})"
            failures.append(f"case {name}, {_label(feature, axis)}: value {value!r}, golden "
                            f"{expected!r}, tolerance {tol!r}{diff}")
    assert not failures, "\n".join(failures) + (
        f"\nIf the model, tire law or analysis changed on purpose, regenerate with: "
        f"{_regenerate()}")
