"""skidsteer: the extended Pioneer 3-AT of Mafrica (2012) in MuJoCo.

Importing the package registers the ``skidsteer.tire`` engine plugin, after
which ``mujoco.MjModel.from_xml_path("models/pioneer3at_extended.xml")`` works.
"""

from skidsteer._plugin import PLUGIN_NAME, register as _register

_register()

from skidsteer.models import FLOORS, BUILDS, load_model, model_path  # noqa: E402

__all__ = ["PLUGIN_NAME", "FLOORS", "BUILDS", "load_model", "model_path"]
__version__ = "0.1.0"
