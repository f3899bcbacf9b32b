"""Causes of a discrepancy in how the robot moves, not how it shakes: the robot's and
the terrain's parameters that set its yaw rate for a wheel command.

A skid-steer robot turns slower than its wheels' geometry says (the effective-track
factor chi, 1 without slip).  With Coulomb friction and equal wheel loads, chi is set
by geometry alone, 1 + (a/c)^2 (a: half wheelbase, c: half track), whatever the
friction's level: the robot's mass layout, the tire law's shape and its drive decide
chi, the terrain only through how its friction differs across and along the tread.
So the parameters split in two:

- the **robot**'s, shared by every terrain it drives on: how its tires share a
  combined slip (``slip_law``), the saturation slip (``lambda_max``), the centre of
  mass (``com_x_m``, ``com_y_m``), and the drive: the rim speed per logged wheel speed
  (``logged_speed_scale``: what the wheel-speed channel of the recordings reads
  against what the wheels do);
- the **terrain**'s, one set per terrain: its friction level (``mu_static``, the
  kinetic at the floor's ratio) and its lateral over longitudinal friction
  (``lateral_friction_ratio``).

Each parameter has its prior (bounds, the value the base model has, its source) and
an ``apply`` on an MjSpec.  A motion cause groups the parameters one physical
explanation frees.
"""

from __future__ import annotations

import dataclasses
from typing import Mapping

import mujoco

from skidsteer.diagnosis import causes
from skidsteer.diagnosis.causes import NotApplicable, Parameter
from skidsteer.robot import roles, tire

ROBOT, TERRAIN = "robot", "terrain"

LOGGED_SPEED_SCALE = Parameter(
    "logged_speed_scale", 0.6, 1.8, 1.0, log=True,
    source="assumed: the wheels' rim speed per logged wheel speed; 1 when the log holds "
           "what the rims do; the prior spans a unit or radius mismatch in the logging "
           "chain (BorealTC's own code turns its speeds into wheel rates with a radius of "
           "0.13 m for the tyre's 0.1651 m: 1.27); checked against the centripetal "
           "acceleration, which sees the robot's true speed (features.segments)")
COM_X = Parameter(
    "com_x_m", -0.1, 0.1, 0.0, log=False,
    source="assumed: the centre of mass anywhere within +-0.1 m fore-aft of the axles' "
           "midpoint (a payload's place); value: the model's own (set from its MJCF)")
COM_Y = Parameter(
    "com_y_m", -0.1, 0.1, 0.0, log=False,
    source="assumed: the centre of mass anywhere within +-0.1 m of the centre line (a "
           "payload or battery off-centre; the Husky URDF's -0.085 m inside); value: the "
           "model's own (set from its MJCF)")
LAMBDA_MAX = causes.get("slip_lambda_max").main  # the accelerometer cause's prior
LATERAL_RATIO = Parameter(
    "lateral_friction_ratio", 0.5, 2.0, 1.0, log=True,
    source="assumed: a terrain's sliding friction across the tread over along it, from "
           "half to twice (grain, ruts, a surface's texture); value: 1, isotropic, as the "
           "thesis takes its lateral pulls (Sec. 3.3) for both directions")
TREAD_LATERAL_RATIO = Parameter(
    "tread_lateral_friction_ratio", 0.4, 1.5, 1.0, log=True,
    source="assumed: a tyre's sliding friction across its tread over along it on any "
           "floor, from 0.4 (lugs and blocks that grip along the tread and slide across "
           "it) to 1.5; value: 1, isotropic, as the thesis takes its lateral pulls (Sec. "
           "3.3) for both directions")
MU_STATIC = Parameter(
    "mu_static", 0.05, 1.2, 0.86, log=True,
    source="assumed: rubber tread on any rigid ground, 0.05 (wet ice) to 1.2 (rough, "
           "clean); log-uniform, a level's error being a factor; value: the model's "
           "floor's (Sec. 3.3's 0.86 by default)")


@dataclasses.dataclass(frozen=True)
class MotionParameter:
    """A parameter of the motion model: its prior and whether a robot or a terrain owns
    it (a terrain's is fitted once per terrain)."""

    prior: Parameter
    owner: str  # ROBOT or TERRAIN

    @property
    def name(self) -> str:
        return self.prior.name


