"""slip_lambda_max: the slip at which tire friction saturates, re-identified.

eq. 4.12a ramps friction with slip up to lambda_max; the thesis took 0.1 and
named it as a suspect for the missing vibrations (Sec. 6.2, Appendix C ran 1 to
1e-4).  The cause sets the tire plugin's lambda_max attribute.
"""

from skidsteer.diagnosis.causes import Cause, Parameter
from skidsteer.robot import tire

LAMBDA_MAX = Parameter(
    "lambda_max", 0.003, 1.0, 0.1, log=True,
    source="Appendix C's series ran 1 to 1e-4; the prior stops at 3e-3 (assumed: a "
           "saturation slip of 0.3 % is stiffer than any rubber tread); value: the thesis's "
           "0.1 (Sec. 4.2)")


def apply(spec, params, seed: int = 0) -> None:
    tire.configure(spec, {"lambda_max": repr(float(params["lambda_max"]))})


CAUSE = Cause("slip_lambda_max", "the tire's saturation slip lambda_max differs from 0.1",
              LAMBDA_MAX, (), apply, recovery_factor=1.5, null_value=0.1)
