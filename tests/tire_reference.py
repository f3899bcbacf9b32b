"""A readable Python reference of the skidsteer.tire law, for the tests (slow).

Same law, same conventions and same order of operations as
plugin/tire/tire_law.c, the kinematics of plugin/tire/tire_contact.c and the
floors of plugin/tire/tire_floor.c.  The tests drive the C plugin and this
reference with the same random inputs and require them to agree to ~1e-9
relative.  Equation numbers refer to S. Mafrica, MSc thesis, 2012 (see
plugin/tire/README.md).  The parameters' defaults and the floors are the
plugin's own contract (skidsteer.robot.tire), and so are the wheels and the
floor it finds; the law below is written out again on purpose.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping

import mujoco
import numpy as np
from scipy import ndimage

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
    # "implicit": forces solved at the end-of-step slips; "explicit": start-of-step forces
    coupling: str = _DEFAULTS["coupling"]
    # alpha_s (eq. 2.29b) and v_S, m/s: kinetic friction falls with the rim's sliding
    # speed v as alpha_s + (1 - alpha_s) exp(-(v / v_S)^2); alpha_s = 1 is off
    sliding_friction_ratio: float = _DEFAULTS["sliding_friction_ratio"]
    sliding_velocity: float = _DEFAULTS["sliding_velocity"]
    # n and N_0, N: the lateral stiffness is K_y (N / N_0)^n; n = 0 is off
    stiffness_y_load_exponent: float = _DEFAULTS["stiffness_y_load_exponent"]
    reference_load: float = _DEFAULTS["reference_load"]
    # tread lugs per revolution (0: round) and the centre's drop between two lugs, m:
    # geometry of the contact, read by wheel_contact
    lug_count: float = _DEFAULTS["lug_count"]
    lug_depth: float = _DEFAULTS["lug_depth"]
    # a heightfield floor between its samples: "cubic" (the samples' interpolating
    # cubic B-spline, its slope in d(delta)/dt) or "triangles" (MuJoCo's, mj_rayHfield)
    floor_interpolation: str = _DEFAULTS["floor_interpolation"]
    # the contact normal on a heightfield: "vertical" (the floor geom's up) or
    # "surface" (the cubic floor's own normal under the wheel centre)
    floor_normal: str = _DEFAULTS["floor_normal"]
    # "thesis": eq. 4.12a/b per direction; "combined": Coulomb friction on the resultant
    # slip velocity, the friction ellipse of axes mu_x,max and rho mu_x,max
    slip_law: str = _DEFAULTS["slip_law"]
    lateral_friction_ratio: float = _DEFAULTS["lateral_friction_ratio"]  # the floor's
    tread_lateral_friction_ratio: float = _DEFAULTS["tread_lateral_friction_ratio"]  # the tyre's
    # the contact points' backward-Euler steps per body step (implicit coupling only);
    # the body receives their mean force
    contact_substeps: float = _DEFAULTS["contact_substeps"]

    def lateral_stiffness(self, normal: float) -> float:
        """K_y at normal load N > 0: K_y (N / N_0)^n."""
        if self.stiffness_y_load_exponent == 0:
            return self.stiffness_y
        return self.stiffness_y * (normal / self.reference_load) ** self.stiffness_y_load_exponent

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
        values.update({k: (v if k in ("contact_point", "coupling", "floor_interpolation",
                                     "floor_normal", "slip_law")
                           else float(v))
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
    """(mu_x, mu_y), the limits' factors relative to mu_x,max: eq. 4.12a/b, saturated,
    the lateral one times rho; or the friction ellipse of the combined law."""
    return _friction(p, k)[0]


def friction_slopes(p: TireParams, k: Kinematics) -> tuple[float, float]:
    """(d mu_x / d u_x, d mu_y / d u_y) within the branch of friction_factors."""
    return _friction(p, k)[1]


def _friction(p: TireParams, k: Kinematics):
    rolling, slip_x, slip_y = abs(k.rolling_speed), abs(k.slip_x), abs(k.slip_y)
    rho = p.lateral_friction_ratio * p.tread_lateral_friction_ratio
    if p.slip_law == "combined":
        # force against (u_x, rho^2 u_y) on the ellipse, magnitude g = min(1, q / (r w lm))
        q = math.hypot(slip_x, rho * slip_y)
        scale = rolling * p.lambda_max
        if q < scale:
            return ((slip_x / scale, rho ** 2 * slip_y / scale),
                    (np.sign(k.slip_x) / scale, rho ** 2 * np.sign(k.slip_y) / scale))
        if q > 0:
            return ((slip_x / q, rho ** 2 * slip_y / q),
                    (np.sign(k.slip_x) * (rho * slip_y) ** 2 / q ** 3,
                     rho ** 2 * np.sign(k.slip_y) * slip_x ** 2 / q ** 3))
        return (1.0, rho), (0.0, 0.0)
    lam = min(1.0, slip_x / rolling) if rolling > 0 else 1.0
    if lam < p.lambda_max:
        scale = rolling * p.lambda_max
        mu = (lam / p.lambda_max, min(1.0, slip_y / scale))
        slope = (np.sign(k.slip_x) / scale, np.sign(k.slip_y) / scale if slip_y < scale else 0.0)
    else:
        mu = (1.0, (min(1.0, slip_y / slip_x) if slip_x > 0 else 1.0))
        slope = (0.0, (np.sign(k.slip_y) / slip_x if 0 < slip_x and slip_y < slip_x else 0.0))
    return (mu[0], rho * mu[1]), (slope[0], rho * slope[1])


def forces(p: TireParams, k: Kinematics, state: np.ndarray) -> np.ndarray:
    """[N, f_x, f_y] on the wheel, contact frame, from the start-of-step state."""
    normal = normal_force(p, k)
    if normal <= 0:
        return np.array([normal, 0.0, 0.0])
    sx, sy = state[0:NSTATE_DIR], state[NSTATE_DIR:NSTATE_WHEEL]
    fx = -p.damping_x * (k.slip_x - sx[VELOCITY]) - p.stiffness_x * sx[DEFLECTION]
    fy = (-p.damping_y * (k.slip_y - sy[VELOCITY])
          - p.lateral_stiffness(normal) * sy[DEFLECTION])
    return np.array([normal, fx, fy])


def _chained_slope(damping, stiffness, h, dv, chain) -> float:
    """d f / d u of the end-of-substep force, the state's derivatives carried in chain
    ([d s / d u, d v / d u], updated in place) and d v' / d u = dv."""
    chain[0] += h * (1 - dv)
    chain[1] = dv
    return -damping * (1 - dv) - stiffness * chain[0]


