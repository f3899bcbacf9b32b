"""The thesis's measurements that issue 3 sets as targets: Table 5.2 and Sec. 3.3.

Targets met are asserted; targets our model misses for a documented cause are
strict xfails: they fail the suite if the miss disappears (the report and the
README would then be wrong) and they keep the miss visible in every run.
"""

from __future__ import annotations

import math
import warnings

import pytest

from skidsteer import experiments
from skidsteer.diagnosis.thesis_features import _wheel_components_linear
from skidsteer.diagnosis.thesis_targets import DECAY_TARGET_FACTOR as DECAY_FACTOR_TARGET
from skidsteer.diagnosis.thesis_targets import FREQUENCY_TARGET, SPIN_STEADY_N, TABLE_5_2
from skidsteer.reports.reproduction import MISS_EXPLANATIONS as CAUSES
from skidsteer.robot import Setup

# A strict xfail here is an issue-3 target our model misses for the cause in its
# reason (reported in docs/reproduction/report.md).  Strict: if the target is met one
# day the test fails, because the report, the README and this reason are then stale.
# Each has a companion test that pins the miss to what the report states.
MISSED = "issue 3 target missed (docs/reproduction/report.md); cause: "


@pytest.fixture(scope="module")  # 24 s of free responses: the tests that use it are slow
def free_responses():
    return {axis: experiments.free_response(axis) for axis in ("roll", "pitch", "yaw")}


def _frequency_error(result, axis):
    return abs(result["refined_peak_hz"] / TABLE_5_2[axis]["peak_hz"] - 1)


def _decay_factor(result, axis):
    a, b = result["decay_per_s"], TABLE_5_2[axis]["decay_per_s"]
    return max(a / b, b / a)


@pytest.mark.parametrize("axis", ["pitch", "yaw"])
@pytest.mark.slow
def test_free_response_frequency_within_10_percent_of_table_5_2(free_responses, axis):
    assert _frequency_error(free_responses[axis], axis) <= FREQUENCY_TARGET


@pytest.mark.xfail(strict=True, reason=MISSED + "roll 6.66 Hz vs Table 5.2's 6.04 Hz, +10.2 % "
                   "(target 10 %), the same at 1e-5 s (the free responses' step), 5e-6 s "
                   "and 1e-4 s: " + CAUSES["free_response_roll"])
@pytest.mark.slow
def test_roll_frequency_within_10_percent_of_table_5_2(free_responses):
    assert _frequency_error(free_responses["roll"], "roll") <= FREQUENCY_TARGET


@pytest.mark.slow
def test_roll_frequency_miss_is_a_near_miss(free_responses):
    # the documented miss stays what the report says: above 10 %, below 12 %
    assert 0.10 < _frequency_error(free_responses["roll"], "roll") < 0.12


@pytest.mark.parametrize("axis", ["roll", "pitch"])
@pytest.mark.slow
def test_free_response_decay_within_factor_1_6(free_responses, axis):
    assert _decay_factor(free_responses[axis], axis) <= DECAY_FACTOR_TARGET


@pytest.mark.xfail(strict=True, reason=MISSED + "yaw decay 2.80/s vs Table 5.2's 4.5/s, x1.61 "
                   "(target x1.6), at the free responses' 1e-5 s step and the same at "
                   "5e-6 s (2.79/s), so a narrow miss but not a step artefact (2.60/s "
                   "at 1e-4 s): "
                   + CAUSES["free_response_decay_yaw"])
@pytest.mark.slow
def test_yaw_decay_within_factor_1_6(free_responses):
    assert _decay_factor(free_responses["yaw"], "yaw") <= DECAY_FACTOR_TARGET


@pytest.mark.slow
def test_yaw_decay_miss_is_underdamping(free_responses):
    # the documented miss: yaw decays slower than measured (x1.61), from eq. 6.5's
    # D_x, D_y tuned on roll and pitch only; faster than measured would be another cause
    assert free_responses["yaw"]["decay_per_s"] < TABLE_5_2["yaw"]["decay_per_s"]
    assert DECAY_FACTOR_TARGET < _decay_factor(free_responses["yaw"], "yaw") < 2.0


@pytest.fixture(scope="module")
def lateral_pull():
    return experiments.pull("lateral", 0.0, "locked")  # platform on concrete, at the floor


def test_lateral_pull_first_peak_is_static_friction(lateral_pull):
    # issue 3 target: with the cable at contact height the first peak is mu_s N within 10 %
    mu_s_n = 0.86 * lateral_pull["normal_force_sum_N"]
    assert lateral_pull["first_peak_N"] == pytest.approx(mu_s_n, rel=0.10)
    # and it lies in Sec. 3.3's measured 180-200 N (the platform weighs 225 N)
    assert 180 <= lateral_pull["first_peak_N"] <= 200
    assert lateral_pull["normal_force_sum_N"] == pytest.approx(225, rel=0.01)


def test_lateral_pull_is_a_saw_tooth_with_ramps_between_2k_and_4k(lateral_pull):
    assert lateral_pull["teeth"] >= 5  # 10 mm of travel, ~0.2 mm per tooth
    slope = lateral_pull["ramp_slope_N_per_m"] / 18000.0
    assert 2.0 <= slope <= 4.0  # Sec. 6.2: two to four tire springs in parallel


