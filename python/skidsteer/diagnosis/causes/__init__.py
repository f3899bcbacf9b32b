"""Candidate causes: physical extensions of the model that diagnose fits and ranks.

A cause is one module in this package that defines ``CAUSE = Cause(...)``:
its main parameter (the one the diagnosis fits, with bounds and a documented
prior), the parameters it holds at stated values, and ``apply(spec, params,
seed)``, which edits an MjSpec of the robot in place.  Adding a cause is adding
a module; the registry finds it.  ``seed`` picks the realisation of causes
with a random geometry (a rough floor, the phases of eccentric wheels); the
diagnosis never knows the realisation behind measured data, so its features
are statistical (band powers, line powers), not phase-exact, and it picks the
realisation, among a few draws, that fits the training runs best.
"""

from __future__ import annotations

import dataclasses
import importlib
import pkgutil
from typing import Callable, Mapping

import mujoco
import numpy as np

from skidsteer.robot import roles


# generator (synth) draws of a clear defect: at least 40 % of the prior's (log) range
# from the value where the cause vanishes (assumed: the nearer 40 % holds the
# defects too small to matter, the remaining 60 % still spans a decade or more)
STRONG_DISTANCE = 0.4


class NotApplicable(ValueError):
    """The cause cannot be applied to this model (a part it needs is missing)."""


@dataclasses.dataclass(frozen=True)
class Parameter:
    name: str  # SI unit in the name: *_m, *_hz, *_n_m_per_rad; plain for ratios
    low: float
    high: float
    value: float  # the prior's central value; the value held when not fitted
    log: bool  # prior uniform in log(value) (scale parameters) or in value
    source: str  # where the bounds and value come from

    def to_unit(self, x: float) -> float:
        """Prior coordinate in [0, 1] (log or linear)."""
        if self.log:
            return float((np.log(x) - np.log(self.low)) / (np.log(self.high) - np.log(self.low)))
        return float((x - self.low) / (self.high - self.low))

    def from_unit(self, u):
        u = np.clip(u, 0.0, 1.0)
        if self.log:
            return np.exp(np.log(self.low) + u * (np.log(self.high) - np.log(self.low)))
        return self.low + u * (self.high - self.low)

    def draw(self, rng: np.random.Generator) -> float:
        return float(self.from_unit(rng.uniform()))

    def levels(self, n: int) -> np.ndarray:
        """The middles of n equal (log or linear) slices of the prior: a coarse design's
        levels of this parameter (Cause.design)."""
        return self.from_unit((np.arange(n) + 0.5) / n)


@dataclasses.dataclass(frozen=True)
class Cause:
    name: str
    summary: str  # one line for reports
    main: Parameter  # fitted by diagnose
    held: tuple[Parameter, ...]  # held at their values
    apply: Callable[[mujoco.MjSpec, Mapping[str, float], int], None]
    # recovery tolerance of the main parameter: the fitted value is within this
    # factor of the truth on the generator's data (tests/test_diagnose.py).  Set
    # before the tests ran, not fitted to them: 1.5 (~15-20 % of a 1.5-2 decade prior)
    # for amplitudes and stiffnesses, whose band powers change as their square; 1.25 for
    # a resonance frequency, which the spectra place within a band; 1.15 for mu_s,
    # which scales every tire force and the start-up breakaway linearly
    recovery_factor: float
    # the main parameter's value at which the cause vanishes (the base model), or
    # the end of its prior nearest to it
    null_value: float
    # True when apply's seed changes the geometry (a rough floor, wheel phases):
    # the diagnosis then chooses the realisation too (diagnosis.search.fit_cause)
    random_realisation: bool = False
    # parameters -> the same kind of effect on the other branch of an ambiguity the
    # features leave (a frame's roll and pitch stiffnesses exchanged): the diagnosis
    # also searches from a fit's mirror image (diagnosis.search.fit_every_parameter)
    mirror: Callable[[Mapping[str, float]], dict[str, float]] | None = None
    # () -> parameter sets a fit of every parameter also starts from (a coarse design over
    # parameters the main parameter's one-dimensional fit says nothing about: a frame's
    # roll and pitch stiffnesses, a floor's correlation length); the search starts from
    # the best of them and the main fit (diagnosis.search.fit_every_parameter)
    design: Callable[[], list[dict[str, float]]] | None = None
    # how far (m) the robot's centre may move from its start with the cause's geometry
    # still under every wheel (a rough floor is a finite heightfield); None: anywhere.
    # A dataset whose commands drive farther is not fitted (check_reach)
    reach_m: float | None = None

    @property
    def priors(self) -> dict[str, Parameter]:
        """Every parameter's prior by name, the main one first."""
        return {p.name: p for p in (self.main, *self.held)}

    def parameters(self, main_value: float | None = None,
                   overrides: Mapping[str, float] | None = None) -> dict[str, float]:
        values = {name: p.value for name, p in self.priors.items()}
        if main_value is not None:
            values[self.main.name] = float(main_value)
        for key, value in (overrides or {}).items():
            if key not in values:
                raise ValueError(f"cause {self.name!r} has no parameter {key!r}; "
                                 f"its parameters are {sorted(values)}")
            values[key] = float(value)
        return values

    def strong_draw(self, rng: np.random.Generator, distance: float = STRONG_DISTANCE) -> float:
        """A main-parameter value drawn from the prior at least `distance` (in prior
        coordinates, 0-1) from the null value: a defect clear of the base model."""
        u0 = self.main.to_unit(self.null_value)
        pieces = [(0.0, u0 - distance), (u0 + distance, 1.0)]
        pieces = [(a, b) for a, b in pieces if b > a]
        lengths = np.array([b - a for a, b in pieces])
        x = rng.uniform(0, lengths.sum())
        for (a, b), length in zip(pieces, lengths):
            if x <= length:
                return float(self.main.from_unit(a + x))
            x -= length
        return float(self.main.from_unit(pieces[-1][1]))

    def check_reach(self, commands, duration_s: float) -> None:
        """Raises NotApplicable when one of the commands ((v_x m/s, omega_z deg/s) pairs)
        drives the robot's centre beyond reach_m within duration_s: its simulations would
        run off the cause's geometry (off a rough floor's edge the wheels find no floor
        and the robot falls), and their features would be scored as if they were real."""
        if self.reach_m is None:
            return
        for v_mps, omega_deg_s in commands:
            travel = travel_m(v_mps, omega_deg_s, duration_s)
            if travel > self.reach_m:
                raise NotApplicable(
                    f"{self.name}: the command v = {v_mps:g} m/s, omega = {omega_deg_s:g} "
                    f"deg/s drives the robot {travel:.2f} m from its start in {duration_s:g} s, "
                    f"beyond the {self.reach_m:g} m its geometry covers")

    def edit(self, params: Mapping[str, float], seed: int = 0):
        """An edit(spec) callable for models.load_model."""
        def edit(spec: mujoco.MjSpec) -> None:
            self.apply(spec, params, seed)
        return edit