def advance_direction(stiffness, damping, mass, static_limit, kinetic_limit, drive, h,
                      st: np.ndarray, kinetic_slope: float = 0.0, chain=None) -> float:
    """One backward-Euler step of the contact point along one direction (in place).

    Sticking: v = 0 while |K s + D u| <= F_s.  Slipping: m dv/dt = K s + D (u - v)
    - F_k sign(v), ds/dt = u - v; it ends when the friction impulse stops v.
    Returns d f / d u of the end-of-step force f = -D (u - v') - K s' in the regime
    the step ends in (kinetic_slope = d F_k / d u); chain: [d s / d u, d v / d u]
    carried from the earlier substeps of one step (updated), which the slope then
    includes.
    """
    deflection, velocity = st[DEFLECTION], st[VELOCITY]
    spring_damper = damping + h * stiffness
    if st[STUCK] > 0.5:
        deflection_next = deflection + h * drive
        if abs(stiffness * deflection_next + damping * drive) <= static_limit:
            st[DEFLECTION], st[VELOCITY] = deflection_next, 0.0
            if chain is not None:
                return _chained_slope(damping, stiffness, h, 0.0, chain)
            return -spring_damper
        velocity = 0.0
        if chain is not None:
            chain[1] = 0.0
    a = mass + h * damping + h * h * stiffness
    velocity_free = (mass * velocity
                     + h * (stiffness * deflection + (stiffness * h + damping) * drive)) / a
    friction_dv = h * kinetic_limit / a
    if abs(velocity_free) > friction_dv:
        velocity_next = velocity_free - math.copysign(friction_dv, velocity_free)
        velocity_slope = (h * (stiffness * h + damping)
                          - (1.0 if velocity_free > 0 else -1.0) * h * kinetic_slope) / a
        st[STUCK] = 0.0
    else:
        velocity_next = 0.0
        velocity_slope = 0.0
        st[STUCK] = 1.0
    st[VELOCITY] = velocity_next
    st[DEFLECTION] = deflection + h * (drive - velocity_next)
    if chain is not None:
        dv = 0.0 if st[STUCK] > 0.5 else (
            velocity_slope + (mass * chain[1] + h * stiffness * chain[0]) / a)
        return _chained_slope(damping, stiffness, h, dv, chain)
    return -spring_damper * (1 - velocity_slope)


