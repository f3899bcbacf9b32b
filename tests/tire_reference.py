"""A readable Python reference of the skidsteer.tire law, for the tests (slow).

Same law, same conventions and same order of operations as
plugin/tire/tire_law.c and the kinematics of plugin/tire/tire_plugin.c.  The
tests drive the C plugin and this reference with the same random inputs and
require them to agree to ~1e-9 relative.  Equation numbers refer to
S. Mafrica, MSc thesis, 2012 (see plugin/tire/README.md).  The parameters'
defaults and the floors are the plugin's own contract (skidsteer.robot.tire),
and so are the wheels and the floor it finds; the law below is written out
again on purpose.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping

import mujoco
import numpy as np

from skidsteer.robot import tire
from skidsteer.robot.tire import find_wheels, floor_geoms

_PLANE = int(mujoco.mjtGeom.mjGEOM_PLANE)

# Friction of the floors the plugin knows by name (Sec. 3.3)
FLOOR_FRICTION: dict[str, tuple[float, float]] = {
    name: (f.mu_static, f.mu_kinetic) for name, f in tire.floors().items()}
_DEFAULTS = {name: a.default for name, a in tire.attributes().items()}

# State per wheel: for x then y, [deflection s, contact velocity v_c, stuck flag]
_LAYOUT = tire.state_layout()
DEFLECTION, VELOCITY, STUCK = _LAYOUT.deflection, _LAYOUT.velocity, _LAYOUT.stuck
NSTATE_DIR = _LAYOUT.nstate_direction
NSTATE_WHEEL = _LAYOUT.nstate_wheel


def _series(tread: float, belt: float) -> float:
    """Springs or dampers in series, eq. 4.14."""
    return belt if math.isinf(tread) else tread * belt / (tread + belt)


@dataclasses.dataclass(frozen=True)
class TireParams:
    """Parameters of the tire law, SI units, defaults the plugin's (its contract)."""

    mu_static: float = FLOOR_FRICTION[_DEFAULTS["floor"]][0]
    mu_kinetic: float = FLOOR_FRICTION[_DEFAULTS["floor"]][1]
    stiffness_z: float = _DEFAULTS["stiffness_z"]  # K_z, N/m
    damping_z: float = _DEFAULTS["damping_z"]  # D_z, N s/m
    stiffness_y: float = _DEFAULTS["stiffness_y"]  # K_y, N/m
    damping_y: float = _DEFAULTS["damping_y"]  # D_y, N s/m
    belt_stiffness: float = _DEFAULTS["belt_stiffness"]  # K_belt, N/m
    belt_damping: float = _DEFAULTS["belt_damping"]  # D_x ~ D_belt, N s/m
    tread_stiffness_x: float = _DEFAULTS["tread_stiffness_x"]  # K_tx >> K_belt, eq. 4.14
    tread_damping_x: float = _DEFAULTS["tread_damping_x"]  # D_tx >> D_belt, eq. 4.14
    contact_mass: float = _DEFAULTS["contact_mass"]  # m_t, kg
    lambda_max: float = _DEFAULTS["lambda_max"]
    # "coulomb": contact point with kinetic friction (eq. 4.9/4.13); "relay": eq. 6.4
    # as the thesis's Simulink model has it (relay flag, no kinetic-friction term)
    contact_point: str = _DEFAULTS["contact_point"]

    @property
    def stiffness_x(self) -> float:
        return _series(self.tread_stiffness_x, self.belt_stiffness)

    @property
    def damping_x(self) -> float:
        return _series(self.tread_damping_x, self.belt_damping)

    @classmethod
    def from_config(cls, config: Mapping[str, str]) -> "TireParams":
        """Parameters from plugin attributes (strings), as the C plugin reads them."""
        config = dict(config)
        floor = config.pop("floor", _DEFAULTS["floor"])
        config.pop("radius", None)
        mu_s, mu_k = FLOOR_FRICTION[floor]
        values = {"mu_static": mu_s, "mu_kinetic": mu_k}
        values.update({k: (v if k == "contact_point" else float(v))
                       for k, v in config.items()})
        return cls(**values)


@dataclasses.dataclass
class Kinematics:
    compression: float  # delta > 0 compressed, m
    compression_rate: float  # m/s
    slip_x: float  # Delta v_x = v_x - r omega, m/s
    slip_y: float  # v_y, m/s
    rolling_speed: float  # r omega, m/s


