"""Causes of a discrepancy in how the robot moves (its yaw rate), not how it shakes.

The accelerometer diagnosis (``skidsteer.diagnosis.causes``) explains vibration;
a real robot's first disagreement with its model is often in its motion: how
fast it turns for a wheel command, the effective-track factor chi (issue 20).
Found in the BorealTC recordings of a Husky A200: the model with the
manufacturer's URDF turns about 1.6x slower than the robot (chi 2.1-2.4 against
1.35-1.43 measured on flooring), and centring its centre of mass closes the
gap.  A skid-steer robot turning in place drags its wheels sideways against
lateral friction in proportion to each wheel's load; with the mass 8.5 cm off
the centre line the loaded side resists as if the robot were wider.

``com_lateral_offset`` (this module) moves the chassis's centre of mass sideways
to the parameter's value (an absolute position, not a shift); the vibration
cause ``slip_lambda_max`` is a motion cause too: the saturation slip sets how
much lateral force a rolling wheel gives per unit of lateral slip (eq. 4.12b),
which decides how an arc slips.
"""

from __future__ import annotations

import mujoco

from skidsteer.diagnosis import causes
from skidsteer.diagnosis.causes import Cause, NotApplicable, Parameter

COM_LATERAL = Parameter(
    "com_lateral_m", -0.1, 0.1, 0.0, log=False,
    source="assumed: the centre of mass anywhere within +-0.1 m of the centre line (a payload "
           "or battery off-centre; the Husky URDF's own value, -0.085 m, inside); value: "
           "centred, as a symmetric robot is built")


def apply_com_lateral(spec: mujoco.MjSpec, params, seed: int = 0) -> None:
    """Puts the root body's (the chassis's) centre of mass at y = com_lateral_m."""
    roots = [b for b in spec.worldbody.bodies if any(
        j.type == mujoco.mjtJoint.mjJNT_FREE for j in b.joints)]
    if len(roots) != 1:
        raise NotApplicable("com_lateral_offset needs one free-floating chassis body")
    body = roots[0]
    pos = list(body.ipos)
    pos[1] = float(params["com_lateral_m"])
    body.ipos = pos


COM_LATERAL_OFFSET = Cause(
    "com_lateral_offset", "the centre of mass sits elsewhere across the robot than the model "
    "says", COM_LATERAL, (), apply_com_lateral,
    # a linear parameter through zero: recovery is judged in metres, not as a factor
    # (tests/test_real_data.py: within 2 cm); the factor is unused for it
    recovery_factor=1.0, null_value=0.0)

MOTION_CAUSES = {COM_LATERAL_OFFSET.name: COM_LATERAL_OFFSET,
                 "slip_lambda_max": causes.get("slip_lambda_max")}
