"""Writing runs in the measured-data layout (shared/spec/measured-data.md), atomically."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

CSV_HEADER = "time_s,ax,ay,az"


def _read_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _read_umask()  # once, at import: os.umask is process-wide


def write_atomically(path: Path, write, keep_suffix: bool = False) -> Path:
    """Calls write(tmp_path), then renames tmp_path to path: never a half file.

    keep_suffix: the temporary name ends in path's suffix (for writers that pick
    the format from it, like ffmpeg); otherwise in .part.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.",
                               suffix=f".part{path.suffix}" if keep_suffix else ".part",
                               dir=path.parent)
    os.close(fd)
    try:
        write(Path(tmp))
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600; a plain open() would not
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def remove_temporaries(directory: Path) -> None:
    """Deletes, below directory, the temporaries a killed write_atomically left."""
    for stale in Path(directory).rglob(".*.part*"):
        stale.unlink(missing_ok=True)


def write_accelerometer_csv(path: Path, time_s: np.ndarray, accel: np.ndarray) -> Path:
    """CSV run file: time_s and the cube's accelerations in m/s^2, gravity included."""
    data = np.column_stack([time_s, accel])

    def write(tmp: Path) -> None:
        np.savetxt(tmp, data, delimiter=",", header=CSV_HEADER, comments="",
                   fmt=["%.6f", "%.9g", "%.9g", "%.9g"])

    return write_atomically(path, write)
