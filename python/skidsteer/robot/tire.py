"""The skidsteer.tire plugin seen from Python: its contract, its wheels, its state.

The contract (attributes with defaults, bounds, units and sources; the floors it
knows by name; the layout of its state) is read from the loaded plugin library
itself (plugin/tire/tire_contract.h, through ctypes), so the C validation, this
module and the plugin README's attribute table (``attributes_markdown``) share
one table.

The plugin treats as a wheel every body that names its instance
(``find_wheels`` lists them in the order the plugin does), and as the floor
every plane or heightfield of the world body (``floor_geoms``).  Its state, per
wheel and direction [deflection s, contact-point velocity v_c, stuck flag], is
read and written through ``TireState``, never by index.
"""

from __future__ import annotations

import ctypes
import dataclasses
import functools
import math

import mujoco
import numpy as np

from skidsteer.robot import plugin

PLUGIN_NAME = plugin.PLUGIN_NAME


# ------------------------------------------------------------------ the contract

class _Attribute(ctypes.Structure):
    _fields_ = [("name", ctypes.c_char_p), ("symbol", ctypes.c_char_p),
                ("kind", ctypes.c_int), ("default_value", ctypes.c_double),
                ("default_text", ctypes.c_char_p), ("low", ctypes.c_double),
                ("high", ctypes.c_double), ("low_open", ctypes.c_int),
                ("high_open", ctypes.c_int), ("finite", ctypes.c_int),
                ("choices", ctypes.c_char_p), ("unit", ctypes.c_char_p),
                ("rule", ctypes.c_char_p), ("source", ctypes.c_char_p)]


class _Floor(ctypes.Structure):
    _fields_ = [("name", ctypes.c_char_p), ("mu_static", ctypes.c_double),
                ("mu_kinetic", ctypes.c_double), ("source", ctypes.c_char_p)]


class _Layout(ctypes.Structure):
    _fields_ = [("version", ctypes.c_int), ("ndirection", ctypes.c_int),
                ("nstate_direction", ctypes.c_int), ("deflection", ctypes.c_int),
                ("velocity", ctypes.c_int), ("stuck", ctypes.c_int),
                ("nsensor_wheel", ctypes.c_int)]


CONTRACT_VERSION = 2  # SKIDSTEER_TIRE_CONTRACT_VERSION this module reads (2: integer kind)


@dataclasses.dataclass(frozen=True)
class Attribute:
    """One attribute of the plugin (tire_contract.h)."""

    name: str
    symbol: str
    kind: str  # "number", "integer" or "choice"
    default: float | str | None  # a number, a choice's word, or None ("from floor", "from geom")
    default_text: str
    low: float
    high: float
    low_open: bool
    high_open: bool
    finite: bool
    choices: tuple[str, ...]
    unit: str
    rule: str
    source: str

    def valid(self, value) -> bool:
        """Whether the plugin accepts the value (numbers: bounds and finiteness)."""
        if self.kind == "choice":
            return value in self.choices
        value = float(value)
        if math.isnan(value) or (self.finite and not math.isfinite(value)):
            return False
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        whole = self.kind != "integer" or value == int(value)
        return above and below and whole


@dataclasses.dataclass(frozen=True)
class Floor:
    """A floor the plugin knows by name (its `floor` attribute)."""

    name: str
    mu_static: float
    mu_kinetic: float
    source: str


@dataclasses.dataclass(frozen=True)
class StateLayout:
    ndirection: int
    nstate_direction: int
    deflection: int
    velocity: int
    stuck: int
    nsensor_wheel: int

    @property
    def nstate_wheel(self) -> int:
        return self.ndirection * self.nstate_direction


