"""friction_levels: the floor's static and kinetic friction, re-identified.

Sec. 3.3 measured mu_s and mu_k with a pull test on three floors; a user's floor
is another.  The cause sets mu_static and keeps the measured kinetic-to-static
ratio of the floor (0.914 on concrete and tile, 0.914 on carpet; Sec. 3.3).
"""

from skidsteer.causes import Cause, Parameter
from skidsteer.models import tire_instance
from skidsteer.tire_reference import FLOOR_FRICTION

MU_STATIC = Parameter(
    "mu_static", 0.4, 1.2, 0.86, log=False,
    source="assumed: indoor floors under rubber tread, 0.4 (polished, dusty) to 1.2 (rubber "
           "on carpet); value: Sec. 3.3's concrete")


def apply(spec, params, seed: int = 0) -> None:
    instance = tire_instance(spec)
    config = dict(instance.config)
    mu_s, mu_k = FLOOR_FRICTION[config.get("floor") or "concrete"]
    config["mu_static"] = repr(float(params["mu_static"]))
    config["mu_kinetic"] = repr(float(params["mu_static"]) * mu_k / mu_s)
    instance.config = config


CAUSE = Cause("friction_levels", "the floor's friction coefficients differ from Sec. 3.3's",
              MU_STATIC, (), apply, recovery_factor=1.15, null_value=0.86)
