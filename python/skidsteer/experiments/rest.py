"""The robot at rest on its tires: the normal forces against its weight and eq. 2.24."""

from __future__ import annotations

import mujoco
import numpy as np

from skidsteer.robot import Setup, load_model, resolve, roles_of
from skidsteer.simulation.run import settle

DEFAULT_SETUP = Setup(build="extended", floor="concrete")


def tire_loads(setup: Setup = DEFAULT_SETUP, settle_s: float = 3.0) -> dict:
    """Normal forces of the robot at rest and the split eq. 2.24 predicts (front/rear by
    the CoM's place between the axles, half per side)."""
    setup = resolve(setup)
    m = load_model(setup)
    d = mujoco.MjData(m)
    settle(m, d, settle_s)
    mujoco.mj_forward(m, d)
    parts = roles_of(m)
    normal = d.sensordata[parts.sensor_slice(m, parts.tire_forces, "tire_forces")] \
        .reshape(-1, 3)[:, 0]
    root = parts.chassis  # the robot's free body
    mass = float(m.body_subtreemass[root])
    weight = mass * float(np.linalg.norm(m.opt.gravity))
    # eq. 2.24 from the compiled geometry: a, b from the CoM to the axles
    forward = d.xmat[root].reshape(3, 3)[:, 0]
    com_x = float(d.subtree_com[root] @ forward)
    wheel_x = np.array([d.xpos[w.body] @ forward for w in parts.wheels])
    a = com_x - wheel_x.min()
    b = wheel_x.max() - com_x
    rear = wheel_x < com_x
    expected = np.where(rear, b / (2 * (a + b)), a / (2 * (a + b))) * weight
    return {
        "build": setup.build, "floor": setup.floor,
        "wheels": [m.body(w.body).name for w in parts.wheels],
        "normal_forces_N": normal.tolist(),
        "sum_N": float(normal.sum()),
        "weight_N": weight,
        "sum_over_weight": float(normal.sum() / weight),
        "eq_2_24_N": expected.tolist(),
        "relative_error_vs_eq_2_24": ((normal - expected) / expected).tolist(),
    }
