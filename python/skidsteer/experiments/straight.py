"""Straight line at constant speed (Fig. 6.8): the speed reached, wheel slip, drift."""

from __future__ import annotations

import mujoco
import numpy as np

from skidsteer.robot import Setup, load_model, resolve, roles_of
from skidsteer.simulation.drive import DriveGeometry
from skidsteer.simulation.run import rollout, settle

DEFAULT_SETUP = Setup(build="extended", floor="concrete")


def straight(speed_mps: float = 1.0, duration_s: float = 6.0, *,
             setup: Setup = DEFAULT_SETUP, tire: dict | None = None,
             timestep: float | None = None) -> dict:
    """Straight line at v_x* (Fig. 6.8), ramped in at the firmware's 0.3 m/s^2: the mean
    speed of the last second, the time to 90 % of the command, the wheels' slip (eq.
    2.7), the heading drift and the lateral speed."""
    setup = resolve(setup)
    m = load_model(setup, tire=tire, timestep=timestep)
    d = mujoco.MjData(m)
    settle(m, d, 1.0)
    drive = DriveGeometry.from_model(m)
    nstep = int(round(duration_s / m.opt.timestep))
    ctrl = drive.ramp(m, speed_mps, 0.0, nstep)  # at the firmware's TransAccel
    if np.any(np.abs(ctrl[-1]) > m.actuator_ctrlrange[:, 1] + 1e-12):
        raise ValueError(f"speed {speed_mps} m/s needs wheel speeds beyond the motors' "
                         f"ctrlrange {m.actuator_ctrlrange[0].tolist()} rad/s")
    parts = roles_of(m)
    root_joint = int(m.body_jntadr[parts.chassis])
    dof, qadr = int(m.jnt_dofadr[root_joint]), int(m.jnt_qposadr[root_joint])
    states, _ = rollout(m, d, ctrl, nstep)
    nq = m.nq
    qvel = states[:, 1 + nq:1 + nq + m.nv]
    quat = states[:, 1 + qadr + 3:1 + qadr + 7]
    # body-frame linear velocity of the chassis (free joint qvel is world-frame)
    forward = np.column_stack([1 - 2 * (quat[:, 2]**2 + quat[:, 3]**2),
                               2 * (quat[:, 1] * quat[:, 2] + quat[:, 0] * quat[:, 3]),
                               2 * (quat[:, 1] * quat[:, 3] - quat[:, 0] * quat[:, 2])])
    v_world = qvel[:, dof:dof + 3]
    v_x = np.einsum("ij,ij->i", v_world, forward)
    # the wheels' speeds at the same instants (end of each step) as the chassis's
    speeds = qvel[:, [int(m.jnt_dofadr[w.joint]) for w in parts.wheels]]
    rim = speeds * drive.wheel_radius
    slip = (rim - v_x[:, None]) / np.maximum(np.abs(rim), 1e-9)  # eq. 2.7 sign: driving > 0
    t = states[:, 0] - states[0, 0]
    steady = t > duration_s - 1.0
    reach = np.argmax(v_x >= 0.9 * speed_mps) if np.any(v_x >= 0.9 * speed_mps) else None
    yaw = np.unwrap(2 * np.arctan2(quat[:, 3], quat[:, 0]))
    return {
        "speed_command_mps": speed_mps, "build": setup.build, "floor": setup.floor,
        "variant": setup.variant, "duration_s": duration_s, "timestep_s": m.opt.timestep,
        "mean_speed_mps": float(v_x[steady].mean()),
        "time_to_90_percent_s": float(t[reach]) if reach is not None else None,
        "steady_slip": float(np.abs(slip[steady]).mean()),
        # during the ramp, once the rims move at >= 5 cm/s (a ratio of tiny speeds is noise)
        "peak_slip": float(np.abs(slip[np.abs(rim).min(axis=1) >= 0.05]).max()),
        "heading_drift_deg": float(np.rad2deg(yaw[-1] - yaw[0])),
        "lateral_speed_rms_mps": float(np.sqrt(np.mean(
            (v_world[:, 0] * -forward[:, 1] + v_world[:, 1] * forward[:, 0])[steady] ** 2))),
    }