def normal_force(p: TireParams, k: Kinematics) -> float:
    """eq. 4.15, clamped at zero so wheels can lift."""
    if k.compression <= 0:
        return 0.0
    normal = p.stiffness_z * k.compression + p.damping_z * k.compression_rate
    return normal if normal > 0 else 0.0


def friction_factors(p: TireParams, k: Kinematics) -> tuple[float, float]:
    """(mu_x, mu_y) in [0, 1]: eq. 4.12a/b, saturated."""
    rolling, slip_x, slip_y = abs(k.rolling_speed), abs(k.slip_x), abs(k.slip_y)
    lam = min(1.0, slip_x / rolling) if rolling > 0 else 1.0
    if lam < p.lambda_max:
        return lam / p.lambda_max, min(1.0, slip_y / (rolling * p.lambda_max))
    return 1.0, (min(1.0, slip_y / slip_x) if slip_x > 0 else 1.0)


def forces(p: TireParams, k: Kinematics, state: np.ndarray) -> np.ndarray:
    """[N, f_x, f_y] on the wheel, contact frame, from the start-of-step state."""
    normal = normal_force(p, k)
    if normal <= 0:
        return np.array([normal, 0.0, 0.0])
    sx, sy = state[0:NSTATE_DIR], state[NSTATE_DIR:NSTATE_WHEEL]
    fx = -p.damping_x * (k.slip_x - sx[VELOCITY]) - p.stiffness_x * sx[DEFLECTION]
    fy = -p.damping_y * (k.slip_y - sy[VELOCITY]) - p.stiffness_y * sy[DEFLECTION]
    return np.array([normal, fx, fy])


def advance_direction(stiffness, damping, mass, static_limit, kinetic_limit, drive, h,
                      st: np.ndarray) -> None:
    """One backward-Euler step of the contact point along one direction (in place).

    Sticking: v = 0 while |K s + D u| <= F_s.  Slipping: m dv/dt = K s + D (u - v)
    - F_k sign(v), ds/dt = u - v; it ends when the friction impulse stops v.
    """
    deflection, velocity = st[DEFLECTION], st[VELOCITY]
    if st[STUCK] > 0.5:
        deflection_next = deflection + h * drive
        if abs(stiffness * deflection_next + damping * drive) <= static_limit:
            st[DEFLECTION], st[VELOCITY] = deflection_next, 0.0
            return
        velocity = 0.0
    a = mass + h * damping + h * h * stiffness
    velocity_free = (mass * velocity
                     + h * (stiffness * deflection + (stiffness * h + damping) * drive)) / a
    friction_dv = h * kinetic_limit / a
    if abs(velocity_free) > friction_dv:
        velocity_next = velocity_free - math.copysign(friction_dv, velocity_free)
        st[STUCK] = 0.0
    else:
        velocity_next = 0.0
        st[STUCK] = 1.0
    st[VELOCITY] = velocity_next
    st[DEFLECTION] = deflection + h * (drive - velocity_next)


def advance_direction_relay(stiffness, damping, mass, static_limit, kinetic_limit, drive, h,
                            st: np.ndarray) -> None:
    """One step of eq. 6.4 as simulated in the thesis (in place).

    m_t dv/dt + D v = F' with F' = K s + D u while the relay is on, 0 while off;
    on when |F'| > F_s, off when |F'| < F_k; STUCK holds 1 while off.
    """
    deflection, velocity = st[DEFLECTION], st[VELOCITY]
    driving = abs(stiffness * deflection + damping * drive)
    off = st[STUCK] > 0.5
    if off and driving > static_limit:
        off = False
    elif not off and driving < kinetic_limit:
        off = True
    if off:
        velocity_next = mass * velocity / (mass + h * damping)
    else:
        a = mass + h * damping + h * h * stiffness
        velocity_next = (mass * velocity
                         + h * (stiffness * deflection + (stiffness * h + damping) * drive)) / a
    st[STUCK] = 1.0 if off else 0.0
    st[VELOCITY] = velocity_next
    st[DEFLECTION] = deflection + h * (drive - velocity_next)


def reset_state(state: np.ndarray) -> None:
    state[:] = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0]


def advance(p: TireParams, k: Kinematics, h: float, state: np.ndarray) -> None:
    """Advances one wheel's state (in place) by h seconds."""
    normal = normal_force(p, k)
    if normal <= 0:
        reset_state(state)
        return
    mu = friction_factors(p, k)
    step = advance_direction_relay if p.contact_point == "relay" else advance_direction
    for direction, (stiffness, damping, drive) in enumerate((
            (p.stiffness_x, p.damping_x, k.slip_x),
            (p.stiffness_y, p.damping_y, k.slip_y))):
        step(stiffness, damping, p.contact_mass,
             p.mu_static * mu[direction] * normal,
             p.mu_kinetic * mu[direction] * normal,
             drive, h, state[direction * NSTATE_DIR:(direction + 1) * NSTATE_DIR])