@functools.lru_cache(maxsize=None)
def _library() -> ctypes.CDLL:
    lib = ctypes.CDLL(str(plugin.register()))
    lib.skidsteer_tire_attributes.restype = ctypes.c_int
    lib.skidsteer_tire_attributes.argtypes = [ctypes.POINTER(ctypes.POINTER(_Attribute))]
    lib.skidsteer_tire_floors.restype = ctypes.c_int
    lib.skidsteer_tire_floors.argtypes = [ctypes.POINTER(ctypes.POINTER(_Floor))]
    lib.skidsteer_tire_layout.restype = ctypes.POINTER(_Layout)
    layout = lib.skidsteer_tire_layout().contents
    if layout.version != CONTRACT_VERSION:
        raise RuntimeError(f"{plugin.library_path()}: tire contract version {layout.version}, "
                           f"this skidsteer reads version {CONTRACT_VERSION}; reinstall")
    return lib


def _text(raw: bytes | None) -> str:
    return raw.decode() if raw else ""


@functools.lru_cache(maxsize=None)
def attributes() -> dict[str, Attribute]:
    """The plugin's attributes by name, in the plugin's order."""
    rows = ctypes.POINTER(_Attribute)()
    n = _library().skidsteer_tire_attributes(ctypes.byref(rows))
    out = {}
    for row in rows[:n]:
        kind = {1: "choice", 2: "integer"}.get(row.kind, "number")
        if kind == "choice":
            default = _text(row.default_text)
        else:
            default = None if math.isnan(row.default_value) else float(row.default_value)
        attribute = Attribute(
            _text(row.name), _text(row.symbol), kind, default, _text(row.default_text),
            row.low, row.high, bool(row.low_open), bool(row.high_open), bool(row.finite),
            tuple(_text(row.choices).split()), _text(row.unit), _text(row.rule),
            _text(row.source))
        out[attribute.name] = attribute
    return out


@functools.lru_cache(maxsize=None)
def floors() -> dict[str, Floor]:
    """The floors the plugin knows by name (the `floor` attribute), in its order."""
    rows = ctypes.POINTER(_Floor)()
    n = _library().skidsteer_tire_floors(ctypes.byref(rows))
    return {_text(r.name): Floor(_text(r.name), r.mu_static, r.mu_kinetic, _text(r.source))
            for r in rows[:n]}


@functools.lru_cache(maxsize=None)
def state_layout() -> StateLayout:
    layout = _library().skidsteer_tire_layout().contents
    return StateLayout(layout.ndirection, layout.nstate_direction, layout.deflection,
                       layout.velocity, layout.stuck, layout.nsensor_wheel)


def attributes_markdown() -> str:
    """The plugin README's attribute table, from the contract."""
    lines = ["| attribute | symbol | default | unit | valid | source |",
             "|---|---|---|---|---|---|"]
    for a in attributes().values():
        default = f"`{a.default_text}`" if a.kind == "choice" else a.default_text
        valid = ("one of " + ", ".join(f"`{c}`" for c in a.choices) if a.kind == "choice"
                 else a.rule.removeprefix("must ").removeprefix("be ").removeprefix("lie "))
        lines.append(f"| `{a.name}` | {a.symbol} | {default} | {a.unit} | {valid} | "
                     f"{a.source} |")
    return "\n".join(lines) + "\n"


def floors_markdown() -> str:
    """The plugin README's floor table, from the contract."""
    lines = ["| floor | `mu_static` | `mu_kinetic` | source |", "|---|---|---|---|"]
    lines += [f"| `{f.name}` | {f.mu_static:g} | {f.mu_kinetic:g} | {f.source} |"
              for f in floors().values()]
    return "\n".join(lines) + "\n"


def friction(config: dict[str, str]) -> tuple[float, float]:
    """(mu_static, mu_kinetic) that the plugin reads from an instance's attributes."""
    floor = floors()[config.get("floor") or attributes()["floor"].default]
    mu_s = float(config["mu_static"]) if config.get("mu_static") else floor.mu_static
    mu_k = float(config["mu_kinetic"]) if config.get("mu_kinetic") else floor.mu_kinetic
    return mu_s, mu_k


