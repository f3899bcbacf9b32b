"""A disk cache of simulated features, so that a killed `diagnose` resumes.

A diagnosis is hundreds of independent simulations (every command of a dataset,
for every grid point of every candidate cause).  Each finished one is stored
here under a key made of everything that determines it:

- the compiled model, as mj_saveModel writes it (geometry, inertias, the tire
  plugin's attributes, the floor, the time step, a cause's edit and its
  realisation all change these bytes);
- the task: settling time, command, record length, the sensor chain;
- the code: skidsteer's Python sources, the plugin library's bytes and MuJoCo's
  version (a changed feature extractor or tire law never reads an old entry);
- the numeric platform (``numeric_platform``): the C library and the CPU features
  its libm picks its sin/cos/exp/pow by.  MuJoCo calls them every step, and the
  stick-slip swivel amplifies their last-bit differences into different runs, so
  an entry made on another platform is another simulation.  And the kernels of
  the BLAS numpy and scipy bundle (OpenBLAS picks them by CPU model, not by
  feature flag: SkylakeX on an AVX-512 Intel Xeon, Haswell on an AMD EPYC with the
  same flags), whose last bits reach the features (a 10 s swivel's features hash
  differently under OPENBLAS_CORETYPE=Haswell on one machine).

An entry holds what the fits read: the feature vector and the mean yaw rate (a
few hundred bytes); the time series are not kept (a diagnosis's worth would be
hundreds of MB) and are simulated again for the few models a report plots.
Entries are written atomically, one file each, so a kill loses at most the
simulations in flight.
"""

from __future__ import annotations

import functools
import hashlib
import os
import platform
import threading
from pathlib import Path

import mujoco
import numpy as np
import scipy.linalg  # noqa: F401  (its BLAS loaded beside numpy's: blas_kernels reads both)
from threadpoolctl import threadpool_info

from skidsteer.data.files import write_atomically
from skidsteer.robot import plugin

FORMAT = 1  # bump when an entry's content changes meaning
CACHE_DIR = ".skidsteer-cache"  # diagnose's default cache, inside its output directory


# CPU features by which glibc's x86-64 libm chooses its implementations (IFUNC)
LIBM_CPU_FEATURES = ("fma", "fma4", "avx2", "avx512f")


@functools.lru_cache(maxsize=None)
def numeric_platform() -> str:
    """What, beyond the code, decides a simulation's last bits: the C library's
    version, the machine, the CPU features its libm dispatches on and any glibc
    tunables that override them (e.g. "glibc 2.36, x86_64, fma avx2")."""
    libc, version = platform.libc_ver()
    flags: set[str] = set()
    try:
        with open("/proc/cpuinfo") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("flags"):
                    flags = set(line.split(":", 1)[1].split())
                    break
    except OSError:
        pass
    features = " ".join(f for f in LIBM_CPU_FEATURES if f in flags) or "none of " + \
        "/".join(LIBM_CPU_FEATURES)
    tunables = os.environ.get("GLIBC_TUNABLES")
    return (f"{libc or 'libc'} {version or '?'}, {platform.machine()}, {features}"
            + (f", GLIBC_TUNABLES={tunables}" if tunables else "") + f", {blas_kernels()}")


def blas_kernels() -> str:
    """The BLAS libraries numpy and scipy load and the kernels each picked (e.g. "blas
    openblas SkylakeX"), read by threadpoolctl.  OpenBLAS chooses its kernels by CPU
    model (OPENBLAS_CORETYPE overrides it): two machines whose libm features agree can
    still differ here, and their features in the last bits."""
    kernels = sorted({f"{i.get('internal_api', '?')} {i.get('architecture') or '?'}"
                      for i in threadpool_info() if i.get("user_api") == "blas"})
    return "blas " + (" ".join(kernels) if kernels else "none found")


@functools.lru_cache(maxsize=None)
def code_fingerprint() -> str:
    """sha256 of what turns a model into features: skidsteer's sources, the tire
    plugin's library, MuJoCo's version and the numeric platform."""
    h = hashlib.sha256(f"mujoco {mujoco.__version__} format {FORMAT} "
                       f"platform {numeric_platform()}".encode())
    package = Path(__file__).parents[1]  # the skidsteer package
    for path in sorted(package.rglob("*.py")):
        h.update(str(path.relative_to(package)).encode())
        h.update(path.read_bytes())
    h.update(plugin.library_path().read_bytes())
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

    def get(self, key: str) -> tuple[np.ndarray, float, tuple[float, ...]] | None:
        """(features, mean yaw rate in deg/s, the wheels' rates in Hz), or None when not
        stored (or unreadable: an entry is only ever whole, but a damaged disk is a
        miss, not an error)."""
        path = self._path(key)
        if not path.is_file():
            return None
        try:
            with np.load(path) as entry:
                features, yaw = np.array(entry["features"]), float(entry["yaw_deg_s"])
                rates = tuple(float(r) for r in entry["wheel_rates_hz"])
        except (OSError, ValueError, KeyError):
            return None
        with self._lock:
            self.hits += 1
        return features, yaw, rates

    def put(self, key: str, features: np.ndarray, yaw_deg_s: float,
            wheel_rates_hz=()) -> None:
        def write(tmp: Path) -> None:
            with open(tmp, "wb") as f:
                np.savez(f, features=np.asarray(features, float), yaw_deg_s=float(yaw_deg_s),
                         wheel_rates_hz=np.asarray(wheel_rates_hz, float))

        write_atomically(self._path(key), write)
        with self._lock:
            self.stores += 1
