"""A disk cache of simulated features, so that a killed `diagnose` resumes.

A diagnosis is hundreds of independent simulations (every command of a dataset,
for every grid point of every candidate cause).  Each finished one is stored
here under a key made of everything that determines it:

- the compiled model, as mj_saveModel writes it (geometry, inertias, the tire
  plugin's attributes, the floor, the time step, a cause's edit and its
  realisation all change these bytes);
- the task: settling time, command, record length, the sensor chain;
- the code: skidsteer's Python sources, the plugin library's bytes and MuJoCo's
  version (a changed feature extractor or tire law never reads an old entry).

An entry holds what the fits read: the feature vector and the mean yaw rate (a
few hundred bytes); the time series are not kept (a diagnosis's worth would be
hundreds of MB) and are simulated again for the few models a report plots.
Entries are written atomically, one file each, so a kill loses at most the
simulations in flight.
"""

from __future__ import annotations

import functools
import hashlib
import threading
from pathlib import Path

import mujoco
import numpy as np

from skidsteer.datafiles import write_atomically

FORMAT = 1  # bump when an entry's content changes meaning
CACHE_DIR = ".skidsteer-cache"  # diagnose's default cache, inside its output directory


@functools.lru_cache(maxsize=None)
def code_fingerprint() -> str:
    """sha256 of what turns a model into features: skidsteer's sources, the tire
    plugin's library and MuJoCo's version."""
    from skidsteer import _plugin

    h = hashlib.sha256(f"mujoco {mujoco.__version__} format {FORMAT}".encode())
    package = Path(__file__).parent
    for path in sorted(package.rglob("*.py")):
        h.update(str(path.relative_to(package)).encode())
        h.update(path.read_bytes())
    h.update(_plugin.library_path().read_bytes())
    return h.hexdigest()


def model_bytes(m: mujoco.MjModel) -> bytes:
    buffer = np.zeros(mujoco.mj_sizeModel(m), np.uint8)
    mujoco.mj_saveModel(m, None, buffer)
    return buffer.tobytes()


def model_digest(m: mujoco.MjModel) -> str:
    """sha256 of the compiled model (the model part of a key)."""
    return hashlib.sha256(model_bytes(m)).hexdigest()


class SimulationCache:
    """Feature vectors of finished simulations in directory `root` (created on the
    first store); counts what it served and what it stored."""

    def __init__(self, root):
        self.root = Path(root)
        self.hits = 0
        self.stores = 0
        self._lock = threading.Lock()  # fits running concurrently share one cache

    def key(self, model_digest: str, *task) -> str:
        """model_digest: model_digest(the model); task: the simulation's other inputs
        (their repr is exact for floats and for the frozen SensorChain)."""
        text = repr((code_fingerprint(), model_digest, task))
        return hashlib.sha256(text.encode()).hexdigest()

    def _path(self, key: str) -> Path:
        return self.root / f"{key}.npz"

    def get(self, key: str) -> tuple[np.ndarray, float] | None:
        """(features, mean yaw rate in deg/s), or None when not stored (or unreadable:
        an entry is only ever whole, but a damaged disk is a miss, not an error)."""
        path = self._path(key)
        if not path.is_file():
            return None
        try:
            with np.load(path) as entry:
                features, yaw = np.array(entry["features"]), float(entry["yaw_deg_s"])
        except (OSError, ValueError, KeyError):
            return None
        with self._lock:
            self.hits += 1
        return features, yaw

    def put(self, key: str, features: np.ndarray, yaw_deg_s: float) -> None:
        def write(tmp: Path) -> None:
            with open(tmp, "wb") as f:
                np.savez(f, features=np.asarray(features, float), yaw_deg_s=float(yaw_deg_s))

        write_atomically(self._path(key), write)
        with self._lock:
            self.stores += 1
