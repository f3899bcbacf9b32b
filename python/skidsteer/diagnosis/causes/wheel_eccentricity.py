"""wheel_eccentricity: out-of-round wheels, exciting at the wheel-rotation frequency.

Sec. 3.2's on-wheel runs show components rising linearly with omega.  The cause
moves each wheel's tire geom off its axle by the eccentricity, at a random
phase per wheel (the seed); the tire plugin takes the geom's centre as the
wheel centre, so the rim's height over the floor, and the tire load, swing once
per revolution, and the offset tire mass is a rotating imbalance.
"""

from typing import Callable

import mujoco
import numpy as np

from skidsteer.diagnosis.causes import Cause, NotApplicable, Parameter
from skidsteer.robot import tire

ECCENTRICITY = Parameter(
    "eccentricity_m", 2e-5, 2e-3, 2e-4, log=True,
    source="assumed: radial run-out of moulded tyres on their hubs, from a precise wheel "
           "(~0.02 mm) to a worn, deformed one (~2 mm); value: the geometric middle")


def wheel_phases(seed: int, n_wheels: int) -> np.ndarray:
    """The realisation: each wheel's run-out phase, rad (tire.find_wheels order)."""
    return np.random.default_rng(seed).uniform(0, 2 * np.pi, n_wheels)


def offset_wheels(spec: mujoco.MjSpec, eccentricity_m: float,
                  phases: Callable[[int], np.ndarray]) -> None:
    """Moves each wheel's tire geom off its axle by eccentricity_m at its phase;
    phases(number of wheels) gives them (tire.find_wheels order)."""
    m = spec.compile()
    wheels = tire.find_wheels(m, tire.instance_id(m))
    if not wheels or any(w.geom < 0 for w in wheels):
        raise NotApplicable("wheel_eccentricity needs a cylinder geom on each wheel")
    for wheel, phase in zip(wheels, phases(len(wheels))):
        name = m.geom(wheel.geom).name
        if not name:
            raise NotApplicable("wheel_eccentricity needs named wheel geoms")
        geom = spec.geom(name)
        # offset perpendicular to the axle (the wheel joint's axis, in the body frame)
        axis = np.asarray(m.jnt_axis[wheel.joint], dtype=float)
        u = np.cross(axis, [0.0, 0.0, 1.0] if abs(axis[2]) < 0.9 else [1.0, 0.0, 0.0])
        u /= np.linalg.norm(u)
        v = np.cross(axis, u)
        geom.pos = list(np.asarray(geom.pos)
                        + eccentricity_m * (np.cos(phase) * u + np.sin(phase) * v))


def apply(spec: mujoco.MjSpec, params, seed: int = 0) -> None:
    offset_wheels(spec, params["eccentricity_m"],
                  lambda n_wheels: wheel_phases(seed, n_wheels))


CAUSE = Cause("wheel_eccentricity", "out-of-round wheels (a once-per-revolution run-out)",
              ECCENTRICITY, (), apply, recovery_factor=1.5, null_value=2e-5, random_realisation=True)
