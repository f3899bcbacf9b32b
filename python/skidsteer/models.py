"""The MJCF models and how to load them with a chosen floor and tire parameters."""

from __future__ import annotations

import dataclasses
import importlib.resources
from pathlib import Path
from typing import Mapping

import mujoco

from skidsteer._plugin import PLUGIN_NAME
from skidsteer.tire_reference import FLOOR_FRICTION, TireParams

BUILDS: dict[str, str] = {
    "extended": "pioneer3at_extended.xml",  # platform + mast, laptop, camera
    "platform": "pioneer3at.xml",  # bare platform ("noFrame" in the thesis)
}
FLOORS: tuple[str, ...] = tuple(FLOOR_FRICTION)
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


def load_spec(build: str = "extended", floor: str | None = None,
              tire: Mapping[str, float | str] | None = None,
              timestep: float | None = None) -> mujoco.MjSpec:
    """The model as an MjSpec, with the floor and tire attributes overridden."""
    spec = mujoco.MjSpec.from_file(str(model_path(build)))
    overrides: dict[str, str] = {}
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
               timestep: float | None = None) -> mujoco.MjModel:
    """Compiles a model; a bad tire attribute raises ValueError naming it."""
    return load_spec(build, floor, tire, timestep).compile()


def tire_config(build: str = "extended", floor: str | None = None,
                tire: Mapping[str, float | str] | None = None) -> dict[str, str]:
    """The tire plugin attributes that load_model(build, floor, tire) compiles."""
    return dict(tire_instance(load_spec(build, floor, tire)).config)
