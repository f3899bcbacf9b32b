"""The thesis's experiments on the simulated robot, each on a Setup: free response
(Sec. 5.2, 6.2), pull tests (Sec. 3.3, 6.2), straight line (Fig. 6.8), swivel in
place (Sec. 3.2) and its sweeps, and the tire loads at rest (eq. 2.24)."""

from skidsteer.experiments.free_response import (FREE_RESPONSE_AXES, FREE_RESPONSE_TIMESTEP_S,
                                                 free_response, release)
from skidsteer.experiments.pull import CABLE_STIFFNESS, pull
from skidsteer.experiments.rest import tire_loads
from skidsteer.experiments.straight import straight
from skidsteer.experiments.sweep import THESIS_OMEGAS_DEG_S, plan, run_sweep
from skidsteer.experiments.swivel import run_swivel, swivel_summary

__all__ = ["CABLE_STIFFNESS", "FREE_RESPONSE_AXES", "FREE_RESPONSE_TIMESTEP_S",
           "THESIS_OMEGAS_DEG_S", "free_response", "plan", "pull", "release", "run_sweep",
           "run_swivel", "straight", "swivel_summary", "tire_loads"]