def advance_direction_relay(stiffness, damping, mass, static_limit, kinetic_limit, drive, h,
                            st: np.ndarray, kinetic_slope: float = 0.0, chain=None) -> float:
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
        velocity_slope = 0.0
        carried = 0.0 if chain is None else mass * chain[1] / (mass + h * damping)
    else:
        a = mass + h * damping + h * h * stiffness
        velocity_next = (mass * velocity
                         + h * (stiffness * deflection + (stiffness * h + damping) * drive)) / a
        velocity_slope = h * (stiffness * h + damping) / a
        carried = 0.0 if chain is None else (mass * chain[1] + h * stiffness * chain[0]) / a
    st[STUCK] = 1.0 if off else 0.0
    st[VELOCITY] = velocity_next
    st[DEFLECTION] = deflection + h * (drive - velocity_next)
    if chain is not None:
        return _chained_slope(damping, stiffness, h, velocity_slope + carried, chain)
    return -(damping + h * stiffness) * (1 - velocity_slope)


def reset_state(state: np.ndarray) -> None:
    state[:] = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0]


def sliding_factor(p: TireParams, k: Kinematics) -> tuple[float, tuple[float, float]]:
    """(g, (d g / d u_x, d g / d u_y)): the falling branch of kinetic friction,
    g = alpha_s + (1 - alpha_s) exp(-(v / v_S)^2) with v = |(u_x, u_y)|; 1 when off."""
    if p.sliding_friction_ratio >= 1:
        return 1.0, (0.0, 0.0)
    vs2 = p.sliding_velocity ** 2
    falling = (1 - p.sliding_friction_ratio) * math.exp(-(k.slip_x ** 2 + k.slip_y ** 2) / vs2)
    return (p.sliding_friction_ratio + falling,
            (-2 * falling * k.slip_x / vs2, -2 * falling * k.slip_y / vs2))


def advance(p: TireParams, k: Kinematics, h: float, state: np.ndarray,
            mean: np.ndarray | None = None) -> np.ndarray:
    """Advances one wheel's state (in place) by h seconds; returns the force slopes
    (d f_x / d u_x, d f_y / d u_y) of the regime it ends in.  With contact_substeps
    n > 1: n steps of h / n, the slips held, and the slopes are those of the mean
    force over them, written into mean (f_x, f_y) when given."""
    normal = normal_force(p, k)
    if normal <= 0:
        reset_state(state)
        if mean is not None:
            mean[:] = 0.0
        return np.zeros(2)
    mu = friction_factors(p, k)
    mu_slope = friction_slopes(p, k)
    sliding, sliding_grad = sliding_factor(p, k)
    step = advance_direction_relay if p.contact_point == "relay" else advance_direction
    n = max(1, int(p.contact_substeps))
    slopes = np.zeros(2)
    for direction, (stiffness, damping, drive) in enumerate((
            (p.stiffness_x, p.damping_x, k.slip_x),
            (p.lateral_stiffness(normal), p.damping_y, k.slip_y))):
        st = state[direction * NSTATE_DIR:(direction + 1) * NSTATE_DIR]
        args = (stiffness, damping, p.contact_mass,
                p.mu_static * mu[direction] * normal,
                p.mu_kinetic * mu[direction] * sliding * normal)
        kinetic_slope = p.mu_kinetic * (mu_slope[direction] * sliding
                                        + mu[direction] * sliding_grad[direction]) * normal
        if n == 1:
            slopes[direction] = step(*args, drive, h, st, kinetic_slope)
            continue
        chain, force_sum, slope_sum = [0.0, 0.0], 0.0, 0.0
        for _ in range(n):
            slope_sum += step(*args, drive, h / n, st, kinetic_slope, chain)
            force_sum += -damping * (drive - st[VELOCITY]) - stiffness * st[DEFLECTION]
        slopes[direction] = slope_sum / n
        if mean is not None:
            mean[direction] = force_sum / n
    return slopes


