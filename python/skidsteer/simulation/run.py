"""Simulating the robot: settling on its tires, open-loop wheel commands, swivel in place.

Runs step in C through mujoco.rollout (no per-step Python); the state handed
between phases is mjSTATE_FULLPHYSICS, which includes the tire plugin's state.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import mujoco
import mujoco.rollout
import numpy as np

from skidsteer.features.signals import decimate
from skidsteer.robot import roles, tire
from skidsteer.simulation.drive import DriveGeometry

FULLPHYSICS = mujoco.mjtState.mjSTATE_FULLPHYSICS
LOG_RATE_HZ = 1000.0  # the thesis's accelerometer sample rate (Sec. 3.2)


def get_state(m: mujoco.MjModel, d: mujoco.MjData) -> np.ndarray:
    state = np.empty(mujoco.mj_stateSize(m, FULLPHYSICS))
    mujoco.mj_getState(m, d, state, FULLPHYSICS)
    return state


def set_state(m: mujoco.MjModel, d: mujoco.MjData, state: np.ndarray) -> None:
    mujoco.mj_setState(m, d, state, FULLPHYSICS)
    mujoco.mj_forward(m, d)


def rollout(m: mujoco.MjModel, d: mujoco.MjData, control: np.ndarray, nstep: int,
            initial_state: np.ndarray | None = None):
    """(states, sensordata) of nstep steps under control (nu,) or (nstep, nu).

    Leaves d at the final state.
    """
    if initial_state is None:
        initial_state = get_state(m, d)
    control = np.asarray(control, dtype=float)
    if control.ndim == 1:
        control = np.broadcast_to(control, (nstep, m.nu))
    states, sensors = mujoco.rollout.rollout(m, d, initial_state, control[None], nstep=nstep)
    set_state(m, d, states[0, -1])
    return states[0], sensors[0]


def settle(m: mujoco.MjModel, d: mujoco.MjData, duration_s: float = 2.0) -> np.ndarray:
    """Lets the robot come to rest on its tires with the motors holding zero speed."""
    nstep = int(round(duration_s / m.opt.timestep))
    if nstep > 0:
        rollout(m, d, np.zeros(m.nu), nstep)
    return get_state(m, d)


def trial_start(m: mujoco.MjModel, rng: np.random.Generator, settle_s: float = 2.0
                ) -> np.ndarray:
    """A repeat trial's settled start state: where a previous swivel left the robot.

    A swivel turns the robot in place by a yaw and its wheels by a number of turns
    that is not whole, so a real dataset's trials start at a yaw and at wheel angles
    nobody chose: here both are uniform in [0, 2 pi), the left wheels turned by minus
    the angle of the right ones (a swivel turns the sides opposite ways, and the front
    and rear wheel of a side alike, so the wheels' relative phases are kept).  On a
    flat floor with round wheels this changes nothing; on an uneven floor the wheels
    stand on other spots, and out-of-round wheels start at other phases, so the
    trials' spread shows how much of a start-up depends on them (a run-out's start-up
    moves by several trial spreads with the wheels' angle alone)."""
    d = mujoco.MjData(m)
    yaw, wheel_angle = rng.uniform(0.0, 2 * np.pi, 2)
    parts = roles.roles_of(m)
    base = int(m.body_jntadr[parts.chassis])  # the wheels' root body's first joint
    if base < 0 or m.jnt_type[base] != mujoco.mjtJoint.mjJNT_FREE:
        raise ValueError(f"trial_start needs the robot's base body "
                         f"{m.body(parts.chassis).name!r} on a free joint")
    quat = d.qpos[m.jnt_qposadr[base] + 3:m.jnt_qposadr[base] + 7]
    turned = np.empty(4)
    mujoco.mju_mulQuat(turned, np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]), quat)
    quat[:] = turned
    for wheel, side in zip(parts.wheels, parts.wheel_side):  # side: +1 left, -1 right
        d.qpos[m.jnt_qposadr[wheel.joint]] -= side * wheel_angle
    mujoco.mj_forward(m, d)
    return settle(m, d, settle_s)


