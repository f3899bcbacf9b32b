"""Files written so that nothing half-done ever looks done.

``write_atomically`` writes any file through a temporary and a rename.  A command
whose outputs are a directory (a sweep's dataset, a diagnosis) marks it with
``INCOMPLETE_MARKER`` from ``begin_outputs`` until ``finish_outputs`` writes its
result file, last; readers refuse a marked directory.  JSON is written strict
(NaN as null) by ``write_json``.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np

# Kept in an output directory while a command writes it: read_dataset refuses such a
# directory, and a result file is never there beside it, so that an interrupted
# command never passes for a finished one.
INCOMPLETE_MARKER = ".skidsteer-incomplete"


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


def write_text(path: Path, text: str) -> Path:
    return write_atomically(Path(path), lambda tmp: tmp.write_text(text))


def plain(value):
    """A value as strict JSON has it: numpy scalars as numbers, non-finite floats as
    None, paths as strings, containers recursively."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return value if np.isfinite(value) else None
    return str(value) if isinstance(value, Path) else value


def write_json(path: Path, data, indent: int | None = 2) -> Path:
    """Strict JSON (non-finite numbers as null, numpy scalars as numbers), atomically."""
    return write_text(path, json.dumps(plain(data), indent=indent, allow_nan=False) + "\n")


def begin_outputs(out: Path, result_name: str, command: str, note: str = "") -> Path:
    """Marks `out` unfinished until finish_outputs: removes a previous run's result file
    (written last, so its presence means a complete set of outputs), writes the marker
    (its text ends with note) and clears stale temporaries."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / result_name).unlink(missing_ok=True)
    write_text(out / INCOMPLETE_MARKER,
               f"an unfinished skidsteer {command}: no {result_name} yet{note}\n")
    remove_temporaries(out)
    return out


def finish_outputs(out: Path, result_name: str, write_result) -> None:
    """Writes the result file, the last of the outputs (write_result(path)), and removes
    the marker."""
    out = Path(out)
    write_result(out / result_name)
    (out / INCOMPLETE_MARKER).unlink(missing_ok=True)
