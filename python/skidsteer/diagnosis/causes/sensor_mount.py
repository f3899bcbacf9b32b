"""sensor_mount: the accelerometer cube is taped on, with its own resonance.

The wood cube with the three SCA620s (Sec. 3.2) is fixed with tape; the cause
puts it on a three-axis spring-damper at the sensor's site, tuned by the
mount's natural frequency, and moves the accelerometer (and gyro) onto it.
"""

import mujoco

from skidsteer.diagnosis.causes import Cause, Parameter, mount_sensors

CUBE_MASS_KG = 0.1  # assumed: a 4 cm wood cube (~40 g) with three SCA620 boards and cables
FREQUENCY = Parameter(
    "frequency_hz", 15.0, 50.0, 27.0, log=True,
    source="assumed: double-sided foam tape under a 0.1 kg cube resonates at tens of Hz; the "
           "upper bound is Appendix A's 50 Hz low-pass, above which the analysis sees nothing")
DAMPING_RATIO = Parameter(
    "damping_ratio", 0.02, 0.2, 0.05, log=True,
    source="assumed: foam tape, 2-20 % of critical")


def apply(spec: mujoco.MjSpec, params, seed: int = 0) -> None:
    mount_sensors(spec, "sensor_cube", CUBE_MASS_KG, params["frequency_hz"],
                  params["damping_ratio"],
                  {"cube_x": [1, 0, 0], "cube_y": [0, 1, 0], "cube_z": [0, 0, 1]})


CAUSE = Cause("sensor_mount", "the accelerometer cube resonates on its tape",
              FREQUENCY, (DAMPING_RATIO,), apply, recovery_factor=1.25, null_value=50.0)
