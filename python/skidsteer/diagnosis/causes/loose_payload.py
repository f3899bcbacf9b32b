"""loose_payload: the laptop sits on Velcro, a compliant mount (Sec. 3.2).

The cause frees the laptop to slide in x and y on its tray, on a spring and a
damper whose stiffness gives the mount's natural frequency for the laptop's
mass.  The vertical direction stays rigid: the laptop rests on the tray.
"""

import mujoco

from skidsteer.diagnosis.causes import Cause, Parameter, add_spring_slides, part

FREQUENCY = Parameter(
    "frequency_hz", 4.0, 30.0, 11.0, log=True,
    source="assumed: hook-and-loop pads in shear under a 2 kg laptop, 4-30 Hz; value: the "
           "geometric middle")
DAMPING_RATIO = Parameter(
    "damping_ratio", 0.05, 0.3, 0.1, log=True,
    source="assumed: Velcro and rubber feet are lossy, 5-30 % of critical")


def apply(spec: mujoco.MjSpec, params, seed: int = 0) -> None:
    laptop = part(spec, "payload", "loose_payload")
    add_spring_slides(laptop, laptop.mass, params["frequency_hz"], params["damping_ratio"],
                      {"laptop_x": [1, 0, 0], "laptop_y": [0, 1, 0]})


CAUSE = Cause("loose_payload", "the laptop slides on a compliant (Velcro) mount",
              FREQUENCY, (DAMPING_RATIO,), apply, recovery_factor=1.5, null_value=30.0)
