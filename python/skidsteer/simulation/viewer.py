"""MuJoCo's interactive viewer with the tire plugin loaded."""

from __future__ import annotations

import mujoco
import mujoco.viewer

from skidsteer.robot import Setup, load_model
from skidsteer.simulation.run import settle


def launch(setup: Setup) -> None:
    """Opens the setup's model (a robot's build, or an MJCF file), settled on its tires."""
    m = load_model(setup)
    d = mujoco.MjData(m)
    settle(m, d, 1.0)
    mujoco.viewer.launch(m, d)