def sensor_slice(m: mujoco.MjModel, name: str) -> slice:
    """The sensordata slice of the sensor called name."""
    s = m.sensor(name)
    return slice(int(s.adr[0]), int(s.adr[0] + s.dim[0]))


@dataclasses.dataclass
class Run:
    """A simulated run, sampled every time step."""

    time_s: np.ndarray  # (n,)
    accel: np.ndarray  # (n, 3) m/s^2, cube axes, specific force (gravity included)
    gyro: np.ndarray  # (n, 3) rad/s, cube axes
    wheel_speed: np.ndarray  # (n, nwheel) rad/s, the axles' speeds (end of each step)
    tire_forces: np.ndarray  # (n, nwheel, 3) [N, f_x, f_y] in N (NaN: no tire_forces sensor)
    command: np.ndarray  # (nu,) the constant control

    @property
    def sample_rate_hz(self) -> float:
        return float(1 / (self.time_s[1] - self.time_s[0]))

    def accelerometer_log(self, rate_hz: float = LOG_RATE_HZ) -> tuple[np.ndarray, np.ndarray]:
        """(time_s, accel) at rate_hz, as a logger with an anti-aliasing filter records it."""
        factor = self.sample_rate_hz / rate_hz
        if abs(factor - round(factor)) > 1e-6 or round(factor) < 1:
            raise ValueError(f"log rate {rate_hz} Hz does not divide the simulation rate "
                             f"{self.sample_rate_hz:g} Hz")
        factor = int(round(factor))
        return self.time_s[::factor], decimate(self.accel, factor)

    def mean_yaw_rate_deg_s(self) -> float:
        return float(np.rad2deg(self.gyro[:, 2].mean()))

    def wheel_lift_fraction(self) -> float:
        """Fraction of samples in which at least one wheel carries no load."""
        return float((self.tire_forces[:, :, 0] <= 0).any(axis=1).mean())


def _run_from_rollout(m: mujoco.MjModel, states: np.ndarray, sensors: np.ndarray,
                      ctrl: np.ndarray, t0: float) -> Run:
    nstep = len(states)
    r = roles.roles_of(m)
    # wheel speeds: the axles' velocities in the end-of-step states (FULLPHYSICS: time,
    # qpos, qvel, ...)
    dofs = [1 + m.nq + int(m.jnt_dofadr[w.joint]) for w in r.wheels]
    tires = (sensors[:, r.sensor_slice(m, r.tire_forces, "tire_forces")].reshape(nstep, -1, 3)
             if r.tire_forces is not None else np.full((nstep, len(r.wheels), 3), np.nan))
    return Run(
        time_s=states[:, 0] - t0,  # state starts with time in FULLPHYSICS
        accel=sensors[:, r.sensor_slice(m, r.accelerometer, "accelerometer")].copy(),
        gyro=(sensors[:, r.sensor_slice(m, r.gyro, "gyro")].copy() if r.gyro is not None
              else np.full((nstep, 3), np.nan)),
        wheel_speed=states[:, dofs].copy(),
        tire_forces=tires.copy(),
        command=ctrl,
    )


def run_commanded(m: mujoco.MjModel, v_mps: float, omega_deg_s: float, duration_s: float,
                  settle_s: float = 2.0, d: mujoco.MjData | None = None) -> Run:
    """Settles the robot (from d's state when given), then drives it open loop at
    (v_x*, omega_z*) for duration_s, the command ramped in at the firmware's
    acceleration limits (DriveGeometry.ramp)."""
    d = d if d is not None else mujoco.MjData(m)
    return run_from_settled(m, settle(m, d, settle_s), v_mps, omega_deg_s, duration_s)


TRIAL_DEFLECTION_M = 1e-4  # assumed: 0.1 mm of tire deflection left over from placing the robot


