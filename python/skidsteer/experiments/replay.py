"""Replaying a recorded run: its own wheel-speed schedule as the servos' targets.

A recording of a real robot is driven by whatever its operator commanded, not by
one constant swivel.  ``replay`` settles the model, then steps it with each side's
servo target held at the run's wheel speed of the moment (m/s at the rim over the
model's wheel radius, times the rim speed per logged speed the model states,
``skidsteer.drive.logged_speed_scale``), and returns the simulated IMU at the recording's own rate
and clock, through the same anti-aliased decimation a logger applies.
"""

from __future__ import annotations

import mujoco
import numpy as np

from skidsteer.data.imu import ImuRun
from skidsteer.features.signals import decimate
from skidsteer.robot import roles
from skidsteer.simulation import drive
from skidsteer.simulation.drive import DriveGeometry
from skidsteer.simulation.run import get_state, rollout, settle

CHUNK_S = 10.0  # rollout length per call (bounds the memory of the per-step states)


def replay(m: mujoco.MjModel, run: ImuRun, settle_s: float = 2.0) -> ImuRun:
    """The run simulated on m: same clock (time_s), the model's accelerometer and gyro
    decimated to the run's sample rate, the run's wheel speeds.  Raises ValueError
    when the run has no wheel speeds or its rate does not divide the model's."""
    if run.wheels is None:
        raise ValueError(f"{run.path.name}: no wheel speeds to replay")
    dt = m.opt.timestep
    factor = (1.0 / run.sample_rate_hz) / dt
    if abs(factor - round(factor)) > 1e-3 * factor:
        raise ValueError(f"{run.path.name}: its sample step {1 / run.sample_rate_hz:g} s is "
                         f"not a multiple of the model's time step {dt:g} s")
    factor = int(round(factor))
    geometry = DriveGeometry.from_model(m)
    rim_per_logged = roles.model_numeric(m, "drive.logged_speed_scale", 1.0)
    transmission = drive.ripple(m)
    angle = np.zeros(2)  # each side's commanded wheel angle, carried across chunks
    r = roles.roles_of(m)
    accel_slice = r.sensor_slice(m, r.accelerometer, "accelerometer")
    gyro_slice = r.sensor_slice(m, r.gyro, "gyro")
    d = mujoco.MjData(m)
    state = settle(m, d, settle_s)
    t0 = float(run.time_s[0])
    nstep = len(run.time_s) * factor
    accel = np.empty((nstep, 3), np.float32)
    gyro = np.empty((nstep, 3), np.float32)
    chunk = max(1, int(round(CHUNK_S / dt)))
    for start in range(0, nstep, chunk):
        n = min(chunk, nstep - start)
        # step k acts over [k dt, (k+1) dt] and takes the command of its start
        t = t0 + (start + np.arange(n)) * dt
        left, right = run.wheels.at(t)
        ctrl = np.zeros((n, m.nu))
        for side, (speed, actuators) in enumerate(((left, geometry.left_actuators),
                                                   (right, geometry.right_actuators))):
            omega = rim_per_logged * speed / geometry.wheel_radius
            if transmission is not None:
                theta = angle[side] + np.cumsum(omega) * dt
                angle[side] = theta[-1]
                omega = drive.rippled(omega, theta, geometry.wheel_radius, *transmission,
                                      drive.RIPPLE_SIDE_PHASE[side])
            for a in actuators:
                ctrl[:, a] = omega
        states, sensors = rollout(m, d, ctrl, n, state)
        state = get_state(m, d)
        accel[start:start + n] = sensors[:, accel_slice]
        gyro[start:start + n] = sensors[:, gyro_slice]
    # the sample at the end of each recorded interval, anti-aliased: a logger's
    # decimation in stages of at most 10 (scipy.signal.decimate's FIR per stage)
    a, g = accel.astype(float), gyro.astype(float)
    for stage in _stages(factor):
        a, g = decimate(a, stage), decimate(g, stage)
    n = len(run.time_s)
    return ImuRun(run.path, run.time_s.copy(), a[:n], g[:n], run.wheels,
                  terrain=run.terrain, notes=(f"simulated: replay of {run.path.name} on "
                                               f"{m.opt.timestep:g} s steps",))


def _stages(factor: int) -> list[int]:
    """factor as a product of stages of at most 10 (largest first)."""
    out, rest = [], factor
    while rest > 1:
        for s in range(min(10, rest), 1, -1):
            if rest % s == 0:
                out.append(s)
                rest //= s
                break
        else:  # a prime above 10: one stage
            out.append(rest)
            rest = 1
    return out
