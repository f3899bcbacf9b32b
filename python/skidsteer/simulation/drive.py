"""Wheel commands: the thesis's feed-forward (Sec. 6.1) and the firmware's ramps.

A command is (v_x*, omega_z*): forward speed and yaw rate.  Without slip the
wheels of each side turn at (v -/+ c omega) / r (eq. 2.11 inverted); the
robot's firmware ramps a new command in at its acceleration limits.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from skidsteer.robot import roles

# The P3-AT firmware ramps a new velocity command at its acceleration limits
# (ARIA robot parameter file p3at.p: TransAccel 300 mm/s^2, RotAccel 100 deg/s^2;
# assumed to be the thesis robot's settings).  A step in wheel speed would jerk
# the bare wheels (inertia 2.5e-4 kg m^2) at thousands of rad/s^2.
TRANS_ACCEL_MPS2 = 0.3
ROT_ACCEL_DEG_S2 = 100.0


@dataclasses.dataclass(frozen=True)
class DriveGeometry:
    """What the feed-forward controller of Sec. 6.1 needs, read from the model."""

    wheel_radius: float  # r, m
    half_track: float  # c, m (Table 5.1: 0.18)
    left_actuators: tuple[int, ...]  # actuator ids driving the left wheels (rad/s)
    right_actuators: tuple[int, ...]

    @classmethod
    def from_model(cls, m: mujoco.MjModel) -> "DriveGeometry":
        r = roles.roles_of(m)
        radius = float(np.mean([w.radius for w in r.wheels]))
        half_track = float(np.mean(np.abs(r.wheel_position_m[:, 1])))
        return cls(radius, half_track, r.left, r.right)

    def wheel_speeds(self, v_mps: float, omega_rad_s: float) -> tuple[float, float]:
        """eq. 2.11 inverted without slip: the thesis's feed-forward (Sec. 6.1)."""
        c, r = self.half_track, self.wheel_radius
        return (v_mps - c * omega_rad_s) / r, (v_mps + c * omega_rad_s) / r

    def ramp(self, m: mujoco.MjModel, v_mps: float, omega_deg_s: float,
             nstep: int) -> np.ndarray:
        """(nstep, nu) controls: from rest to (v_x*, omega_z*) at the firmware's
        acceleration limits, then held (step k acts over t in [k dt, (k+1) dt])."""
        t = step_times(m, nstep)
        return self.control(m, firmware_ramp(t, v_mps, TRANS_ACCEL_MPS2),
                            np.deg2rad(firmware_ramp(t, omega_deg_s, ROT_ACCEL_DEG_S2)))

    def control(self, m: mujoco.MjModel, v_mps, omega_rad_s) -> np.ndarray:
        """Controls for (v_x*, omega_z*): (nu,) for scalars, (n, nu) for arrays of n."""
        left, right = self.wheel_speeds(np.asarray(v_mps, float), np.asarray(omega_rad_s, float))
        ctrl = np.zeros(np.broadcast(left, right).shape + (m.nu,))
        for a in self.left_actuators:
            ctrl[..., a] = left
        for a in self.right_actuators:
            ctrl[..., a] = right
        return ctrl

    def side_speeds(self, ctrl: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(left, right) wheel speed commands (rad/s) of controls (..., nu)."""
        return ctrl[..., self.left_actuators[0]], ctrl[..., self.right_actuators[0]]


def step_times(m: mujoco.MjModel, nstep: int) -> np.ndarray:
    """The times a command is timed at for steps 0..nstep-1 from rest: step k acts over
    [k dt, (k+1) dt] and takes the command at its end, (k+1) dt."""
    return (np.arange(nstep) + 1) * m.opt.timestep


def firmware_ramp(t, target: float, acceleration: float):
    """The firmware's ramp to a target (Sec. 6.1: the P3-AT limits its accelerations):
    rising at `acceleration` from 0 at t = 0, then held; either sign."""
    return np.sign(target) * np.minimum(abs(target), acceleration * np.maximum(t, 0.0))


# A drivetrain's transmission error (gear mesh, belt teeth): the wheel turns ahead of
# and behind its motor by a small angle that repeats ORDER times per wheel revolution.
# A model states it with <numeric name="skidsteer.drive.ripple_order" data="n"/> and
# <numeric name="skidsteer.drive.ripple_error_m" data="e1 e2 ..."/>: the error's
# amplitude at the rim (m) at n, 2n, ... times the wheel's rotation rate.  The two sides
# are driven by independent motors: their errors are taken in quadrature (assumed: a
# random relative phase puts, on average, half of a line's power in the sides' common
# mode, fore-aft, and half in their difference, yaw).
RIPPLE_SIDE_PHASE = (0.0, np.pi / 2)  # left, right


def ripple(m: mujoco.MjModel) -> tuple[float, np.ndarray] | None:
    """(order, rim error amplitudes per harmonic, m) the model states, None without."""
    i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_NUMERIC, "skidsteer.drive.ripple_order")
    j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_NUMERIC, "skidsteer.drive.ripple_error_m")
    if i < 0 or j < 0:
        return None
    order = float(m.numeric_data[m.numeric_adr[i]])
    errors = np.array(m.numeric_data[m.numeric_adr[j]:m.numeric_adr[j] + m.numeric_size[j]])
    return (order, errors) if order > 0 and np.any(errors) else None


def rippled(omega_rad_s: np.ndarray, angle_rad: np.ndarray, radius_m: float, order: float,
            errors_m: np.ndarray, phase: float) -> np.ndarray:
    """A side's speed target with its transmission error: omega (1 + sum_k (e_k / r) k n
    cos(k n angle + phase)), angle the side's commanded wheel angle: the speed of a
    wheel that lags its motor by (e_k / r) sin(k n angle + phase)."""
    out = np.array(omega_rad_s, float)
    for k, e in enumerate(errors_m, start=1):
        out += omega_rad_s * (e / radius_m) * k * order * np.cos(k * order * angle_rad + phase)
    return out