def _discover() -> dict[str, Cause]:
    causes: dict[str, Cause] = {}
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        cause = getattr(module, "CAUSE", None)
        if not isinstance(cause, Cause):
            raise TypeError(f"skidsteer.causes.{info.name} defines no CAUSE = Cause(...)")
        if cause.name in causes:
            raise ValueError(f"two causes named {cause.name!r}")
        causes[cause.name] = cause
    return causes


def travel_m(v_mps: float, omega_deg_s: float, duration_s: float) -> float:
    """The farthest a robot's centre gets from its start under a constant command, its
    start-up aside: |v| T on a straight run, at most the circle's diameter 2 |v| / |omega|
    on an arc (0 turning in place)."""
    straight = abs(v_mps) * duration_s
    if omega_deg_s == 0:
        return straight
    return min(straight, 2 * abs(v_mps) / np.deg2rad(abs(omega_deg_s)))


# ------------------------------------------------------------ helpers for causes

def part(spec: mujoco.MjSpec, role: str, cause: str):
    """The body the model names as its `role` part (robot.roles: skidsteer.part.ROLE)."""
    b = roles.spec_part(spec, role)
    if b is None:
        raise NotApplicable(f"cause {cause!r} needs the model to name its {role} "
                            f"(<custom><text name=\"skidsteer.part.{role}\" data=\"BODY\"/>"
                            "</custom>)")
    return b


def sensor_site(spec: mujoco.MjSpec, role: str = "accelerometer"):
    """The site the model's accelerometer (or gyro) is attached to."""
    s = roles.spec_sensor(spec, role)
    if s is None:
        raise NotApplicable(f"the model has no {role}")
    return spec.site(s.objname)


def mount_sensors(spec: mujoco.MjSpec, name: str, mass: float, frequency_hz: float,
                  damping_ratio: float, axes: dict[str, list[float]]):
    """Moves the accelerometer and the gyro onto a small box body `name` of `mass` at the
    accelerometer's site, sliding along each named axis on a spring and a damper
    (add_spring_slides); returns the body."""
    site = sensor_site(spec, "accelerometer")
    if site.parent is None:
        raise NotApplicable(f"{name}: the accelerometer's site has no body")
    body = site.parent.add_body(name=name, pos=list(site.pos), quat=list(site.quat))
    body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, 0.02, 0.02],
                  mass=mass, contype=0, conaffinity=0, group=3)
    add_spring_slides(body, mass, frequency_hz, damping_ratio, axes)
    body.add_site(name=f"{name}_site")
    for role in ("accelerometer", "gyro"):
        sensor = roles.spec_sensor(spec, role)
        if sensor is not None:
            sensor.objname = f"{name}_site"
    return body


def critical_damping(stiffness: float, inertia: float, ratio: float) -> float:
    """Viscous damping of a spring-mass (or torsion-inertia) at a damping ratio."""
    return 2.0 * ratio * float(np.sqrt(stiffness * inertia))


def add_spring_slides(body, mass: float, frequency_hz: float, damping_ratio: float,
                      axes: dict[str, list[float]]) -> None:
    """Frees body to slide along each named axis on a spring and a damper that give a
    mass of `mass` the natural frequency and damping ratio."""
    k = mass * (2 * np.pi * frequency_hz) ** 2
    c = critical_damping(k, mass, damping_ratio)
    for name, axis in axes.items():
        body.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis, stiffness=k,
                       damping=c)


CAUSES: dict[str, Cause] = _discover()


def get(name: str) -> Cause:
    if name not in CAUSES:
        raise ValueError(f"unknown cause {name!r}: the candidates are {sorted(CAUSES)}")
    return CAUSES[name]
