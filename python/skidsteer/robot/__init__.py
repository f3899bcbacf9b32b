"""The robot stage: the tire plugin's contract, robots as data, setups and their models.

``load_model(Setup(...))`` (or ``load_model("extended", "carpet")``) is the entry
point; ``load_robot(name)`` reads a robot's description (models/<name>/robot.toml);
``roles_of(m)`` says which parts of a compiled model are its wheels, drive and sensors.
"""

from skidsteer.robot.description import (BASE_VARIANT, DEFAULT_ROBOT, Robot, load_robot,
                                         models_dir, robot_names)
from skidsteer.robot.model import (PLATFORM_MOUNT, Setup, composite_inertia, load_model,
                                   load_spec, model_path, resolve, set_composite_inertia,
                                   tire_config)
from skidsteer.robot.roles import Roles, roles_of

__all__ = ["BASE_VARIANT", "DEFAULT_ROBOT", "PLATFORM_MOUNT", "Robot", "Roles", "Setup",
           "composite_inertia", "load_model", "load_robot", "load_spec", "model_path",
           "models_dir", "resolve", "robot_names", "roles_of", "set_composite_inertia", "tire_config"]