def step_force(p: TireParams, k: Kinematics, h: float, state: np.ndarray):
    """([N, f_x, f_y] over a step whose rim slips are k's, slopes); state kept.  The
    force at the step's end, or with contact_substeps > 1 the substeps' mean."""
    after = np.array(state, dtype=float)
    mean = np.zeros(2)
    slopes = advance(p, k, h, after, mean)
    out = forces(p, k, after)
    if p.contact_substeps > 1 and out[0] > 0:
        out[1:] = mean
    return out, slopes


# --------------------------------------------------------------- kinematics


def _point_velocity(m, d, body, point):
    cvel = d.cvel[body]
    offset = point - d.subtree_com[m.body_rootid[body]]
    return np.cross(cvel[:3], offset) + cvel[3:]


def floor_spline(m: mujoco.MjModel, hfield: int) -> np.ndarray:
    """The cubic B-spline coefficients (nrow, ncol) of a heightfield's elevation in m,
    with mirror ends: scipy.ndimage's prefilter, so that map_coordinates(order=3,
    prefilter=False, mode="mirror") evaluates the samples' interpolating spline."""
    nrow, ncol = int(m.hfield_nrow[hfield]), int(m.hfield_ncol[hfield])
    adr = int(m.hfield_adr[hfield])
    elevation = (m.hfield_data[adr:adr + nrow * ncol].astype(np.float64)
                 * m.hfield_size[hfield][2]).reshape(nrow, ncol)
    return ndimage.spline_filter(elevation, order=3, mode="mirror")


def _bspline_slope_weights(t: float) -> np.ndarray:
    """d/dt of the cubic B-spline's weights of samples i-1 .. i+2, t past sample i."""
    return np.array([-(1 - t) ** 2 / 2, 1.5 * t * t - 2 * t, -1.5 * t * t + t + 0.5, t * t / 2])


def _bspline_weights(t: float) -> np.ndarray:
    return np.array([(1 - t) ** 3, 3 * t ** 3 - 6 * t ** 2 + 4,
                     -3 * t ** 3 + 3 * t ** 2 + 3 * t + 1, t ** 3]) / 6


def spline_elevation(m: mujoco.MjModel, f: int, coef: np.ndarray, x: float, y: float):
    """(elevation m, (dh/dx, dh/dy)) of floor geom f's spline at its frame's (x, y),
    None outside the heightfield.  The elevation is scipy's (map_coordinates); the
    slope is the B-spline basis's derivative, written out."""
    size = m.hfield_size[m.geom_dataid[f]]
    nrow, ncol = coef.shape
    if abs(x) > size[0] or abs(y) > size[1]:
        return None
    du_dx, dv_dy = (ncol - 1) / (2 * size[0]), (nrow - 1) / (2 * size[1])
    u, v = (x + size[0]) * du_dx, (y + size[1]) * dv_dy
    elevation = float(ndimage.map_coordinates(coef, [[v], [u]], order=3, prefilter=False,
                                              mode="mirror")[0])
    i = min(max(int(math.floor(u)), 0), max(ncol - 2, 0))
    j = min(max(int(math.floor(v)), 0), max(nrow - 2, 0))
    period_u, period_v = 2 * (ncol - 1), 2 * (nrow - 1)
    cols = [(k % period_u if (k % period_u) <= ncol - 1 else period_u - k % period_u)
            for k in range(i - 1, i + 3)]
    rows = [(k % period_v if (k % period_v) <= nrow - 1 else period_v - k % period_v)
            for k in range(j - 1, j + 3)]
    patch = coef[np.ix_(rows, cols)]
    wu, wv = _bspline_weights(u - i), _bspline_weights(v - j)
    slope = (float(wv @ patch @ _bspline_slope_weights(u - i)) * du_dx,
             float(_bspline_slope_weights(v - j) @ patch @ wu) * dv_dy)
    return elevation, slope


