"""A run's setup and the MuJoCo model that simulates it.

``Setup`` says what a run was recorded (or is simulated) on: which robot, which
of its builds, on which floor, with the accelerometer where, and which variant
of the model.  ``load_spec(setup)`` is that model as an MjSpec (the build's MJCF
with the floor's tire attributes, the accelerometer moved, any edit), and
``load_model(setup)`` compiles it; every part of the package that needs a model
for a setup goes through these two, so a report's extended model and a fit's
are the same model.
"""

from __future__ import annotations

import math

import dataclasses
from pathlib import Path
from typing import Callable, Mapping

import mujoco
import numpy as np

from skidsteer.robot import roles
from skidsteer.robot import tire as tire_plugin
from skidsteer.robot.description import BASE_VARIANT, DEFAULT_ROBOT, Robot, load_robot

PLATFORM_MOUNT = "platform"  # the accelerometer where the robot's MJCF puts it
MOUNT_SITE = "skidsteer_mounted_accelerometer"

Edit = Callable[[mujoco.MjSpec], None]


@dataclasses.dataclass(frozen=True)
class Setup:
    """What a run is on.  robot: a robot's name (models/<name>/), its folder, or the path
    of one MJCF file; build and floor: the robot's (None: its default build, and the
    floor its MJCF has); mount: where the accelerometer is ("platform": where the MJCF
    puts it, else one of the robot's mounts); accel_position_m: the accelerometer's
    site moved there (the body's frame), None to leave it; variant: "ours" (the MJCF
    as written) or one of the robot's variants."""

    robot: str = DEFAULT_ROBOT
    build: str | None = None
    floor: str | None = None
    mount: str = PLATFORM_MOUNT
    accel_position_m: tuple[float, float, float] | None = None
    variant: str = BASE_VARIANT

    @property
    def label(self) -> str:
        """Build, floor and mount in a few words, for tables and figure legends."""
        parts = [self.build or "default build", self.floor or "default floor"]
        if self.mount != PLATFORM_MOUNT:
            parts.append(f"cube on {self.mount}")
        if self.variant != BASE_VARIANT:
            parts.append(f"{self.variant} model")
        return ", ".join(parts)


def resolve(setup: Setup) -> Setup:
    """The setup with its robot's default build and floor filled in where it has None
    (a floor stays None for a robot whose MJCF sets none of its named floors)."""
    robot = load_robot(setup.robot)
    return dataclasses.replace(setup, build=setup.build or robot.default_build,
                               floor=setup.floor or robot.default_floor)


def model_path(build: str = "extended", robot: str = DEFAULT_ROBOT) -> Path:
    """The MJCF file of a build of a robot (or a path to an MJCF file, returned as is)."""
    return _robot_and_build(build, robot)[1]


def _robot_and_build(build: str | None, robot: str | Robot) -> tuple[Robot, Path]:
    """A build name of the robot, or a path to an MJCF file (a robot of its own)."""
    if build is not None and (build.lower().endswith(".xml") or "/" in build):
        r = load_robot(build)
        return r, r.build(None).file
    r = load_robot(robot)
    if build is not None and r.single_file is None and build not in r.builds:
        raise ValueError(f"unknown model {build!r}: use one of {sorted(r.builds)} (the builds "
                         f"of {r.name}) or a path to an MJCF .xml file")
    return r, r.build(build).file


def _as_setup(setup: Setup | str, floor: str | None, variant: str | None) -> Setup:
    if isinstance(setup, Setup):
        if floor is not None or variant is not None:
            setup = dataclasses.replace(setup, **{k: v for k, v in (("floor", floor),
                                                                       ("variant", variant))
                                                   if v is not None})
        return setup
    if setup.lower().endswith(".xml") or "/" in setup:
        return Setup(robot=setup, floor=floor, variant=variant or BASE_VARIANT)
    return Setup(build=setup, floor=floor, variant=variant or BASE_VARIANT)


def load_spec(setup: Setup | str = "extended", floor: str | None = None,
              tire: Mapping[str, float | str] | None = None, timestep: float | None = None,
              variant: str | None = None, edit: Edit | None = None) -> mujoco.MjSpec:
    """The setup's model as an MjSpec: the build's MJCF, the variant's and the floor's
    tire attributes, then `tire`'s, the accelerometer where the setup has it, the time
    step, then edit(spec) (a cause, an experiment's rig).

    setup may be a build name of the default robot or an MJCF path, with floor and
    variant given separately (``load_spec("extended", "carpet")``).  Bad names raise
    ValueError naming them before anything compiles.
    """
    setup = _as_setup(setup, floor, variant)
    robot, path = _robot_and_build(setup.build, setup.robot)
    chosen_variant = robot.variant(setup.variant)
    overrides: dict[str, float | str] = {}
    if chosen_variant is not None:
        overrides.update(chosen_variant.tire)
    if setup.floor is not None:
        overrides.update(robot.floor(setup.floor).attributes)
    overrides.update(tire or {})
    spec = mujoco.MjSpec.from_file(str(path))
    tire_plugin.configure(spec, overrides)
    if setup.mount != PLATFORM_MOUNT:
        _mount_accelerometer(spec, robot.mount(setup.mount))
    if setup.accel_position_m is not None:
        sensor = roles.spec_sensor(spec, "accelerometer")
        if sensor is None:
            raise ValueError("the model has no accelerometer to place")
        spec.site(sensor.objname).pos = list(setup.accel_position_m)
    if timestep is not None:
        if not (math.isfinite(timestep) and timestep > 0):
            raise ValueError(f"timestep must be a finite number > 0 s, got {timestep!r}")
        spec.option.timestep = timestep
    if edit is not None:
        edit(spec)
    return spec


