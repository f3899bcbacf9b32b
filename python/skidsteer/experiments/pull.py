"""Pull tests (Sec. 3.3, 6.2): the testing machine drags the robot by a cable.

The cable (K = 1e6 N/m, D = 4 sqrt(m K), tension only) runs horizontally from a
point above the floor under the robot's chassis to the machine, which moves at
1 mm/s; the wheels are locked (the hubs held) or spinning at a set slip velocity
while a tether holds the robot in x.  The force-distance trace gives the
saw-tooth peaks (static friction) and ramp slopes (tire stiffness).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from scipy import signal

from skidsteer.robot import Setup, load_model, resolve, roles_of
from skidsteer.simulation.drive import DriveGeometry
from skidsteer.simulation.run import LOG_RATE_HZ, rollout, sensor_slice

CABLE_STIFFNESS = 1e6  # N/m, K_cable of Sec. 6.2 (>> K_tire)
MACHINE_SPEED = 1e-3  # m/s, Sec. 3.3 / 6.2: 1 mm/s
CABLE_ANCHOR_DISTANCE = 5.0  # m: the cable stays horizontal within 1e-4 rad
FORCE_RESOLUTION_N = 2.0  # Sec. 4.1: ~2 N "is nearly the accuracy of the force sensor"
SLACK_M = 1e-3  # cable slack at the start: the machine takes it up in 1 s


def _add_spring_cable(spec: mujoco.MjSpec, name: str, chassis: str, robot_pos, anchor_pos,
                      damping: float, pull_only: bool) -> None:
    """A straight tendon from a chassis point to a world point, driven by a
    spring-damper actuator: force = K (ctrl - L) - D dL/dt, ctrl = rest length.
    pull_only clamps the whole force to <= 0, a cable that only pulls (the
    thesis's saturation of the cable force, Sec. 6.1)."""
    spec.body(chassis).add_site(name=f"{name}_robot", pos=list(robot_pos), size=[0.01, 0, 0])
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
               slip_speed: float, chassis: str, axles: list[str]):
    """edit(spec) that adds the testing machine's cable (and locks or a tether)."""
    def edit(spec: mujoco.MjSpec) -> None:
        # the height of the chassis frame, which is at the CoM (Table 5.1)
        com_height = float(spec.body(chassis).pos[2])
        damping = 4 * math.sqrt(mass_estimate * CABLE_STIFFNESS)  # Sec. 6.1: D = 4 sqrt(m K)
        pull = np.array([0.0, 1.0, 0.0]) if direction == "lateral" else np.array([-1.0, 0, 0])
        _add_spring_cable(spec, "cable", chassis, [0, 0, height_m - com_height],
                          CABLE_ANCHOR_DISTANCE * pull + [0, 0, height_m], damping,
                          pull_only=True)
        spec.add_sensor(name="cable_force", type=mujoco.mjtSensor.mjSENS_ACTUATORFRC,
                        objtype=mujoco.mjtObj.mjOBJ_ACTUATOR, objname="cable")
        if wheels == "locked":
            # the motors hold the hubs; belt compliance stays in the tire law (Sec. 3.3).
            # solref time constant 1 ms = 10 steps: stiff enough that the locks add < 1 %
            # to the belts' compliance (longitudinal ramp 11.77 vs 4 K_belt in series with
            # the cable 11.86 kN/m, tests/test_reproduction.py)
            for axle in axles:
                spec.add_equality(type=mujoco.mjtEq.mjEQ_JOINT, name1=axle,
                                  solref=[0.001, 1])
        elif slip_speed != 0:
            # spinning wheels push the robot forward; a stiff two-sided tether at CoM
            # height holds it in place, as the thesis cancels that force (Sec. 6.2)
            _add_spring_cable(spec, "tether", chassis, [0, 0, 0],
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


DEFAULT_SETUP = Setup(build="platform", floor="concrete")  # Sec. 3.3 pulled the platform


def pull(direction: str = "lateral", height_m: float = 0.0, wheels: str = "locked",
         slip_velocity_mps: float = 0.0, *, setup: Setup = DEFAULT_SETUP,
         distance_m: float | None = None, speed_mps: float = MACHINE_SPEED,
         trace_rate_hz: float = 200.0, timestep: float | None = None) -> dict:
    """The testing-machine pull of Sec. 3.3 / 6.2 on the simulated robot.

    The cable (K = 1e6 N/m, D = 4 sqrt(m K), tension only) runs horizontally
    from a point height_m above the floor under the CoM to the machine, which
    moves at speed_mps.  wheels: "locked" (hubs held, Fig. 3.5-3.7, 6.7a) or
    "spinning" (all wheels at slip_velocity_mps / r while a tether holds the
    robot in x, Fig. 3.5 second part, 6.7b).  timestep: the simulation step, s
    (None: the model's).
    """
    if direction not in ("lateral", "longitudinal"):
        raise ValueError(f"unknown pull direction {direction!r}: use lateral or longitudinal")
    if wheels not in ("locked", "spinning"):
        raise ValueError(f"unknown wheel condition {wheels!r}: use locked or spinning")
    if wheels == "spinning" and not slip_velocity_mps > 0:
        raise ValueError("spinning wheels need --slip-velocity > 0 m/s")
    if not 0 <= height_m <= 1.5:
        raise ValueError(f"pull height {height_m} m is outside [0, 1.5] m")
    setup = resolve(setup)
    base = load_model(setup, timestep=timestep)
    parts = roles_of(base)
    chassis = base.body(parts.chassis).name
    axles = [base.joint(w.joint).name for w in parts.wheels]
    mass = float(base.body_subtreemass[parts.chassis])
    m = load_model(setup, edit=_cable_rig(direction, height_m, wheels, mass,
                                          slip_velocity_mps if wheels == "spinning" else 0.0,
                                          chassis, axles), timestep=timestep)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    machine = m.actuator("cable").id
    length0 = float(d.ten_length[m.tendon("cable").id])
    ctrl = np.zeros(m.nu)
    ctrl[machine] = length0 + SLACK_M
    if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, "tether") >= 0:
        tether = m.actuator("tether").id
        ctrl[tether] = float(d.ten_length[m.tendon("tether").id])
    # settle with the cable slack (settle() would command zero cable length)
    rollout(m, d, ctrl, int(round(1.0 / m.opt.timestep)))
    tires = roles_of(m)
    normal_sum = float(d.sensordata[tires.sensor_slice(m, tires.tire_forces, "tire_forces")]
                       .reshape(-1, 3)[:, 0].sum())

    if wheels == "spinning":
        drive = DriveGeometry.from_model(m)
        spin = slip_velocity_mps / drive.wheel_radius
        ctrl[list(drive.left_actuators + drive.right_actuators)] = spin
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
        "build": setup.build, "floor": setup.floor, "variant": setup.variant,
        "machine_speed_mps": speed_mps, "timestep_s": m.opt.timestep, "mass_kg": mass,
        "normal_force_sum_N": normal_sum,
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