def instance(spec: mujoco.MjSpec):
    """The skidsteer.tire plugin instance of a model spec (there must be one)."""
    found = [p for p in spec.plugins if p.plugin_name == PLUGIN_NAME]
    if len(found) != 1:
        raise ValueError(f"model {spec.modelname!r} has {len(found)} {PLUGIN_NAME} "
                         "instances; skidsteer expects exactly one")
    return found[0]


def configure(spec: mujoco.MjSpec, overrides: dict[str, float | str]) -> None:
    """Sets attributes of the spec's tire instance; a name the plugin lacks is a
    ValueError naming it (before compiling)."""
    known = attributes()
    for key in overrides:
        if key not in known:
            raise ValueError(f"unknown tire attribute {key!r}: the {PLUGIN_NAME} attributes "
                             f"are {list(known)}")
    if overrides:
        inst = instance(spec)
        config = dict(inst.config)
        config.update({k: str(v) for k, v in overrides.items()})
        inst.config = config


def instance_id(m: mujoco.MjModel) -> int:
    """The tire plugin instance of a compiled model: the one instance that bodies (the
    wheels) name.  Other plugins attach to the model, not to bodies."""
    ids = sorted({int(i) for i in m.body_plugin if i >= 0})
    if len(ids) != 1:
        raise ValueError(f"the model's bodies name {len(ids)} plugin instances; skidsteer "
                         f"expects the wheels to name one {PLUGIN_NAME} instance")
    return ids[0]


# ------------------------------------------------------------------ wheels and floor

# geom types as ints: numpy ints never compare equal to pybind enum members
_CYLINDER, _SPHERE, _ELLIPSOID = (int(mujoco.mjtGeom.mjGEOM_CYLINDER),
                                  int(mujoco.mjtGeom.mjGEOM_SPHERE),
                                  int(mujoco.mjtGeom.mjGEOM_ELLIPSOID))
_PLANE, _HFIELD = int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_HFIELD)


@dataclasses.dataclass(frozen=True)
class Wheel:
    body: int  # body id
    joint: int  # its hinge (the axle)
    geom: int  # the geom whose centre is the wheel centre (-1: the body origin)
    radius: float  # unloaded radius, m


def find_wheels(m: mujoco.MjModel, instance: int = 0, radius: float = 0.0) -> list[Wheel]:
    """The wheels of a plugin instance, in body order (the plugin's order, that of its
    state and of the tire_forces sensor)."""
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
    """The plane and heightfield geoms of the world body: what the tires stand on."""
    start, count = m.body_geomadr[0], m.body_geomnum[0]
    return [g for g in range(start, start + count) if int(m.geom_type[g]) in (_PLANE, _HFIELD)]


def sensor(m: mujoco.MjModel, instance: int = 0) -> int | None:
    """The id of the plugin sensor of the instance (tire_forces), None without one."""
    for s in range(m.nsensor):
        if (int(m.sensor_type[s]) == int(mujoco.mjtSensor.mjSENS_PLUGIN)
                and int(m.sensor_plugin[s]) == instance):
            return s
    return None


# ------------------------------------------------------------------ state

class TireState:
    """Named views into the plugin's state of one instance in a state vector
    (``d.plugin_state`` or a copy): ``deflection``, ``velocity`` and ``stuck``, each
    (nwheel, 2) with columns x (longitudinal) and y (lateral).  Writes go through."""

    def __init__(self, m: mujoco.MjModel, plugin_state: np.ndarray, instance: int = 0):
        layout = state_layout()
        adr = int(m.plugin_stateadr[instance])
        n = int(m.plugin_statenum[instance])
        block = plugin_state[adr:adr + n]
        self.array = block.reshape(-1, layout.ndirection, layout.nstate_direction)
        self.deflection = self.array[:, :, layout.deflection]
        self.velocity = self.array[:, :, layout.velocity]
        self.stuck = self.array[:, :, layout.stuck]

    @property
    def nwheel(self) -> int:
        return self.array.shape[0]

    def reset(self) -> None:
        """No deflection, contact points at rest and sticking (the plugin's reset)."""
        self.deflection[:] = 0.0
        self.velocity[:] = 0.0
        self.stuck[:] = 1.0