def perturbed(m: mujoco.MjModel, state: np.ndarray, seed: int | Sequence[int] | None
              ) -> np.ndarray:
    """A repeat trial's initial state: the settled state plus random residual tire
    deflections (N(0, TRIAL_DEFLECTION_M) per wheel and direction), the way a robot
    put down by hand never starts twice from the same tire state.  seed: an int or a
    sequence of ints (numpy's default_rng); None: as is."""
    if seed is None:
        return state
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, state, FULLPHYSICS)
    rng = np.random.default_rng(seed)
    deflection = tire.TireState(m, d.plugin_state, tire.instance_id(m)).deflection
    # one draw per wheel and direction, in the state's order (wheel, then x, y)
    deflection += rng.normal(0, TRIAL_DEFLECTION_M, deflection.size).reshape(deflection.shape)
    return get_state(m, d)


def run_batch(models: list[mujoco.MjModel], commands: list[tuple[float, float]],
              duration_s: float, settle_s: float = 2.0, nthread: int = 2,
              seeds: list[int | None] | None = None) -> list[Run]:
    """Runs i: models[i] settled, then driven at commands[i] = (v_x*, omega_z* deg/s),
    from the settled state perturbed by seeds[i] (see perturbed).

    Runs sharing a model object step together in one mujoco.rollout call on
    nthread threads; settling is done once per model.  Runs of different models
    are not mixed in one call: rollout would step them with MjData made from one
    model, and the tire plugin keeps its attributes (the floor) in the plugin
    data of the MjData it was initialised for.
    """
    if len(models) != len(commands):
        raise ValueError("one command per model")
    nstep = int(round(duration_s / models[0].opt.timestep))
    runs: list[Run | None] = [None] * len(models)
    groups: dict[int, list[int]] = {}
    for i, m in enumerate(models):
        groups.setdefault(id(m), []).append(i)
    for indices in groups.values():
        m = models[indices[0]]
        drive = DriveGeometry.from_model(m)
        controls = np.stack([drive.ramp(m, commands[i][0], commands[i][1], nstep)
                             for i in indices])
        group_runs = runs_from_rest(m, controls, settle_s, nthread,
                                    [seeds[i] for i in indices] if seeds else None)
        for i, run in zip(indices, group_runs):
            runs[i] = run
    return runs  # type: ignore[return-value]


def runs_from_rest(m: mujoco.MjModel, controls: np.ndarray, settle_s: float = 2.0,
                   nthread: int = 2, seeds: list[int | None] | None = None,
                   settled: np.ndarray | None = None) -> list[Run]:
    """One run per (nstep, nu) control sequence in controls (k, nstep, nu), each from the
    model settled once (settle_s; or the given settled state), perturbed by seeds[k]
    (see perturbed), stepped in one mujoco.rollout call on nthread threads."""
    if settled is None:
        settled = settle(m, mujoco.MjData(m), settle_s)
    initial = np.stack([perturbed(m, settled, seeds[k] if seeds else None)
                        for k in range(len(controls))])
    datas = [mujoco.MjData(m) for _ in range(max(1, min(nthread, len(controls))))]
    states, sensors = mujoco.rollout.rollout(m, datas, initial, controls,
                                             nstep=controls.shape[1])
    return [_run_from_rollout(m, states[k], sensors[k], controls[k, -1], initial[k, 0])
            for k in range(len(controls))]


def run_from_settled(m: mujoco.MjModel, settled: np.ndarray, v_mps: float, omega_deg_s: float,
                     duration_s: float, seed: int | None = None) -> Run:
    """One run on one thread: from the settled state (perturbed by seed), driven at
    (v_x*, omega_z* deg/s) ramped in at the firmware's limits (DriveGeometry.ramp).  The
    unit of work of sweeps and diagnoses on any backend (simulation.backends)."""
    nstep = int(round(duration_s / m.opt.timestep))
    ctrl = DriveGeometry.from_model(m).ramp(m, v_mps, omega_deg_s, nstep)
    return runs_from_rest(m, ctrl[None], nthread=1, seeds=[seed], settled=settled)[0]


def swivel(m: mujoco.MjModel, omega_deg_s: float, duration_s: float = 20.0,
           settle_s: float = 2.0) -> Run:
    """Swivel in place (v_x* = 0) at omega_z* deg/s, as in Sec. 3.2."""
    return run_commanded(m, 0.0, omega_deg_s, duration_s, settle_s)
