"""Shared fixtures.  Importing skidsteer registers the tire plugin."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

import skidsteer
from skidsteer.simulation import settle

REPO = Path(__file__).resolve().parents[1]

from installed_copy import stale_files  # noqa: E402  (tests/, on sys.path as conftest's folder)
# the suite's slow marks and worker groups: a hook, which pytest finds in this module
from scheduling import pytest_collection_modifyitems  # noqa: E402, F401

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


def pytest_sessionstart(session):
    """Stop before any test when the imported skidsteer is an installed copy older
    than the checkout (tests/installed_copy.py); xdist's workers import the same one."""
    if hasattr(session.config, "workerinput"):
        return
    package = Path(skidsteer.__file__).resolve().parent
    if package == REPO / "python" / "skidsteer":
        return
    stale = stale_files(package, REPO)
    if stale:
        shown = ", ".join(stale[:5]) + (f" and {len(stale) - 5} more" if len(stale) > 5 else "")
        raise pytest.UsageError(
            f"the skidsteer these tests import ({package}) is not this checkout's: "
            f"{len(stale)} file(s) differ ({shown}); reinstall with "
            f"scripts/install.sh --test, or install editable while developing "
            f"(pip install -e '.[test,ray]')")