def _chassis(spec: mujoco.MjSpec):
    bodies = [b for b in spec.worldbody.bodies
              if any(j.type == mujoco.mjtJoint.mjJNT_FREE for j in b.joints)]
    if len(bodies) != 1:
        raise NotApplicable("a motion cause needs one free-floating chassis body")
    return bodies[0]


def base_values(spec: mujoco.MjSpec) -> dict[str, float]:
    """Every motion parameter's value in the model as written (its base model)."""
    config = dict(tire.instance(spec).config)
    mu_s, _ = tire.friction(config)
    attributes = tire.attributes()

    def number(name: str) -> float:
        return float(config.get(name, attributes[name].default))

    chassis = _chassis(spec)
    return {"logged_speed_scale": roles.spec_numeric(spec, "drive.logged_speed_scale", 1.0),
            "com_x_m": float(chassis.ipos[0]), "com_y_m": float(chassis.ipos[1]),
            "lambda_max": number("lambda_max"),
            "lateral_friction_ratio": number("lateral_friction_ratio"),
            "tread_lateral_friction_ratio": number("tread_lateral_friction_ratio"),
            "mu_static": float(mu_s)}


def apply(spec: mujoco.MjSpec, values: Mapping[str, float]) -> None:
    """Sets the given motion parameters on the spec (any subset; see base_values)."""
    settings: dict[str, str] = {}
    for name, value in values.items():
        if name == "slip_law":
            settings["slip_law"] = str(value)
        elif name in ("com_x_m", "com_y_m"):
            chassis = _chassis(spec)
            pos = list(chassis.ipos)
            pos[0 if name == "com_x_m" else 1] = float(value)
            chassis.ipos = pos
        elif name == "logged_speed_scale":
            roles.set_spec_numeric(spec, "drive.logged_speed_scale", float(value))
        elif name == "mu_static":
            mu_s, mu_k = tire.friction(dict(tire.instance(spec).config))
            settings["mu_static"] = repr(float(value))
            settings["mu_kinetic"] = repr(float(value) * mu_k / mu_s)
        elif name in ("lambda_max", "lateral_friction_ratio", "tread_lateral_friction_ratio"):
            settings[name] = repr(float(value))
        else:
            raise ValueError(f"unknown motion parameter {name!r}")
    if settings:
        tire.configure(spec, settings)


@dataclasses.dataclass(frozen=True)
class MotionCause:
    """A physical explanation of a motion discrepancy: the parameters it frees (robot's
    or terrain's) and the settings it makes (a law switched)."""

    name: str
    summary: str
    owner: str  # ROBOT or TERRAIN: whose property it is
    parameters: tuple[MotionParameter, ...]
    settings: Mapping[str, str] = dataclasses.field(default_factory=dict)


SPEED = MotionParameter(LOGGED_SPEED_SCALE, ROBOT)
MOTION_CAUSES = {c.name: c for c in (
    MotionCause("combined_slip", "the tires share a combined slip as Coulomb friction on the "
                "resultant slip velocity (the friction circle), not by eq. 4.12a/b's separate "
                "factors, whose resultant reaches sqrt(2) mu N", ROBOT, (),
                {"slip_law": "combined"}),
    MotionCause("wheel_speed_scale", "the wheels' rims turn at another speed than the "
                "recordings' wheel speeds say (the drive's calibration)", ROBOT, (SPEED,)),
    MotionCause("com_offset", "the centre of mass sits elsewhere than the model says", ROBOT,
                (MotionParameter(COM_X, ROBOT), MotionParameter(COM_Y, ROBOT))),
    MotionCause("slip_lambda_max", "the tire's saturation slip differs from the model's", ROBOT,
                (MotionParameter(LAMBDA_MAX, ROBOT),)),
    MotionCause("tread_anisotropy", "the tyres slide across their tread more easily (or "
                "less) than along it, on every floor", ROBOT,
                (MotionParameter(TREAD_LATERAL_RATIO, ROBOT),)),
    MotionCause("lateral_friction", "each terrain's friction across the tread differs from "
                "along it", TERRAIN, (MotionParameter(LATERAL_RATIO, TERRAIN),)),
    MotionCause("friction_levels", "each terrain's friction level differs from the floor's",
                TERRAIN, (MotionParameter(MU_STATIC, TERRAIN),)),
)}
