"""MuJoCo's interactive viewer with the tire plugin loaded."""

from __future__ import annotations

import mujoco
import mujoco.viewer

import skidsteer  # noqa: F401  (registers the plugin in this process)
from skidsteer.models import load_model
from skidsteer.simulation import settle


def launch(model: str = "extended", floor: str | None = None) -> None:
    """Opens the model (a build name or an MJCF path), settled on its tires."""
    m = load_model(model, floor)
    d = mujoco.MjData(m)
    settle(m, d, 1.0)
    mujoco.viewer.launch(m, d)