def wheel_contact(m: mujoco.MjModel, d: mujoco.MjData, wheel: Wheel, floors: list[int],
                  p: TireParams = TireParams(), splines: dict | None = None):
    """(Kinematics, frame rows [n, t_x, t_y], contact point) or None off the floor."""
    center = d.geom_xpos[wheel.geom] if wheel.geom >= 0 else d.xpos[wheel.body]
    axle = d.xaxis[wheel.joint]
    radius, drop_rate = wheel.radius, 0.0
    if p.lug_count > 0 and p.lug_depth > 0:
        # a polygon of lug_count sides, its drop between lugs scaled to lug_depth, at
        # the wheel's angle about its axle from the bodies' poses (as the plugin: they
        # are the step's start also where qpos has moved on)
        parent = m.body_parentid[wheel.body]
        inv_parent, inv_body = np.zeros(4), np.zeros(4)
        relative, q_joint, rotation = np.zeros(4), np.zeros(4), np.zeros(3)
        mujoco.mju_negQuat(inv_parent, d.xquat[parent])
        mujoco.mju_negQuat(inv_body, m.body_quat[wheel.body])
        mujoco.mju_mulQuat(relative, inv_parent, d.xquat[wheel.body])
        mujoco.mju_mulQuat(q_joint, inv_body, relative)
        mujoco.mju_quat2Vel(rotation, q_joint, 1.0)
        angle = float(rotation @ m.jnt_axis[wheel.joint])
        rate = float((d.cvel[wheel.body, :3] - d.cvel[parent, :3]) @ d.xaxis[wheel.joint])
        pitch = 2 * math.pi / p.lug_count
        alpha = angle - pitch * math.floor(angle / pitch + 0.5)
        scale = p.lug_depth / (1 - math.cos(pitch / 2))
        radius -= scale * (1 - math.cos(alpha))
        drop_rate = scale * math.sin(alpha) * rate
    best, normal, spread, profile_rate = -np.inf, None, 1.0, 0.0
    for f in floors:
        up = d.geom_xmat[f].reshape(3, 3)[:, 2]
        floor_normal, surface, rate = up.copy(), False, 0.0
        if int(m.geom_type[f]) == _PLANE:
            height = float((center - d.geom_xpos[f]) @ up)
        elif p.floor_interpolation == "cubic":
            mat = d.geom_xmat[f].reshape(3, 3)
            rel = center - d.geom_xpos[f]
            if splines is None:
                splines = {}
            if f not in splines:
                splines[f] = floor_spline(m, int(m.geom_dataid[f]))
            found = spline_elevation(m, f, splines[f], float(rel @ mat[:, 0]),
                                     float(rel @ mat[:, 1]))
            if found is None:
                continue
            elevation, slope = found
            height = float(rel @ up) - elevation
            if p.floor_normal == "surface":
                # the floor's own normal; its rise under the centre is in -v.n
                floor_normal = up - slope[0] * mat[:, 0] - slope[1] * mat[:, 1]
                floor_normal /= np.linalg.norm(floor_normal)
                surface = True
            else:
                v_center = _point_velocity(m, d, wheel.body, center)
                rate = (slope[0] * float(v_center @ mat[:, 0])
                        + slope[1] * float(v_center @ mat[:, 1]))
        else:
            height = mujoco.mj_rayHfield(m, d, f, center, -up, None)
            if height < 0:
                continue
        cos_tilt = float(floor_normal @ axle)
        sin_tilt = math.sqrt(max(0.0, 1 - cos_tilt * cos_tilt))
        if sin_tilt < 1e-9:
            continue
        rim = radius * sin_tilt
        if surface:
            height *= float(floor_normal @ up)  # to the floor's tangent plane, along n
        compression = rim - height
        if compression > best:
            best, normal, spread, profile_rate = compression, floor_normal, sin_tilt, rate
    if normal is None:
        return None
    cos_tilt = float(normal @ axle)
    point = center + (axle * cos_tilt - normal) * (radius / spread)
    tx = np.cross(axle, normal)
    tx /= np.linalg.norm(tx)
    ty = np.cross(normal, tx)
    v_rim = _point_velocity(m, d, wheel.body, point)
    v_center = _point_velocity(m, d, wheel.body, center)
    slip_x = float(v_rim @ tx)
    k = Kinematics(compression=best,
                   compression_rate=-float(v_rim @ normal) + profile_rate - drop_rate * spread,
                   slip_x=slip_x,
                   slip_y=float(v_rim @ ty), rolling_speed=float(v_center @ tx) - slip_x)
    return k, np.stack([normal, tx, ty]), point


