"""Swivel in place (Sec. 3.2): the experiment the thesis is about."""

from __future__ import annotations

from skidsteer.features.extract import swivel_features
from skidsteer.robot import Setup, load_model, resolve
from skidsteer.simulation.run import Run, run_commanded

DEFAULT_SETUP = Setup(build="extended", floor="concrete")


def run_swivel(omega_deg_s: float = 30.0, setup: Setup = DEFAULT_SETUP,
               duration_s: float = 20.0, settle_s: float = 2.0,
               timestep: float | None = None) -> Run:
    """Swivel in place at omega_z* deg/s on the setup (the accelerometer where its mount
    says): settled, then the thesis's feed-forward ramped in at the firmware's limits."""
    m = load_model(resolve(setup), timestep=timestep)
    return run_commanded(m, 0.0, omega_deg_s, duration_s, settle_s)


def swivel_summary(run: Run, command: dict) -> dict:
    """What `skidsteer swivel` prints: yaw rate, wheel lift and the Appendix A features."""
    time_s, accel = run.accelerometer_log()
    return {"command": command, "mean_yaw_rate_deg_s": run.mean_yaw_rate_deg_s(),
            "wheel_lift_fraction": run.wheel_lift_fraction(),
            "features": swivel_features(time_s, accel)}