def _mount_accelerometer(spec: mujoco.MjSpec, mount) -> None:
    """Moves the accelerometer and gyro onto a site at the mount (Sec. 3.2: "fixed the
    wood-cube to one tire")."""
    body = spec.body(mount.body)
    if body is None:
        raise ValueError(f"mount {mount.name!r} names body {mount.body!r}, which the model "
                         "does not have")
    body.add_site(name=MOUNT_SITE, pos=list(mount.pos_m), size=[0.02, 0.02, 0.02],
                  type=mujoco.mjtGeom.mjGEOM_BOX)
    for role in ("accelerometer", "gyro"):
        sensor = roles.spec_sensor(spec, role)
        if sensor is not None:
            sensor.objname = MOUNT_SITE


def load_model(setup: Setup | str = "extended", floor: str | None = None,
               tire: Mapping[str, float | str] | None = None, timestep: float | None = None,
               variant: str | None = None, edit: Edit | None = None) -> mujoco.MjModel:
    """load_spec(...) compiled; a bad tire attribute raises ValueError naming it.

    A variant with a composite inertia (the thesis's eq. 5.10, which no rigid body has)
    sets it on the compiled model, as the thesis's Simulink model used it.
    """
    setup = _as_setup(setup, floor, variant)
    spec = load_spec(setup, tire=tire, timestep=timestep, edit=edit)
    m = spec.compile()
    robot, _ = _robot_and_build(setup.build, setup.robot)
    chosen = robot.variant(setup.variant)
    build = robot.build(setup.build).name
    if chosen is not None and chosen.composite_inertia_kg_m2 and build in chosen.inertia_builds:
        set_composite_inertia(m, chosen.composite_inertia_kg_m2)
    return m


def tire_config(setup: Setup | str = "extended", floor: str | None = None,
                tire: Mapping[str, float | str] | None = None,
                variant: str | None = None) -> dict[str, str]:
    """The tire plugin attributes that load_model(setup, floor, tire=..., variant=...)
    compiles."""
    return dict(tire_plugin.instance(load_spec(setup, floor, tire, variant=variant)).config)


# ------------------------------------------------------------------ inertia

def composite_inertia(m: mujoco.MjModel, d: mujoco.MjData, root: int = 1):
    """Mass, CoM (world) and inertia about the CoM of root's subtree, in root's axes."""
    mujoco.mj_forward(m, d)
    bodies = [b for b in range(m.nbody) if b == root or m.body_rootid[b] == root]
    mass = sum(m.body_mass[b] for b in bodies)
    com = sum(m.body_mass[b] * d.xipos[b] for b in bodies) / mass
    inertia = np.zeros((3, 3))
    for b in bodies:
        rot = d.ximat[b].reshape(3, 3)
        offset = d.xipos[b] - com
        inertia += rot @ np.diag(m.body_inertia[b]) @ rot.T
        inertia += m.body_mass[b] * (offset @ offset * np.eye(3) - np.outer(offset, offset))
    frame = d.xmat[root].reshape(3, 3)
    return mass, com, frame.T @ inertia @ frame


def set_composite_inertia(m: mujoco.MjModel, principal_kg_m2) -> None:
    """Sets the robot's composite inertia about its CoM to diag(principal_kg_m2) (in the
    chassis axes) by changing the chassis body's own inertia.

    The thesis's eq. 5.10 breaks the triangle inequality (I_x + I_z = 10.79 <
    I_y = 19.83): no rigid body has it, so the MJCF compiler rejects it.  The equations
    of motion only need a positive-definite tensor, so it is written into the compiled
    model.
    """
    chassis = roles.roles_of(m).chassis
    _, _, composite = composite_inertia(m, mujoco.MjData(m), chassis)
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, m.body_iquat[chassis])
    rot = rot.reshape(3, 3)  # chassis inertia axes in the chassis frame
    current = rot @ np.diag(m.body_inertia[chassis]) @ rot.T
    # a tensor added at the chassis CoM adds to the composite about the
    # composite CoM unchanged (the parallel-axis terms do not move)
    target = current + np.diag(principal_kg_m2) - composite
    moments, axes = np.linalg.eigh(target)
    if np.linalg.det(axes) < 0:
        axes[:, 0] *= -1
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, axes.flatten())
    m.body_inertia[chassis] = moments
    m.body_iquat[chassis] = quat
    mujoco.mj_setConst(m, mujoco.MjData(m))  # derived constants (invweight0, ...)