# --------------------------------------------------------------- kinematics


def _point_velocity(m, d, body, point):
    cvel = d.cvel[body]
    offset = point - d.subtree_com[m.body_rootid[body]]
    return np.cross(cvel[:3], offset) + cvel[3:]


def wheel_contact(m: mujoco.MjModel, d: mujoco.MjData, wheel: Wheel, floors: list[int]):
    """(Kinematics, frame rows [n, t_x, t_y], contact point) or None off the floor."""
    center = d.geom_xpos[wheel.geom] if wheel.geom >= 0 else d.xpos[wheel.body]
    axle = d.xaxis[wheel.joint]
    best, normal, spread = -np.inf, None, 1.0
    for f in floors:
        up = d.geom_xmat[f].reshape(3, 3)[:, 2]
        cos_tilt = float(up @ axle)
        sin_tilt = math.sqrt(max(0.0, 1 - cos_tilt * cos_tilt))
        if sin_tilt < 1e-9:
            continue
        rim = wheel.radius * sin_tilt
        if int(m.geom_type[f]) == _PLANE:
            height = float((center - d.geom_xpos[f]) @ up)
        else:
            height = mujoco.mj_rayHfield(m, d, f, center, -up, None)
            if height < 0:
                continue
        compression = rim - height
        if compression > best:
            best, normal, spread = compression, up.copy(), sin_tilt
    if normal is None:
        return None
    cos_tilt = float(normal @ axle)
    point = center + (axle * cos_tilt - normal) * (wheel.radius / spread)
    tx = np.cross(axle, normal)
    tx /= np.linalg.norm(tx)
    ty = np.cross(normal, tx)
    v_rim = _point_velocity(m, d, wheel.body, point)
    v_center = _point_velocity(m, d, wheel.body, center)
    slip_x = float(v_rim @ tx)
    k = Kinematics(compression=best, compression_rate=-float(v_rim @ normal), slip_x=slip_x,
                   slip_y=float(v_rim @ ty), rolling_speed=float(v_center @ tx) - slip_x)
    return k, np.stack([normal, tx, ty]), point


class TireReference:
    """The whole plugin instance in Python: forces, generalized forces, advance."""

    def __init__(self, m: mujoco.MjModel, params: TireParams, instance: int = 0,
                 radius: float = 0.0):
        self.m, self.params, self.instance = m, params, instance
        self.wheels = find_wheels(m, instance, radius)
        self.floors = floor_geoms(m)

    def _state(self, state_vector: np.ndarray, w: int) -> np.ndarray:
        adr = self.m.plugin_stateadr[self.instance] + NSTATE_WHEEL * w
        return state_vector[adr:adr + NSTATE_WHEEL]

    def tire_forces(self, d: mujoco.MjData) -> np.ndarray:
        """(nwheel, 3) [N, f_x, f_y], as the tire_forces sensor reports them."""
        out = np.zeros((len(self.wheels), 3))
        for w, wheel in enumerate(self.wheels):
            contact = wheel_contact(self.m, d, wheel, self.floors)
            if contact is not None:
                out[w] = forces(self.params, contact[0], self._state(d.plugin_state, w))
        return out

    def generalized_forces(self, d: mujoco.MjData) -> np.ndarray:
        """The plugin's contribution to qfrc_passive."""
        qfrc = np.zeros(self.m.nv)
        for w, wheel in enumerate(self.wheels):
            contact = wheel_contact(self.m, d, wheel, self.floors)
            if contact is None:
                continue
            k, frame, point = contact
            f = forces(self.params, k, self._state(d.plugin_state, w))
            if f[0] > 0:
                mujoco.mj_applyFT(self.m, d, frame.T @ f, np.zeros(3), point, wheel.body, qfrc)
        return qfrc

    def next_state(self, d: mujoco.MjData) -> np.ndarray:
        """plugin_state after one mj_step from d (kinematics of the start of the step)."""
        state = d.plugin_state.copy()
        for w, wheel in enumerate(self.wheels):
            st = self._state(state, w)
            contact = wheel_contact(self.m, d, wheel, self.floors)
            if contact is None:
                reset_state(st)
            else:
                advance(self.params, contact[0], self.m.opt.timestep, st)
        return state
