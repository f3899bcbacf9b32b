"""A lugged tread: the cause of lines at a fixed wheel order (issue 20).

Found in the BorealTC recordings of a Husky A200: on the hard floors the IMU
holds lines at 18, 36 and 54 times the wheels' rotation rate (17.3 Hz per m/s
of rim speed), which no other candidate makes: a round wheel on a flat floor
gives none, a rough floor spreads its power over a band, an eccentric wheel
puts it at order 1.  A tyre with lug_count lugs rolls like a polygon of as many
sides: its centre drops between two lugs and rises on the next (the tire
plugin's ``lug_count`` and ``lug_depth``), at lug_count times the wheel rate and
its harmonics.

The lug count is read off the recording (the lowest order with a line: the
wheel orders of the features count revolutions of the wheel), the depth fitted.
"""

from __future__ import annotations

import mujoco

from skidsteer.diagnosis.causes import Cause, Parameter
from skidsteer.robot import tire

LUG_DEPTH = Parameter(
    "lug_depth_m", 5e-5, 5e-3, 5e-4, log=True,
    source="assumed: from 0.05 mm (a worn tread whose carcass bridges the lugs) to 5 mm "
           "(twice the 2.5 mm a rigid 18-sided polygon of the Husky's 0.165 m radius drops); "
           "value: a fifth of the rigid polygon's, the carcass smoothing it")
LUG_COUNT = Parameter(
    "lug_count", 4, 60, 18, log=False,
    source="identified, not fitted: the lowest wheel order holding a line in the recording "
           "(BorealTC's Husky: 18); value: that")


def apply_tread(spec: mujoco.MjSpec, params, seed: int = 0) -> None:
    """Sets the tire plugin's lug_count (rounded to a whole number) and lug_depth."""
    tire.configure(spec, {"lug_count": int(round(params["lug_count"])),
                          "lug_depth": float(params["lug_depth_m"])})


TREAD_LUGS = Cause(
    "tread_lugs", "the tyres' tread has lugs: lines at lug_count times the wheel rate and "
    "its harmonics", LUG_DEPTH, (LUG_COUNT,), apply_tread,
    # a depth's line power grows as its square (1.5: the accelerometer causes' rule for
    # amplitudes, set before any fit)
    recovery_factor=1.5, null_value=LUG_DEPTH.low)
