"""The thesis's experiments on the simulated robot: free response (Sec. 5.2/6.2),
pull tests (Sec. 3.3/6.2), straight line (Fig. 6.8) and swivel in place (Sec. 3.2).

Each returns a JSON-ready dict.  Rigs (the testing machine's cable, locks,
tethers, a wheel-mounted cube) are added to the model spec before compiling,
so every run steps in C through mujoco.rollout.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from scipy import signal

from skidsteer.measured import MOUNTS
from skidsteer.models import load_model
from skidsteer.simulation import (DriveGeometry, LOG_RATE_HZ, Run, decimate, rollout,
                                  run_commanded, sensor_slice, settle)
from skidsteer.tire_reference import NSTATE_WHEEL, find_wheels

GRAVITY = 9.81

# ------------------------------------------------------------------ free response

FREE_RESPONSE_AXES = {"roll": 1, "pitch": 0, "yaw": 1}  # accelerometer axis the thesis read
COMPRESSION_OFFSET_M = 0.001  # Sec. 6.2: z_init = -mg/(4 K_z) -/+ 0.001 m per side
YAW_TWIST_RAD = 0.002  # assumed: "slightly turning the robot" (Sec. 5.2); linear regime
# The free responses' envelope (decay rate) converges at 1e-5 s, not at the models'
# 1e-4 s: standing wheels make eq. 4.12b's lateral factor a ratio of velocity jitters
# (scripts/bench/bench_timestep.py; plugin/tire/README.md#time-step).  5e-6 s agrees
# within 2 %; a 2 s free response at 1e-5 s costs a few seconds.
FREE_RESPONSE_TIMESTEP_S = 1e-5


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
    wheels = find_wheels(m)
    root = int(m.body_rootid[wheels[0].body])
    qadr = int(m.jnt_qposadr[m.body_jntadr[root]])
    mujoco.mj_forward(m, d)
    com = d.subtree_com[root].copy()
    frame = d.xmat[root].reshape(3, 3)
    local = np.array([frame.T @ (d.xpos[w.body] - com) for w in wheels])
    if axis == "roll":
        half_track = float(np.mean(np.abs(local[:, 1])))
        _rotate_about(d, qadr, com, frame[:, 0], COMPRESSION_OFFSET_M / half_track)
    elif axis == "pitch":
        half_base = float(np.mean(np.abs(local[:, 0])))
        _rotate_about(d, qadr, com, frame[:, 1], COMPRESSION_OFFSET_M / half_base)
    elif axis == "yaw":
        for i, (x, y, _) in enumerate(local):
            st = d.plugin_state[i * NSTATE_WHEEL:(i + 1) * NSTATE_WHEEL]
            st[:] = [-y * YAW_TWIST_RAD, 0.0, 1.0, x * YAW_TWIST_RAD, 0.0, 1.0]
    else:
        raise ValueError(f"unknown free-response axis {axis!r}: use roll, pitch or yaw")
    d.qvel[:] = 0
    mujoco.mj_forward(m, d)


def free_response(axis: str = "roll", *, config: str = "extended", surface: str = "concrete",
                  variant: str = "ours", tire: dict | None = None, settle_s: float = 2.0,
                  include_signal: bool = False,
                  timestep: float | None = FREE_RESPONSE_TIMESTEP_S) -> dict:
    """Release as Sec. 6.2, analyse as Sec. 5.2: peak frequency and decay rate.  At the
    converged FREE_RESPONSE_TIMESTEP_S unless timestep says otherwise (None: the
    model's own)."""
    from skidsteer.analysis import FREE_RESPONSE_SAMPLES, free_response_features

    if axis not in FREE_RESPONSE_AXES:
        raise ValueError(f"unknown free-response axis {axis!r}: use roll, pitch or yaw")
    m = load_model(config, surface, tire=tire, variant=variant, timestep=timestep)
    d = mujoco.MjData(m)
    settle(m, d, settle_s)
    release(m, d, axis)
    duration = (FREE_RESPONSE_SAMPLES + 64) / LOG_RATE_HZ
    nstep = int(round(duration / m.opt.timestep))
    states, sensors = rollout(m, d, np.zeros(m.nu), nstep)
    factor = int(round(1 / (m.opt.timestep * LOG_RATE_HZ)))
    accel = decimate(sensors[:, sensor_slice(m, "accelerometer")], factor)
    time_s = (states[::factor, 0] - states[0, 0])[:FREE_RESPONSE_SAMPLES]
    trace = accel[:FREE_RESPONSE_SAMPLES, FREE_RESPONSE_AXES[axis]]
    features = free_response_features(time_s, trace)
    result = {"axis": axis, "accelerometer_axis": "xyz"[FREE_RESPONSE_AXES[axis]],
              "config": config, "surface": surface, "variant": variant,
              "timestep_s": m.opt.timestep, **features}
    if include_signal:
        result["time_s"] = time_s.tolist()
        result["signal_m_s2"] = trace.tolist()
    return result


# ------------------------------------------------------------------ pull test

CABLE_STIFFNESS = 1e6  # N/m, K_cable of Sec. 6.2 (>> K_tire)
MACHINE_SPEED = 1e-3  # m/s, Sec. 3.3 / 6.2: 1 mm/s
CABLE_ANCHOR_DISTANCE = 5.0  # m: the cable stays horizontal within 1e-4 rad
FORCE_RESOLUTION_N = 2.0  # Sec. 4.1: ~2 N "is nearly the accuracy of the force sensor"
SLACK_M = 1e-3  # cable slack at the start: the machine takes it up in 1 s


def _add_spring_cable(spec: mujoco.MjSpec, name: str, robot_pos, anchor_pos,
                      damping: float, pull_only: bool) -> None:
    """A straight tendon from a chassis point to a world point, driven by a
    spring-damper actuator: force = K (ctrl - L) - D dL/dt, ctrl = rest length.
    pull_only clamps the whole force to <= 0, a cable that only pulls (the
    thesis's saturation of the cable force, Sec. 6.1)."""
    spec.body("chassis").add_site(name=f"{name}_robot", pos=list(robot_pos), size=[0.01, 0, 0])
    spec.worldbody.add_site(name=f"{name}_anchor", pos=list(anchor_pos), size=[0.01, 0, 0])
    tendon = spec.add_tendon(name=name)
    tendon.wrap_site(f"{name}_robot")
    tendon.wrap_site(f"{name}_anchor")
    limits = ({"forcelimited": mujoco.mjtLimited.mjLIMITED_TRUE, "forcerange": [-1e9, 0]}
              if pull_only else {})
    spec.add_actuator(name=name, trntype=mujoco.mjtTrn.mjTRN_TENDON, target=name,
                      gainprm=[CABLE_STIFFNESS] + [0] * 9,
                      biastype=mujoco.mjtBias.mjBIAS_AFFINE,
                      biasprm=[0, -CABLE_STIFFNESS, -damping] + [0] * 7, **limits)


def _cable_rig(direction: str, height_m: float, wheels: str, mass_estimate: float,
               slip_speed: float):
    """edit(spec) that adds the testing machine's cable (and locks or a tether)."""
    def edit(spec: mujoco.MjSpec) -> None:
        com_height = float(spec.body("chassis").pos[2])  # chassis frame at the CoM (Table 5.1)
        damping = 4 * math.sqrt(mass_estimate * CABLE_STIFFNESS)  # Sec. 6.1: D = 4 sqrt(m K)
        pull = np.array([0.0, 1.0, 0.0]) if direction == "lateral" else np.array([-1.0, 0, 0])
        _add_spring_cable(spec, "cable", [0, 0, height_m - com_height],
                          CABLE_ANCHOR_DISTANCE * pull + [0, 0, height_m], damping,
                          pull_only=True)
        spec.add_sensor(name="cable_force", type=mujoco.mjtSensor.mjSENS_ACTUATORFRC,
                        objtype=mujoco.mjtObj.mjOBJ_ACTUATOR, objname="cable")
        if wheels == "locked":
            # the motors hold the hubs; belt compliance stays in the tire law (Sec. 3.3).
            # solref time constant 1 ms = 10 steps: stiff enough that the locks add < 1 %
            # to the belts' compliance (longitudinal ramp 11.77 vs 4 K_belt in series with
            # the cable 11.86 kN/m, tests/test_reproduction.py)
            for axle in ("axle1", "axle2", "axle3", "axle4"):
                spec.add_equality(type=mujoco.mjtEq.mjEQ_JOINT, name1=axle,
                                  solref=[0.001, 1])
        elif slip_speed != 0:
            # spinning wheels push the robot forward; a stiff two-sided tether at CoM
            # height holds it in place, as the thesis cancels that force (Sec. 6.2)
            _add_spring_cable(spec, "tether", [0, 0, 0],
                              [-CABLE_ANCHOR_DISTANCE, 0, com_height], damping,
                              pull_only=False)
    return edit


def _teeth_and_slopes(travel: np.ndarray, force: np.ndarray) -> dict:
    """Saw-tooth analysis of a force-distance trace (1 kHz samples)."""
    peaks, _ = signal.find_peaks(force, prominence=FORCE_RESOLUTION_N)
    troughs, _ = signal.find_peaks(-force, prominence=FORCE_RESOLUTION_N)
    slopes = []
    for p in peaks:
        before = troughs[troughs < p]
        start = before[-1] if len(before) else int(np.argmax(force > FORCE_RESOLUTION_N))
        if p - start < 10:
            continue
        # middle 60 % of the rise: away from the release and re-stick transients
        a, b = start + (p - start) // 5, p - (p - start) // 5
        slopes.append(np.polyfit(travel[a:b], force[a:b], 1)[0])
    return {"peaks": peaks, "slopes": np.array(slopes)}


def pull(direction: str = "lateral", height_m: float = 0.0, wheels: str = "locked",
         slip_velocity_mps: float = 0.0, *, config: str = "platform",
         surface: str = "concrete", variant: str = "ours", distance_m: float | None = None,
         speed_mps: float = MACHINE_SPEED, trace_rate_hz: float = 200.0) -> dict:
    """The testing-machine pull of Sec. 3.3 / 6.2 on the simulated robot.

    The cable (K = 1e6 N/m, D = 4 sqrt(m K), tension only) runs horizontally
    from a point height_m above the floor under the CoM to the machine, which
    moves at speed_mps.  wheels: "locked" (hubs held, Fig. 3.5-3.7, 6.7a) or
    "spinning" (all wheels at slip_velocity_mps / r while a tether holds the
    robot in x, Fig. 3.5 second part, 6.7b).
    """
    if direction not in ("lateral", "longitudinal"):
        raise ValueError(f"unknown pull direction {direction!r}: use lateral or longitudinal")
    if wheels not in ("locked", "spinning"):
        raise ValueError(f"unknown wheel condition {wheels!r}: use locked or spinning")
    if wheels == "spinning" and not slip_velocity_mps > 0:
        raise ValueError("spinning wheels need --slip-velocity > 0 m/s")
    if not 0 <= height_m <= 1.5:
        raise ValueError(f"pull height {height_m} m is outside [0, 1.5] m")
    base = load_model(config, surface, variant=variant)
    mass = float(base.body_subtreemass[base.body("chassis").id])
    m = load_model(config, surface, variant=variant,
                   edit=_cable_rig(direction, height_m, wheels, mass,
                                   slip_velocity_mps if wheels == "spinning" else 0.0))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    machine = m.actuator("cable").id
    length0 = float(d.ten_length[m.tendon("cable").id])
    ctrl = np.zeros(m.nu)
    ctrl[machine] = length0 + SLACK_M
    if m.nu > 3:
        tether = m.actuator("tether").id
        ctrl[tether] = float(d.ten_length[m.tendon("tether").id])
    # settle with the cable slack (settle() would command zero cable length)
    rollout(m, d, ctrl, int(round(1.0 / m.opt.timestep)))
    normal_sum = float(d.sensordata[sensor_slice(m, "tire_forces")].reshape(-1, 3)[:, 0].sum())

    if wheels == "spinning":
        drive = DriveGeometry.from_model(m)
        spin = slip_velocity_mps / drive.wheel_radius
        ctrl[drive.left_actuator] = ctrl[drive.right_actuator] = spin
        rollout(m, d, ctrl, int(round(1.0 / m.opt.timestep)))  # wheels up to speed
    if distance_m is None:
        distance_m = 0.010 if wheels == "locked" else 0.006
    duration = (distance_m + SLACK_M) / speed_mps
    nstep = int(round(duration / m.opt.timestep))
    t = np.arange(1, nstep + 1) * m.opt.timestep
    controls = np.tile(ctrl, (nstep, 1))
    controls[:, machine] = length0 + SLACK_M - speed_mps * t
    states, sensors = rollout(m, d, controls, nstep)
    factor = max(1, int(round(1 / (m.opt.timestep * LOG_RATE_HZ))))
    force = -sensors[::factor, sensor_slice(m, "cable_force")][:, 0]
    travel = speed_mps * t[::factor] - SLACK_M  # machine travel since the cable went taut
    taut = travel >= 0
    travel, force = travel[taut], force[taut]

    result = {
        "direction": direction, "height_m": height_m, "wheels": wheels,
        "slip_velocity_mps": slip_velocity_mps if wheels == "spinning" else 0.0,
        "config": config, "surface": surface, "variant": variant,
        "machine_speed_mps": speed_mps, "mass_kg": mass, "normal_force_sum_N": normal_sum,
    }
    saw = _teeth_and_slopes(travel, force)
    peaks = saw["peaks"]
    result.update({
        "first_peak_N": float(force[peaks[0]]) if len(peaks) else None,
        "max_force_N": float(force.max()),
        "teeth": int(len(peaks)),
        "ramp_slope_N_per_m": float(np.median(saw["slopes"])) if len(saw["slopes"]) else None,
        "ramp_slopes_N_per_m": saw["slopes"].tolist(),
        # the last 40 % of the trace: the steady (kinetic) level of Fig. 3.5
        "steady_force_N": float(force[int(0.6 * len(force)):].mean()),
    })
    keep = max(1, int(round(LOG_RATE_HZ / trace_rate_hz)))
    result["trace"] = {"travel_m": travel[::keep].round(7).tolist(),
                       "force_N": force[::keep].round(4).tolist()}
    return result


# ------------------------------------------------------------------ straight line

def straight(speed_mps: float = 1.0, duration_s: float = 6.0, *, config: str = "extended",
             surface: str = "concrete", variant: str = "ours",
             tire: dict | None = None) -> dict:
    """Straight line at v_x* (Fig. 6.8): speed reached, wheel slip, drift."""
    m = load_model(config, surface, tire=tire, variant=variant)
    d = mujoco.MjData(m)
    settle(m, d, 1.0)
    drive = DriveGeometry.from_model(m)
    nstep = int(round(duration_s / m.opt.timestep))
    ctrl = drive.ramp(m, speed_mps, 0.0, nstep)  # at the firmware's TransAccel
    if np.any(np.abs(ctrl[-1]) > m.actuator_ctrlrange[:, 1] + 1e-12):
        raise ValueError(f"speed {speed_mps} m/s needs wheel speeds beyond the motors' "
                         f"ctrlrange {m.actuator_ctrlrange[0].tolist()} rad/s")
    root = m.body("chassis").id
    dof = int(m.jnt_dofadr[m.body_jntadr[root]])
    states, sensors = rollout(m, d, ctrl, nstep)
    nq = m.nq
    qvel = states[:, 1 + nq:1 + nq + m.nv]
    quat = states[:, 1 + 3:1 + 7]
    # body-frame linear velocity of the chassis (free joint qvel is world-frame)
    forward = np.column_stack([1 - 2 * (quat[:, 2]**2 + quat[:, 3]**2),
                               2 * (quat[:, 1] * quat[:, 2] + quat[:, 0] * quat[:, 3]),
                               2 * (quat[:, 1] * quat[:, 3] - quat[:, 0] * quat[:, 2])])
    v_world = qvel[:, dof:dof + 3]
    v_x = np.einsum("ij,ij->i", v_world, forward)
    speeds = np.column_stack([sensors[:, sensor_slice(m, f"wheel{i}_speed")][:, 0]
                              for i in range(1, 5)])
    rim = speeds * drive.wheel_radius
    slip = (rim - v_x[:, None]) / np.maximum(np.abs(rim), 1e-9)  # eq. 2.7 sign: driving > 0
    t = states[:, 0] - states[0, 0]
    steady = t > duration_s - 1.0
    reach = np.argmax(v_x >= 0.9 * speed_mps) if np.any(v_x >= 0.9 * speed_mps) else None
    yaw = np.unwrap(2 * np.arctan2(quat[:, 3], quat[:, 0]))
    return {
        "speed_command_mps": speed_mps, "config": config, "surface": surface,
        "variant": variant, "duration_s": duration_s,
        "mean_speed_mps": float(v_x[steady].mean()),
        "time_to_90_percent_s": float(t[reach]) if reach is not None else None,
        "steady_slip": float(np.abs(slip[steady]).mean()),
        # during the ramp, once the rims move at >= 5 cm/s (a ratio of tiny speeds is noise)
        "peak_slip": float(np.abs(slip[np.abs(rim).min(axis=1) >= 0.05]).max()),
        "heading_drift_deg": float(np.rad2deg(yaw[-1] - yaw[0])),
        "lateral_speed_rms_mps": float(np.sqrt(np.mean(
            (v_world[:, 0] * -forward[:, 1] + v_world[:, 1] * forward[:, 0])[steady] ** 2))),
    }


# ------------------------------------------------------------------ swivel in place

WHEEL_CUBE_POS = (0.06, 0.06, 0.0)  # assumed: on wheel1's outer face, 6 cm off the axle


def _wheel_mount(spec: mujoco.MjSpec) -> None:
    """Moves the accelerometer cube onto wheel 1 (Sec. 3.2: "fixed the wood-cube to one tire")."""
    spec.body("wheel1").add_site(name="accelerometer_wheel", pos=list(WHEEL_CUBE_POS),
                                 size=[0.02, 0.02, 0.02], type=mujoco.mjtGeom.mjGEOM_BOX)
    for name in ("accelerometer", "gyro"):
        spec.sensor(name).objname = "accelerometer_wheel"


def swivel_model(config: str = "extended", surface: str = "concrete", mount: str = "platform",
                 variant: str = "ours", tire: dict | None = None) -> mujoco.MjModel:
    if mount not in MOUNTS:
        raise ValueError(f"unknown accelerometer mount {mount!r}: use platform or wheel")
    return load_model(config, surface, tire=tire, variant=variant,
                      edit=_wheel_mount if mount == "wheel" else None)


def swivel(omega_deg_s: float = 30.0, surface: str = "concrete", duration_s: float = 20.0,
           *, config: str = "extended", mount: str = "platform", variant: str = "ours",
           settle_s: float = 2.0) -> Run:
    """Swivel in place at omega_z* (Sec. 3.2); the accelerometer where mount says."""
    m = swivel_model(config, surface, mount, variant)
    return run_commanded(m, 0.0, omega_deg_s, duration_s, settle_s)


def swivel_summary(run: Run, command: dict) -> dict:
    """What `skidsteer swivel` prints: yaw rate, wheel lift and the Appendix A features."""
    from skidsteer.analysis import swivel_features

    time_s, accel = run.accelerometer_log()
    return {"command": command, "mean_yaw_rate_deg_s": run.mean_yaw_rate_deg_s(),
            "wheel_lift_fraction": run.wheel_lift_fraction(),
            "features": swivel_features(time_s, accel)}
