"""A readable Python reference of the skidsteer.tire law (slow; for tests).

Same law, same conventions and same order of operations as
plugin/tire/tire_law.c and the kinematics of plugin/tire/tire_plugin.c.  The
tests drive the C plugin and this reference with the same random inputs and
require them to agree to ~1e-9 relative.  Equation numbers refer to
S. Mafrica, MSc thesis, 2012 (see plugin/tire/README.md).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping

import mujoco
import numpy as np

# Friction of the floors measured in the thesis, Sec. 3.3 (plugin/tire/README.md
# derives mu_kinetic).  Keep in step with kFloors in plugin/tire/tire_plugin.c.
FLOOR_FRICTION: dict[str, tuple[float, float]] = {
    "concrete": (0.86, 0.786),
    "tile": (0.86, 0.786),
    "carpet": (0.98, 0.896),
}

# geom types as ints: numpy ints never compare equal to pybind enum members
_CYLINDER, _SPHERE, _ELLIPSOID = (int(mujoco.mjtGeom.mjGEOM_CYLINDER),
                                  int(mujoco.mjtGeom.mjGEOM_SPHERE),
                                  int(mujoco.mjtGeom.mjGEOM_ELLIPSOID))
_PLANE, _HFIELD = int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_HFIELD)

# State per wheel: for x then y, [deflection s, contact velocity v_c, stuck flag]
DEFLECTION, VELOCITY, STUCK = 0, 1, 2
NSTATE_DIR = 3
NSTATE_WHEEL = 2 * NSTATE_DIR


def _series(tread: float, belt: float) -> float:
    """Springs or dampers in series, eq. 4.14."""
    return belt if math.isinf(tread) else tread * belt / (tread + belt)


@dataclasses.dataclass(frozen=True)
class TireParams:
    """Parameters of the tire law, SI units, defaults from the thesis."""

    mu_static: float = FLOOR_FRICTION["concrete"][0]
    mu_kinetic: float = FLOOR_FRICTION["concrete"][1]
    stiffness_z: float = 80000.0  # K_z, N/m, Sec. 3.3 (Fig. 3.10a)
    damping_z: float = 70.0  # D_z, N s/m, eq. 6.5
    stiffness_y: float = 18000.0  # K_y, N/m, Sec. 3.3 (Fig. 3.9)
    damping_y: float = 30.0  # D_y, N s/m, eq. 6.5
    belt_stiffness: float = 3000.0  # K_belt, N/m, Sec. 3.3 (eq. 3.8)
    belt_damping: float = 50.0  # D_x ~ D_belt, N s/m, eq. 6.5
    tread_stiffness_x: float = math.inf  # K_tx >> K_belt, eq. 4.14
    tread_damping_x: float = math.inf  # D_tx >> D_belt, eq. 4.14
    contact_mass: float = 0.035  # m_t, kg, Sec. 6.2
    lambda_max: float = 0.1  # assumed, Sec. 6.2 suggests 1e-1 to 1e-2
    # "coulomb": contact point with kinetic friction (eq. 4.9/4.13); "relay": eq. 6.4
    # as the thesis's Simulink model has it (relay flag, no kinetic-friction term)
    contact_point: str = "coulomb"

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
        floor = config.pop("floor", "concrete")
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


@dataclasses.dataclass
class Wheel:
    body: int
    joint: int
    geom: int
    radius: float


def find_wheels(m: mujoco.MjModel, instance: int = 0, radius: float = 0.0) -> list[Wheel]:
    """The wheels of a plugin instance, in body order (as the plugin finds them)."""
    wheels = []
    for b in range(1, m.nbody):
        if m.body_plugin[b] != instance:
            continue
        joint = int(m.body_jntadr[b])
        geoms = range(m.body_geomadr[b], m.body_geomadr[b] + m.body_geomnum[b])
        geom = next((g for g in geoms
                     if int(m.geom_type[g]) in (_CYLINDER, _SPHERE, _ELLIPSOID)), -1)
        if geom < 0 and radius <= 0:
            raise ValueError(f"wheel body {m.body(b).name!r} has no cylinder or sphere geom")
        wheels.append(Wheel(b, joint, geom, radius if radius > 0 else float(m.geom_size[geom][0])))
    return wheels


def floor_geoms(m: mujoco.MjModel) -> list[int]:
    start, count = m.body_geomadr[0], m.body_geomnum[0]
    return [g for g in range(start, start + count) if int(m.geom_type[g]) in (_PLANE, _HFIELD)]


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
