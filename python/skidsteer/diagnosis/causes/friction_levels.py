"""friction_levels: the floor's static and kinetic friction, re-identified.

Sec. 3.3 measured mu_s and mu_k with a pull test on three floors; a user's floor
is another.  The cause sets mu_static and keeps the measured kinetic-to-static
ratio of the floor the model has (0.914 on concrete and tile, 0.914 on carpet;
Sec. 3.3).
"""

from skidsteer.diagnosis.causes import Cause, Parameter
from skidsteer.robot import tire

MU_STATIC = Parameter(
    "mu_static", 0.4, 1.2, 0.86, log=False,
    source="assumed: indoor floors under rubber tread, 0.4 (polished, dusty) to 1.2 (rubber "
           "on carpet); value: Sec. 3.3's concrete")


def apply(spec, params, seed: int = 0) -> None:
    mu_s, mu_k = tire.friction(dict(tire.instance(spec).config))
    tire.configure(spec, {"mu_static": repr(float(params["mu_static"])),
                          "mu_kinetic": repr(float(params["mu_static"]) * mu_k / mu_s)})


CAUSE = Cause("friction_levels", "the floor's friction coefficients differ from Sec. 3.3's",
              MU_STATIC, (), apply, recovery_factor=1.15, null_value=0.86)
