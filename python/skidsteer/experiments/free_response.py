"""Free response (Sec. 5.2, 6.2): the robot released from a tilt or a twist rings down.

Released as Sec. 6.2 (tires +-1 mm about equilibrium for roll and pitch; the tires
deflected as by a small twist for yaw), analysed as Sec. 5.2 (first 2^11 samples,
20 Hz low-pass): the peak frequency and decay rate of Table 5.2.
"""

from __future__ import annotations

import mujoco
import numpy as np

from skidsteer.features.extract import FREE_RESPONSE_SAMPLES, free_response_features
from skidsteer.features.signals import decimate
from skidsteer.robot import Setup, load_model, resolve, roles_of, tire
from skidsteer.simulation.run import LOG_RATE_HZ, rollout, settle

FREE_RESPONSE_AXES = {"roll": 1, "pitch": 0, "yaw": 1}  # accelerometer axis the thesis read
COMPRESSION_OFFSET_M = 0.001  # Sec. 6.2: z_init = -mg/(4 K_z) -/+ 0.001 m per side
YAW_TWIST_RAD = 0.002  # assumed: "slightly turning the robot" (Sec. 5.2); linear regime
# The free responses' envelope (decay rate) converges at 1e-5 s, not at the models'
# 1e-4 s: standing wheels make eq. 4.12b's lateral factor a ratio of velocity jitters
# (scripts/bench/bench_timestep.py; plugin/tire/README.md#time-step).  5e-6 s agrees
# within 2 %; a 2 s free response at 1e-5 s costs a few seconds.
FREE_RESPONSE_TIMESTEP_S = 1e-5
DEFAULT_SETUP = Setup(build="extended", floor="concrete")


def _rotate_about(d: mujoco.MjData, root_qpos: int, center: np.ndarray, axis: np.ndarray,
                  angle: float) -> None:
    """Rotates a free body's pose by angle about a world axis through center."""
    quat = np.empty(4)
    mujoco.mju_axisAngle2Quat(quat, axis, angle)
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, quat)
    pos = d.qpos[root_qpos:root_qpos + 3]
    d.qpos[root_qpos:root_qpos + 3] = center + rot.reshape(3, 3) @ (pos - center)
    new = np.empty(4)
    mujoco.mju_mulQuat(new, quat, d.qpos[root_qpos + 3:root_qpos + 7].copy())
    d.qpos[root_qpos + 3:root_qpos + 7] = new


def release(m: mujoco.MjModel, d: mujoco.MjData, axis: str) -> None:
    """Sets the settled robot d to the initial condition of a free response.

    roll/pitch: the pose rotated about the CoM so that one side's (front's)
    tires are 1 mm more compressed and the other's 1 mm less (Sec. 6.2);
    yaw: the tires deflected as by a twist of YAW_TWIST_RAD about the CoM,
    contact points sticking (Sec. 5.2: "slightly turning the robot").
    """
    r = roles_of(m)
    root = r.chassis
    qadr = int(m.jnt_qposadr[m.body_jntadr[root]])
    mujoco.mj_forward(m, d)
    com = d.subtree_com[root].copy()
    frame = d.xmat[root].reshape(3, 3)
    local = np.array([frame.T @ (d.xpos[w.body] - com) for w in r.wheels])
    if axis == "roll":
        half_track = float(np.mean(np.abs(local[:, 1])))
        _rotate_about(d, qadr, com, frame[:, 0], COMPRESSION_OFFSET_M / half_track)
    elif axis == "pitch":
        half_base = float(np.mean(np.abs(local[:, 0])))
        _rotate_about(d, qadr, com, frame[:, 1], COMPRESSION_OFFSET_M / half_base)
    elif axis == "yaw":
        state = tire.TireState(m, d.plugin_state, tire.instance_id(m))
        state.reset()  # contact points at rest and sticking
        # a twist theta about the CoM moves the contact of a wheel at (x, y) by
        # theta (-y, x): longitudinal -y theta, lateral x theta
        state.deflection[:, 0] = -local[:, 1] * YAW_TWIST_RAD
        state.deflection[:, 1] = local[:, 0] * YAW_TWIST_RAD
    else:
        raise ValueError(f"unknown free-response axis {axis!r}: use roll, pitch or yaw")
    d.qvel[:] = 0
    mujoco.mj_forward(m, d)


def free_response(axis: str = "roll", setup: Setup = DEFAULT_SETUP, *,
                  tire: dict | None = None, settle_s: float = 2.0,
                  include_signal: bool = False,
                  timestep: float | None = FREE_RESPONSE_TIMESTEP_S,
                  edit=None) -> dict:
    """Release as Sec. 6.2, analyse as Sec. 5.2: peak frequency and decay rate.  At the
    converged FREE_RESPONSE_TIMESTEP_S unless timestep says otherwise (None: the
    model's own).  edit: an MjSpec edit applied before compiling (a cause's, e.g.)."""
    if axis not in FREE_RESPONSE_AXES:
        raise ValueError(f"unknown free-response axis {axis!r}: use roll, pitch or yaw")
    setup = resolve(setup)
    m = load_model(setup, tire=tire, timestep=timestep, edit=edit)
    d = mujoco.MjData(m)
    settle(m, d, settle_s)
    release(m, d, axis)
    duration = (FREE_RESPONSE_SAMPLES + 64) / LOG_RATE_HZ
    nstep = int(round(duration / m.opt.timestep))
    states, sensors = rollout(m, d, np.zeros(m.nu), nstep)
    factor = int(round(1 / (m.opt.timestep * LOG_RATE_HZ)))
    r = roles_of(m)
    accel = decimate(sensors[:, r.sensor_slice(m, r.accelerometer, "accelerometer")], factor)
    time_s = (states[::factor, 0] - states[0, 0])[:FREE_RESPONSE_SAMPLES]
    trace = accel[:FREE_RESPONSE_SAMPLES, FREE_RESPONSE_AXES[axis]]
    features = free_response_features(time_s, trace)
    result = {"axis": axis, "accelerometer_axis": "xyz"[FREE_RESPONSE_AXES[axis]],
              "build": setup.build, "floor": setup.floor, "variant": setup.variant,
              "timestep_s": m.opt.timestep, **features}
    if include_signal:
        result["time_s"] = time_s.tolist()
        result["signal_m_s2"] = trace.tolist()
    return result
