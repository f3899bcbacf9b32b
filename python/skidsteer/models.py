"""The MJCF models and how to load them with a chosen floor and tire parameters."""

from __future__ import annotations

import dataclasses
import importlib.resources
from pathlib import Path
from typing import Callable, Mapping

import mujoco
import numpy as np

from skidsteer._plugin import PLUGIN_NAME
from skidsteer.tire_reference import FLOOR_FRICTION, TireParams

BUILDS: dict[str, str] = {
    "extended": "pioneer3at_extended.xml",  # platform + mast, laptop, camera
    "platform": "pioneer3at.xml",  # bare platform ("noFrame" in the thesis)
}
FLOORS: tuple[str, ...] = tuple(FLOOR_FRICTION)
# The model as the thesis published it (Ch. 5-6), as a configuration of ours:
# the inertia identified from the free responses, eq. 5.10 (principal, about the
# CoM; I_x and I_y ~10x the SolidWorks tensor of eq. 5.1), and the contact point
# of eq. 6.4 as its Simulink model integrates it (relay flag, kinetic friction
# dropped).  Everything else (Table 5.1, K, D, mu, m_t, lambda_max) is shared.
THESIS_INERTIA_EQ_5_10 = (9.82, 19.83, 0.97)  # kg m^2
VARIANTS: tuple[str, ...] = ("ours", "thesis")
TIRE_ATTRIBUTES: tuple[str, ...] = (
    "floor", "radius", *(f.name for f in dataclasses.fields(TireParams)))


def models_dir() -> Path:
    """models/ shipped in the package (pip install .), else the source checkout's
    (pip install -e . and running from the repository)."""
    marker = BUILDS["extended"]
    installed = importlib.resources.files("skidsteer") / "models"
    if (installed / marker).is_file():
        return Path(str(installed))
    checkout = Path(__file__).resolve().parents[2] / "models"
    if (checkout / marker).is_file():
        return checkout
    raise FileNotFoundError("skidsteer: the models/ directory was not installed with the "
                            "package; reinstall with `pip install .`")


def model_path(build: str = "extended") -> Path:
    """Path of a built-in model by build name, or of a user's MJCF file."""
    if build in BUILDS:
        return models_dir() / BUILDS[build]
    path = Path(build)
    if path.suffix.lower() == ".xml":
        if not path.is_file():
            raise FileNotFoundError(f"model file {path} does not exist")
        return path
    raise ValueError(f"unknown model {build!r}: use one of {sorted(BUILDS)} or a path to an "
                     "MJCF .xml file")


def tire_instance(spec: mujoco.MjSpec):
    """The skidsteer.tire plugin instance of a model spec."""
    instances = [p for p in spec.plugins if p.plugin_name == PLUGIN_NAME]
    if len(instances) != 1:
        raise ValueError(f"model {spec.modelname!r} has {len(instances)} {PLUGIN_NAME} "
                         "instances; skidsteer expects exactly one")
    return instances[0]


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


def _apply_thesis_inertia(m: mujoco.MjModel) -> None:
    """Sets the composite inertia about the CoM to eq. 5.10 by changing the chassis's.

    eq. 5.10 breaks the triangle inequality (I_x + I_z = 10.79 < I_y = 19.83):
    no rigid body has it, so the MJCF compiler rejects it.  The equations of
    motion only need a positive-definite tensor, so it is written into the
    compiled model, as the thesis's Simulink model used it.
    """
    chassis = m.body("chassis").id
    _, _, composite = composite_inertia(m, mujoco.MjData(m), chassis)
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, m.body_iquat[chassis])
    rot = rot.reshape(3, 3)  # chassis inertia axes in the chassis frame
    current = rot @ np.diag(m.body_inertia[chassis]) @ rot.T
    # a tensor added at the chassis CoM adds to the composite about the
    # composite CoM unchanged (the parallel-axis terms do not move)
    target = current + np.diag(THESIS_INERTIA_EQ_5_10) - composite
    moments, axes = np.linalg.eigh(target)
    if np.linalg.det(axes) < 0:
        axes[:, 0] *= -1
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, axes.flatten())
    m.body_inertia[chassis] = moments
    m.body_iquat[chassis] = quat
    mujoco.mj_setConst(m, mujoco.MjData(m))  # derived constants (invweight0, ...)


def load_spec(build: str = "extended", floor: str | None = None,
              tire: Mapping[str, float | str] | None = None,
              timestep: float | None = None, variant: str = "ours") -> mujoco.MjSpec:
    """The model as an MjSpec, with the floor and tire attributes overridden.

    variant="thesis" is the model as the thesis published it (see VARIANTS);
    its identified inertia belongs to the extended robot only and, being no
    rigid body's, is set on the compiled model by load_model.
    """
    if variant not in VARIANTS:
        raise ValueError(f"unknown model variant {variant!r}: use one of {list(VARIANTS)}")
    spec = mujoco.MjSpec.from_file(str(model_path(build)))
    overrides: dict[str, str] = {}
    if variant == "thesis":
        overrides["contact_point"] = "relay"  # the inertia is set by load_model
    if floor is not None:
        if floor not in FLOORS:
            raise ValueError(f"unknown floor {floor!r}: use one of {list(FLOORS)}")
        overrides["floor"] = floor
    for key, value in (tire or {}).items():
        if key not in TIRE_ATTRIBUTES:
            raise ValueError(f"unknown tire attribute {key!r}: the {PLUGIN_NAME} attributes "
                             f"are {list(TIRE_ATTRIBUTES)}")
        overrides[key] = str(value)
    if overrides:
        instance = tire_instance(spec)
        config = dict(instance.config)
        config.update(overrides)
        instance.config = config
    if timestep is not None:
        if not timestep > 0:
            raise ValueError(f"timestep must be > 0 s, got {timestep}")
        spec.option.timestep = timestep
    return spec


def load_model(build: str = "extended", floor: str | None = None,
               tire: Mapping[str, float | str] | None = None,
               timestep: float | None = None, variant: str = "ours",
               edit: Callable[[mujoco.MjSpec], None] | None = None) -> mujoco.MjModel:
    """Compiles a model; a bad tire attribute raises ValueError naming it.

    edit(spec), if given, changes the spec before compiling (an experiment's rig).
    """
    spec = load_spec(build, floor, tire, timestep, variant)
    if edit is not None:
        edit(spec)
    m = spec.compile()
    if variant == "thesis" and build == "extended":
        _apply_thesis_inertia(m)
    return m


def tire_config(build: str = "extended", floor: str | None = None,
                tire: Mapping[str, float | str] | None = None,
                variant: str = "ours") -> dict[str, str]:
    """The tire plugin attributes that load_model(build, floor, tire, variant=...) compiles."""
    return dict(tire_instance(load_spec(build, floor, tire, variant=variant)).config)
