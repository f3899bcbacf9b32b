"""Swivel sweeps (omega x floor x build x trial) into a dataset directory.

The directory has the layout of shared/spec/measured-data.md (runs.csv plus
one file per run), so simulated and measured runs go through one reader.
Each model is built and settled once and its runs are tasks on a backend
(threads here, or a Ray cluster: skidsteer.backends); every file is written
atomically and a rerun skips the runs whose file already exists, so
an interrupted sweep resumes where it stopped.
"""

from __future__ import annotations

import dataclasses
import itertools
import sys
import zlib
from pathlib import Path
from typing import Iterable


from skidsteer.datafiles import remove_temporaries, write_atomically
from skidsteer.measured import INCOMPLETE_MARKER, RunInfo, write_run, write_runs_csv

THESIS_OMEGAS_DEG_S = tuple(range(2, 65, 2))  # Sec. 3.2: 2 to 64 deg/s in steps of 2


def run_file_name(v_mps: float, omega_deg_s: float, duration_s: float, config: str,
                  surface: str, mount: str = "platform", trial: int | None = None,
                  suffix: str = ".csv") -> str:
    """The thesis's file name v{v}-w{omega}-t{duration}-{conf} (Appendix A), conf
    with its OnWheel / noFrame tokens, the floor and the trial number."""
    conf = (["OnWheel"] if mount == "wheel" else []) + \
        (["noFrame"] if config == "platform" else []) + [surface]
    if trial is not None:
        conf.append(str(trial))
    num = lambda x: f"{x:g}"  # noqa: E731
    return f"v{num(v_mps)}-w{num(omega_deg_s)}-t{num(duration_s)}-{'-'.join(conf)}{suffix}"


@dataclasses.dataclass(frozen=True)
class PlannedRun:
    info: RunInfo
    duration_s: float
    seed: int | None
    variant: str = "ours"


def plan(omegas: Iterable[float], surfaces: Iterable[str], configs: Iterable[str],
         trials: int = 1, duration_s: float = 20.0, mount: str = "platform",
         variant: str = "ours", suffix: str = ".csv", seed: int = 0) -> list[PlannedRun]:
    """The grid of runs.  Trial k > 1 starts from a perturbed tire state (seeded);
    with trials == 1 the single trial starts from the settled state itself."""
    runs = []
    for config, surface, omega, trial in itertools.product(configs, surfaces, omegas,
                                                           range(1, trials + 1)):
        name = run_file_name(0, omega, duration_s, config, surface, mount, trial, suffix)
        run_seed = None if trials == 1 else _stable_seed(seed, config, surface, float(omega),
                                                         trial, mount, variant)
        info = RunInfo(file=name, v_mps=0.0, omega_deg_s=float(omega), surface=surface,
                       config=config, mount=mount, trial=trial, accel_position_m=None,
                       notes=f"simulated: skidsteer variant={variant} seed={run_seed}")
        runs.append(PlannedRun(info, duration_s, run_seed, variant))
    return runs


def _stable_seed(*parts) -> int:
    """A seed from the run's identity that does not change between processes."""
    return zlib.crc32(repr(parts).encode()) % 2**31


def run_sweep(out_dir: Path, runs: list[PlannedRun], nthread: int = 2,
              progress: bool = True, backend=None) -> list[RunInfo]:
    """Simulates the planned runs not yet on disk; writes their files and runs.csv.

    Each model is built and settled once; its runs are `sweep_run` tasks on the
    backend (skidsteer.backends; default: nthread threads here).  Files are written
    here, each as soon as its run is back, so an interrupted sweep keeps them.
    """
    import mujoco

    from skidsteer.backends import LocalBackend
    from skidsteer.experiments import swivel_model
    from skidsteer.simulation import settle

    backend = backend or LocalBackend(nthread)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    todo = [r for r in runs if not (out_dir / r.info.file).is_file()]
    marker = out_dir / INCOMPLETE_MARKER
    remove_temporaries(out_dir)
    if todo:
        # until runs.csv is written the directory is not a dataset (read_dataset
        # refuses it), so that a killed sweep never looks complete
        (out_dir / "runs.csv").unlink(missing_ok=True)
        write_atomically(marker, lambda tmp: tmp.write_text(
            f"an unfinished skidsteer sweep: {len(todo)} of {len(runs)} runs to simulate; "
            "rerun the same sweep to finish it\n"))
    groups: dict[tuple, list[PlannedRun]] = {}
    for r in todo:
        key = (r.info.config, r.info.surface, r.info.mount, r.variant, r.duration_s)
        groups.setdefault(key, []).append(r)
    tasks, planned = [], []
    for (config, surface, mount, variant, duration), group in groups.items():
        m = swivel_model(config, surface, mount, variant)
        shared = backend.share(m), backend.share(settle(m, mujoco.MjData(m)))
        for r in group:
            tasks.append((*shared, r.info.v_mps, r.info.omega_deg_s, duration, r.seed))
            planned.append(r)
    bar = _progress(len(runs), len(runs) - len(todo), progress)
    try:
        for r, (time_s, accel) in zip(planned, backend.map(sweep_run, tasks)):
            write_run(out_dir / r.info.file, time_s, accel)
            bar.update(1)
    finally:
        bar.close()
    infos = [r.info for r in runs]
    write_runs_csv(out_dir, infos)
    marker.unlink(missing_ok=True)
    return infos


def sweep_run(m, settled, v_mps: float, omega_deg_s: float, duration_s: float,
              seed: int | None):
    """One planned run's accelerometer log (time_s, accel at 1 kHz).  A backend task."""
    from skidsteer.simulation import run_from_settled

    return run_from_settled(m, settled, v_mps, omega_deg_s, duration_s, seed).accelerometer_log()


def _progress(total: int, done: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, initial=done, unit="run", desc="sweep", file=sys.stderr,
                disable=not enabled)
