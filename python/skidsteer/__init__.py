"""skidsteer: skid-steer robot vibrations in MuJoCo, held against measured data.

Importing the package registers the ``skidsteer.tire`` engine plugin, after
which ``mujoco.MjModel.from_xml_path("models/pioneer3at/pioneer3at_extended.xml")``
works.  The package is organised by stage, each importing only the ones before
it (docs/architecture.md): robot -> data -> features -> simulation ->
experiments (the thesis's rigs), diagnosis and tasks (dm-control), side by side
-> reports -> cli.
"""

from skidsteer.robot.plugin import PLUGIN_NAME, register as _register

_register()

from skidsteer.version import __version__  # noqa: E402
from skidsteer.robot import (DEFAULT_ROBOT, Setup, load_model, load_robot,  # noqa: E402
                             model_path)

_DEFAULT = load_robot(DEFAULT_ROBOT)
BUILDS: tuple[str, ...] = tuple(_DEFAULT.builds)  # the default robot's builds
FLOORS: tuple[str, ...] = tuple(_DEFAULT.floors)  # and its floors

__all__ = ["__version__", "PLUGIN_NAME", "BUILDS", "DEFAULT_ROBOT", "FLOORS", "Setup", "load_model",
           "load_robot", "model_path"]
