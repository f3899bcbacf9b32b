"""Swivel sweeps (omega x floor x build x trial) into a dataset directory.

The directory has the dataset layout of docs/data-format.md (runs.csv plus one
file per run), so simulated and measured runs go through one reader.  Each
model is built and settled once and its runs are tasks on a backend (threads
here, or a Ray cluster: skidsteer.simulation.backends); every file is written
atomically, the directory is marked unfinished until runs.csv is written, and
a rerun skips the runs whose file already exists, so an interrupted sweep
resumes where it stopped.
"""

from __future__ import annotations

import dataclasses
import itertools
import sys
import zlib
from pathlib import Path
from typing import Iterable

import mujoco
from tqdm import tqdm

from skidsteer.data.dataset import RUNS_FILE, RunInfo, run_file_name, write_runs_csv
from skidsteer.data.files import begin_outputs, finish_outputs
from skidsteer.data.recording import write_run
from skidsteer.robot import BASE_VARIANT, DEFAULT_ROBOT, PLATFORM_MOUNT, Setup, load_model
from skidsteer.simulation.backends import LocalBackend
from skidsteer.simulation.run import run_from_settled, settle

THESIS_OMEGAS_DEG_S = tuple(range(2, 65, 2))  # Sec. 3.2: 2 to 64 deg/s in steps of 2


@dataclasses.dataclass(frozen=True)
class PlannedRun:
    info: RunInfo
    duration_s: float
    seed: int | None


def plan(omegas: Iterable[float], floors: Iterable[str], builds: Iterable[str],
         trials: int = 1, duration_s: float = 20.0, mount: str = PLATFORM_MOUNT,
         variant: str = BASE_VARIANT, suffix: str = ".csv", seed: int = 0,
         robot: str = DEFAULT_ROBOT) -> list[PlannedRun]:
    """The grid of runs.  Trial k > 1 starts from a perturbed tire state (seeded);
    with trials == 1 the single trial starts from the settled state itself."""
    runs = []
    for build, floor, omega, trial in itertools.product(builds, floors, omegas,
                                                        range(1, trials + 1)):
        setup = Setup(robot, build, floor, mount, None, variant)
        name = run_file_name(0, omega, duration_s, setup, trial, suffix)
        run_seed = None if trials == 1 else _stable_seed(seed, build, floor, float(omega),
                                                         trial, mount, variant)
        info = RunInfo(file=name, v_mps=0.0, omega_deg_s=float(omega), setup=setup, trial=trial,
                       notes=f"simulated: skidsteer variant={variant} seed={run_seed}")
        runs.append(PlannedRun(info, duration_s, run_seed))
    return runs


def _stable_seed(*parts) -> int:
    """A seed from the run's identity that does not change between processes."""
    return zlib.crc32(repr(parts).encode()) % 2**31


def run_sweep(out_dir: Path, runs: list[PlannedRun], nthread: int = 2,
              progress: bool = True, backend=None,
              timestep: float | None = None, edit=None,
              tire: dict | None = None) -> list[RunInfo]:
    """Simulates the planned runs not yet on disk; writes their files and runs.csv.

    Each model is built and settled once; its runs are `sweep_run` tasks on the
    backend (default: nthread threads here).  Files are written here, each as soon
    as its run is back, so an interrupted sweep keeps them.  timestep: the simulation
    step, s (None: the model's); edit, tire: an MjSpec edit and tire attributes applied
    to every model (robot.load_model's), e.g. a vibration mechanism's.
    """
    backend = backend or LocalBackend(nthread)
    out_dir = Path(out_dir)
    todo = [r for r in runs if not (out_dir / r.info.file).is_file()]
    # until runs.csv is written the directory is not a dataset (read_dataset refuses
    # it), so that a killed sweep never looks complete
    begin_outputs(out_dir, RUNS_FILE, "sweep",
                  f": {len(todo)} of {len(runs)} runs to simulate; rerun the same sweep to "
                  "finish it")
    groups: dict[tuple, list[PlannedRun]] = {}
    for r in todo:
        groups.setdefault((r.info.setup, r.duration_s), []).append(r)
    tasks, planned = [], []
    for (setup, duration), group in groups.items():
        m = load_model(setup, tire=tire, timestep=timestep, edit=edit)
        shared = backend.share(m), backend.share(settle(m, mujoco.MjData(m)))
        for r in group:
            tasks.append((*shared, r.info.v_mps, r.info.omega_deg_s, duration, r.seed))
            planned.append(r)
    bar = tqdm(total=len(runs), initial=len(runs) - len(todo), unit="run", desc="sweep",
               file=sys.stderr, disable=not progress)
    try:
        for r, (time_s, accel) in zip(planned, backend.map(sweep_run, tasks)):
            write_run(out_dir / r.info.file, time_s, accel)
            bar.update(1)
    finally:
        bar.close()
    infos = [r.info for r in runs]
    finish_outputs(out_dir, RUNS_FILE, lambda path: write_runs_csv(path.parent, infos))
    return infos


def sweep_run(m, settled, v_mps: float, omega_deg_s: float, duration_s: float,
              seed: int | None):
    """One planned run's accelerometer log (time_s, accel at 1 kHz).  A backend task."""
    return run_from_settled(m, settled, v_mps, omega_deg_s, duration_s, seed).accelerometer_log()