_MAX_ITERATIONS = 20  # tire_implicit.c's TIRE_MAX_ITERATIONS
_SMALLEST_STEP = 1 / 64  # TIRE_SMALLEST_STEP
_SLIP_TOLERANCE = 1e-10  # m/s, TIRE_SLIP_TOLERANCE


class TireReference:
    """The whole plugin instance in Python: forces, generalized forces, advance."""

    def __init__(self, m: mujoco.MjModel, params: TireParams, instance: int = 0,
                 radius: float = 0.0):
        self.m, self.params, self.instance = m, params, instance
        self.wheels = find_wheels(m, instance, radius)
        self.floors = floor_geoms(m)
        self.splines: dict[int, np.ndarray] = {}  # floor geom: its heightfield's spline

    def _state(self, state_vector: np.ndarray, w: int) -> np.ndarray:
        adr = self.m.plugin_stateadr[self.instance] + NSTATE_WHEEL * w
        return state_vector[adr:adr + NSTATE_WHEEL]

    # ---------------------------------------------------------- implicit coupling

    def _same_branch(self) -> np.ndarray:
        m = self.m
        mask = np.zeros((m.nv, m.nv), dtype=bool)
        for i in range(m.nv):
            j = i
            while j >= 0:
                mask[i, j] = mask[j, i] = True
                j = m.dof_parentid[j]
        return mask

    def _step_matrix(self, d: mujoco.MjData) -> np.ndarray:
        """M + h B: the damping each integrator treats implicitly, in M's sparsity."""
        m, h = self.m, self.m.opt.timestep
        nv = m.nv
        H = np.zeros((nv, nv))
        mujoco.mj_fullM(m, d, H)
        integ = m.opt.integrator
        implicit = integ in (mujoco.mjtIntegrator.mjINT_IMPLICIT,
                             mujoco.mjtIntegrator.mjINT_IMPLICITFAST)
        euler = (integ == mujoco.mjtIntegrator.mjINT_EULER
                 and not m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_EULERDAMP)
        damper = not m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_DAMPER
        actuation = not m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_ACTUATION
        if (implicit or euler) and damper:
            H[np.diag_indices(nv)] += h * m.dof_damping
        extra = np.zeros((nv, nv))
        if implicit and damper:
            for t in range(m.ntendon):
                adr, nnz = m.ten_J_rowadr[t], m.ten_J_rownnz[t]
                row = np.zeros(nv)
                row[m.ten_J_colind[adr:adr + nnz]] = d.ten_J[adr:adr + nnz]
                extra += h * m.tendon_damping[t] * np.outer(row, row)
        if implicit and actuation:
            for a in range(m.nu):
                slope = 0.0
                if m.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE:
                    slope += m.actuator_biasprm[a, 2]
                if m.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_AFFINE:
                    if m.actuator_dyntype[a] == mujoco.mjtDyn.mjDYN_NONE:
                        signal = d.ctrl[m.actuator_ctrladr[a]] if m.actuator_ctrlnum[a] else 0.0
                    else:
                        signal = d.act[m.actuator_actadr[a] + m.actuator_actnum[a] - 1]
                    slope += m.actuator_gainprm[a, 2] * signal
                for o in range(m.actuator_outadr[a], m.actuator_outadr[a] + m.actuator_outnum[a]):
                    adr, nnz = d.moment_rowadr[o], d.moment_rownnz[o]
                    row = np.zeros(nv)
                    row[d.moment_colind[adr:adr + nnz]] = d.actuator_moment[adr:adr + nnz]
                    extra -= h * slope * np.outer(row, row)
        return H + np.where(self._same_branch(), extra, 0.0)

    def implicit_solve(self, d: mujoco.MjData):
        """(forces (nwheel, 3), end-of-step slips (2 nwheel), contact rows J), as
        tire_implicit.c's tire_implicit_forces solves them."""
        m, p, h = self.m, self.params, self.m.opt.timestep
        nv, nw = m.nv, len(self.wheels)
        n = 2 * nw
        J = np.zeros((n, nv))
        contacts = []
        for w, wheel in enumerate(self.wheels):
            contact = wheel_contact(m, d, wheel, self.floors, p, self.splines)
            contacts.append(contact)
            if contact is not None and normal_force(p, contact[0]) > 0:
                jacp = np.zeros((3, nv))
                mujoco.mj_jac(m, d, jacp, None, contact[2], wheel.body)
                J[2 * w], J[2 * w + 1] = contact[1][1] @ jacp, contact[1][2] @ jacp
        out = np.zeros((nw, 3))
        if not J.any():
            return out, np.zeros(n), J, contacts
        scratch = mujoco.MjData(m)
        mujoco.mj_copyData(scratch, m, d)
        mujoco.mj_fwdActuation(m, scratch)
        bias = np.zeros(nv)
        mujoco.mj_rne(m, d, 0, bias)
        # the passive forces before the plugin's (no actuator gravity compensation here)
        other = d.qfrc_spring + d.qfrc_damper + d.qfrc_gravcomp + d.qfrc_fluid
        other = other + scratch.qfrc_actuator - bias + d.qfrc_applied
        for w, contact in enumerate(contacts):  # the normal forces, explicit
            if contact is not None and normal_force(p, contact[0]) > 0:
                mujoco.mj_applyFT(m, d, contact[1][0] * normal_force(p, contact[0]),
                                  np.zeros(3), contact[2], self.wheels[w].body, other)
        for b in range(1, m.nbody):
            if d.xfrc_applied[b].any():
                mujoco.mj_applyFT(m, d, d.xfrc_applied[b, :3], d.xfrc_applied[b, 3:],
                                  d.xipos[b], b, other)
        B = J.copy()
        if d.ne:
            if mujoco.mj_isSparse(m):
                E = np.zeros((d.ne, nv))
                for i in range(d.ne):
                    adr, nnz = d.efc_J_rowadr[i], d.efc_J_rownnz[i]
                    E[i, d.efc_J_colind[adr:adr + nnz]] = d.efc_J[adr:adr + nnz]
            else:
                E = d.efc_J[:d.ne * nv].reshape(d.ne, nv)
            M = np.zeros((nv, nv))
            mujoco.mj_fullM(m, d, M)
            EMinv = np.linalg.solve(M, E.T).T
            S = E @ EMinv.T + np.diag(d.efc_R[:d.ne])
            kbip = d.efc_KBIP[:d.ne]
            aref = -kbip[:, 1] * (E @ d.qvel) - kbip[:, 0] * kbip[:, 2] * d.efc_pos[:d.ne]
            lam0 = np.linalg.solve(S, aref - E @ np.linalg.solve(M, other))
            lam = np.linalg.solve(S, -EMinv @ J.T)  # (ne, n)
            other = other + E.T @ lam0
            B = B + lam.T @ E
        H = self._step_matrix(d)
        A = J @ np.linalg.solve(H, B.T)
        slip_free = J @ (d.qvel + h * np.linalg.solve(H, other))
        slip = np.zeros(n)
        for w, contact in enumerate(contacts):
            if contact is not None:
                slip[2 * w], slip[2 * w + 1] = contact[0].slip_x, contact[0].slip_y
        state = d.plugin_state

        def evaluate(u):
            force, slope = np.zeros(n), np.zeros(n)
            for w, contact in enumerate(contacts):
                if contact is not None:
                    k = dataclasses.replace(contact[0], slip_x=u[2 * w], slip_y=u[2 * w + 1])
                    f, slope[2 * w:2 * w + 2] = step_force(p, k, h, self._state(state, w))
                    force[2 * w:2 * w + 2] = f[1:]
            residual = slip_free + h * (A @ force) - u
            return force, slope, residual, float(residual @ residual)

        force, slope, residual, merit = evaluate(slip)
        converged = False
        for _ in range(_MAX_ITERATIONS):
            if np.max(np.abs(residual)) <= _SLIP_TOLERANCE:
                converged = True
                break
            G = np.eye(n) - h * A * slope[None, :]
            try:
                step = np.linalg.solve(G, residual)
            except np.linalg.LinAlgError:
                break
            t, accepted = 1.0, False
            while t >= _SMALLEST_STEP:
                trial = slip + t * step
                result = evaluate(trial)
                if result[3] <= (1 - 1e-4 * t) * merit:
                    slip = trial
                    force, slope, residual, merit = result
                    accepted = True
                    break
                t *= 0.5
            if not accepted:
                break
        if not converged:
            rows = [r for r in range(n) if J[r].any()]
            if rows:
                try:
                    force[rows] = np.linalg.solve(h * A[np.ix_(rows, rows)],
                                                  slip[rows] - slip_free[rows])
                except np.linalg.LinAlgError:
                    pass
        for w, contact in enumerate(contacts):
            if contact is None:
                continue
            out[w, 0] = normal_force(p, contact[0])
            if out[w, 0] > 0:
                out[w, 1:] = force[2 * w:2 * w + 2]
        return out, slip, J, contacts

    def explicit_generalized(self, d, forces_per_wheel) -> np.ndarray:
        qfrc = np.zeros(self.m.nv)
        for w, wheel in enumerate(self.wheels):
            contact = wheel_contact(self.m, d, wheel, self.floors, self.params, self.splines)
            if contact is None or forces_per_wheel[w][0] <= 0:
                continue
            k, frame, point = contact
            mujoco.mj_applyFT(self.m, d, frame.T @ forces_per_wheel[w], np.zeros(3), point,
                              wheel.body, qfrc)
        return qfrc

    # ---------------------------------------------------------- the plugin's outputs

    def tire_forces(self, d: mujoco.MjData) -> np.ndarray:
        """(nwheel, 3) [N, f_x, f_y], as the tire_forces sensor reports them."""
        if self.params.coupling == "implicit":
            return self.implicit_solve(d)[0]
        out = np.zeros((len(self.wheels), 3))
        for w, wheel in enumerate(self.wheels):
            contact = wheel_contact(self.m, d, wheel, self.floors, self.params, self.splines)
            if contact is not None:
                out[w] = forces(self.params, contact[0], self._state(d.plugin_state, w))
        return out

    def generalized_forces(self, d: mujoco.MjData) -> np.ndarray:
        """The plugin's contribution to qfrc_passive."""
        return self.explicit_generalized(d, self.tire_forces(d))

    def next_state(self, d: mujoco.MjData, qvel_next: np.ndarray | None = None) -> np.ndarray:
        """plugin_state after one mj_step from d.  Explicit: with the kinematics of the
        start of the step.  Implicit: with the slips of the step's end, J qvel_next."""
        state = d.plugin_state.copy()
        implicit = self.params.coupling == "implicit"
        if implicit:
            _, _, J, contacts = self.implicit_solve(d)
        for w, wheel in enumerate(self.wheels):
            st = self._state(state, w)
            contact = (contacts[w] if implicit else
                       wheel_contact(self.m, d, wheel, self.floors, self.params, self.splines))
            if contact is None:
                reset_state(st)
                continue
            k = contact[0]
            if implicit and normal_force(self.params, k) > 0:
                k = dataclasses.replace(k, slip_x=float(J[2 * w] @ qvel_next),
                                        slip_y=float(J[2 * w + 1] @ qvel_next))
            advance(self.params, k, self.m.opt.timestep, st)
        return state
