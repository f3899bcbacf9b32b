"""What the benchmarks print about the machine they ran on (imported by the bench scripts,
which run as `python scripts/bench/NAME.py`, so this folder is on sys.path)."""

from __future__ import annotations

import os
import platform
from pathlib import Path

import mujoco


def machine() -> str:
    return (f"{platform.system()} {platform.release()}, {platform.machine()}, "
            f"{platform.processor() or 'cpu'}, os.cpu_count()={os.cpu_count()}, "
            f"Python {platform.python_version()}, mujoco {mujoco.__version__}")


def loadavg() -> list[float] | None:
    """The 1, 5 and 15 min load averages: whether something else ran beside a benchmark."""
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def save_results(path, benchmark: str, **fields) -> None:
    """A benchmark's results as strict JSON, written atomically, with the machine."""
    from skidsteer.data.files import write_json

    write_json(Path(path), {"benchmark": benchmark, "machine": machine(),
                            "cpu_count": os.cpu_count(), **fields})
    print(f"wrote {path}")
