"""Shared fixtures.  Importing skidsteer registers the tire plugin."""

from __future__ import annotations

import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

import skidsteer
from skidsteer.simulation import settle

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts"))

# Table 5.1: contact points from the CoM, wheels numbered as the thesis
TABLE_5_1 = np.array([
    [-0.15, 0.18, -0.23],
    [0.13, 0.18, -0.23],
    [0.13, -0.18, -0.23],
    [-0.15, -0.18, -0.23],
])
# eq. 5.1, the SolidWorks inertia tensor about the CoM, kg m^2
INERTIA_EQ_5_1 = np.array([
    [1.21, 0.000355, -0.0655],
    [0.000355, 1.41, -0.00125],
    [-0.0655, -0.00125, 0.922],
])


@pytest.fixture(scope="session")
def extended_model() -> mujoco.MjModel:
    return skidsteer.load_model("extended", "concrete")


@pytest.fixture(scope="session")
def platform_model() -> mujoco.MjModel:
    return skidsteer.load_model("platform", "concrete")


@pytest.fixture()
def settled(extended_model):
    d = mujoco.MjData(extended_model)
    settle(extended_model, d, 2.0)
    return extended_model, d