def test_pull_above_the_tipping_height_tips_before_sliding():
    # rigid-body statics: the robot tips when F h > m g c (c = 0.18 m, Table 5.1), i.e.
    # before sliding (F = mu_s m g) when h > c / mu_s = 0.21 m
    result = experiments.pull("lateral", 0.3, "locked", distance_m=0.006)
    weight = result["normal_force_sum_N"]
    assert result["max_force_N"] < 1.1 * weight * 0.18 / 0.3 < 0.86 * weight


def test_longitudinal_pull_slope_is_four_belts_in_series_with_the_cable():
    result = experiments.pull("longitudinal", 0.0, "locked", distance_m=0.006)
    four_belts = 4 * 3000.0  # K_belt per wheel, eq. 4.13-4.14
    expected = 1 / (1 / four_belts + 1 / experiments.CABLE_STIFFNESS)
    # the ramp before the first breakaway; 5 %: the tires' damping and the robot's small
    # pitch under a cable at the floor
    assert result["max_force_N"] / 0.006 == pytest.approx(expected, rel=0.05)


@pytest.fixture(scope="module")
def spinning_pull():
    return experiments.pull("lateral", 0.0, "spinning", 0.04)


@pytest.mark.xfail(strict=True, reason=MISSED + "steady lateral force 18 N at 0.04 m/s of "
                   "slip vs Sec. 3.3's 20-30 N: " + CAUSES["spin_force"])
def test_spinning_wheels_lateral_force_is_20_to_30_newtons(spinning_pull):
    assert SPIN_STEADY_N[0] <= spinning_pull["steady_force_N"] <= SPIN_STEADY_N[1]


def test_spinning_wheels_lateral_force_miss_is_too_little_friction(spinning_pull):
    # the documented miss: below the measured 20 N, yet above what eq. 4.12b gives a
    # platform sliding steadily at 1 mm/s (mu_y = 0.001 / 0.04 -> 0.025 mu_k N ~ 4.4 N):
    # the rest is the robot's own lateral jitter, as the report states
    weight = spinning_pull["normal_force_sum_N"]
    steady_slide = 0.001 / 0.04 * 0.786 * weight
    assert steady_slide < spinning_pull["steady_force_N"] < SPIN_STEADY_N[0]


def test_spinning_wheels_lateral_force_falls_with_slip():
    slow = experiments.pull("lateral", 0.0, "spinning", 0.002, distance_m=0.004)
    fast = experiments.pull("lateral", 0.0, "spinning", 0.04, distance_m=0.004)
    # eq. 4.12b: mu_y = |v_y| / |Delta v_x| falls with slip; the sliding platform's
    # lateral friction is far below static friction once the wheels spin
    assert fast["steady_force_N"] < 0.5 * slow["steady_force_N"]
    assert fast["steady_force_N"] < 0.2 * 0.86 * fast["normal_force_sum_N"]


def test_straight_line_reaches_the_commanded_speed():
    result = experiments.straight(1.0, 6.0)
    assert result["mean_speed_mps"] == pytest.approx(1.0, rel=0.01)
    assert abs(result["heading_drift_deg"]) < 0.1  # symmetric robot, symmetric command
    assert result["steady_slip"] < 0.01
    # the ramp at the firmware's 0.3 m/s^2 reaches 0.9 m/s after 3 s
    assert result["time_to_90_percent_s"] == pytest.approx(3.0, abs=0.1)


@pytest.mark.slow
def test_thesis_variant_differs_where_it_should():
    ours = experiments.free_response("roll")
    thesis = experiments.free_response("roll", Setup(build="extended", floor="concrete",
                                                     variant="thesis"))
    # eq. 5.10's I_x is 8x eq. 5.1's: the roll mode must be slower, but with the tire
    # springs coupling roll and sway it is not sqrt(8) slower
    ratio = ours["refined_peak_hz"] / thesis["refined_peak_hz"]
    assert 1.1 < ratio < math.sqrt(9.82 / 1.21)


def _wheel_runs(peaks_hz: dict[str, list[float]]) -> dict:
    omegas = [10.0, 20.0, 30.0, 40.0, 50.0, 60.0]
    return {"runs": [{"floor": "concrete", "mount": "wheel", "omega_deg_s": w,
                      "rms_m_s2": {a: 1.0 for a in "xyz"},
                      "top_peaks_hz": {a: [peaks_hz[a][i], None, None] for a in "xyz"}}
                     for i, w in enumerate(omegas)], "skipped": []}


def test_a_peak_that_stays_put_is_not_a_line_moving_with_the_wheels():
    still = [12.5] * 6  # one frequency at every speed: no correlation to read
    moving = [1.0, 2.1, 2.9, 4.2, 5.0, 6.1]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # pearsonr's ConstantInputWarning would raise
        r, linear, text = _wheel_components_linear(
            _wheel_runs({"x": still, "y": moving, "z": still}), "concrete")
        assert linear and r > 0.99 and "(a_y)" in text
        r, linear, _ = _wheel_components_linear(
            _wheel_runs({"x": still, "y": still, "z": still}), "concrete")
        assert r is None and not linear
