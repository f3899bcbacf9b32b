"""The calm-swivel baseline: a soft start against the thesis's feed-forward."""

from __future__ import annotations

import numpy as np
import pytest

import skidsteer  # noqa: F401  (registers the tire plugin)
from skidsteer import tasks
from skidsteer.robot import load_model
from skidsteer.tasks import calm_swivel
from skidsteer.tasks.pioneer3at import feedforward_action


@pytest.mark.parametrize("omega", [2.0, 30.0, -64.0])
def test_soft_start_commands_the_feedforward_mean_without_a_jerk_step(omega):
    dt = 1e-4
    t = (np.arange(int(calm_swivel.RUN_S / dt)) + 1) * dt
    soft = calm_swivel.soft_start_command(t, omega)
    ff = calm_swivel.feedforward_command(t, omega)
    # same mean command over the run (exact up to the time grid's 1e-4 s)
    assert soft.mean() == pytest.approx(ff.mean(), rel=1e-3)
    # starts from rest with zero acceleration, reaches its final rate with zero acceleration
    accel = np.diff(soft) / dt
    assert soft[0] == pytest.approx(0.0, abs=1e-6 * abs(omega))
    assert abs(accel[0]) < 1e-3 * abs(omega) and abs(accel[-1]) == 0.0
    assert np.sign(soft[-1]) == np.sign(omega)


def test_soft_start_needs_time_to_finish_within_the_run():
    with pytest.raises(ValueError, match="soft_start_s"):
        calm_swivel.soft_start_final_rate(30.0, run_s=20.0, soft_start_s=25.0)


def test_soft_start_calms_the_swivel_at_the_same_mean_yaw_rate():
    m = load_model("extended", "concrete")
    r = calm_swivel.run_controllers(m, 30.0)
    ff, soft = r["feedforward"], r["soft_start"]
    # the comparison: the same mean yaw rate within 5 % (measured +0.5 %)
    assert soft["mean_yaw_rate_deg_s"] == pytest.approx(ff["mean_yaw_rate_deg_s"],
                                                        rel=calm_swivel.MEAN_YAW_TOLERANCE)
    # the start-up jolt on a_y is the thesis amplitude of both (largest axis)
    for run in (ff, soft):
        assert max(run["amplitude_m_s2"], key=run["amplitude_m_s2"].get) == "y"
    # measured: 0.672 -> 0.316 m/s^2 (53 % less); a third is the README's claim for
    # 30 deg/s, with room for the integrator and platform-dependent rounding
    assert soft["amplitude_m_s2"]["y"] <= (1 - 1 / 3) * ff["amplitude_m_s2"]["y"]


def test_soft_start_policy_shakes_the_task_less_than_the_feedforward():
    seconds = 5.0  # the jolt comes within 1 s; the soft start ends at 4 s

    def peak_vibration(policy):
        env = tasks.load("pioneer3at", "swivel_smooth",
                         task_kwargs=dict(omega_deg_s=30.0, time_limit=seconds, random=0))
        step, peak = env.reset(), 0.0
        while not step.last():
            step = env.step(policy(step, env))
            peak = max(peak, float(step.observation["vibration"][0]))
        return peak

    ff = peak_vibration(lambda step, env: feedforward_action(env.physics, 30.0))
    soft = peak_vibration(calm_swivel.SoftStartPolicy(30.0))
    assert soft < 0.7 * ff, (soft, ff)
