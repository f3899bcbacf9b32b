"""Reading measured accelerometer runs: the contract of shared/spec/measured-data.md.

A dataset is a directory of run files, described by ``runs.csv`` or, without
it, by the thesis's file names ``v{v}-w{omega}-t{duration}-{conf}.xlsx``.
A run file is either the thesis's LabVIEW export (Appendix A, ``parseData``:
three sheets, the first z, the second y, the third x; rows 1-10 header; from
row 11 column A time in s and column B the SCA620's output in V) or a CSV
``time_s,ax,ay,az`` in m/s^2.

Bad input raises :class:`DataError`, whose message names the file and the
sheet, row or column at fault.  Rows are numbered as a spreadsheet shows them
(in a CSV the header is row 1).  :func:`read_dataset` never lets one bad run
sink the others: it lists it in ``Dataset.skipped`` with that message.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from skidsteer.datafiles import CSV_HEADER, write_accelerometer_csv, write_atomically
from skidsteer.models import BUILDS, FLOORS

GRAVITY_M_S2 = 9.8  # the thesis's g (Appendix A's volts formula)
SENSOR_RANGE_M_S2 = 1.7 * GRAVITY_M_S2  # SCA620: +-1.7 g
SATURATION_FRACTION = 0.999  # |a| at or above this fraction of the range is saturated
MIN_SAMPLES = 2**11  # the shortest analysis window of the thesis (Sec. 5.2)
TIME_STEP_RTOL = 1e-3  # relative to the median step
# Gravity is in every recording (the spec: "as an accelerometer reads them"), and
# a robot on its floor reads a mean specific force of 1 g: the swivel's
# centripetal and vibration terms are below 0.1 g (Sec. 3.2).  A mean outside
# 0.5-1.5 g is a file in other units: g (1/9.8 of it) or mm/s^2 (1000x).
GRAVITY_BAND = (0.5, 1.5)
HEADER_ROWS = 10  # LabVIEW export header; data from row 11
SHEET_AXES = ("z", "y", "x")  # sheet order in the LabVIEW export (parseData reads sheet 4-i)
CSV_COLUMNS = tuple(CSV_HEADER.split(","))

SURFACES = FLOORS  # the floors the simulation has parameter sets for
CONFIGS = tuple(BUILDS)
MOUNTS = ("platform", "wheel")
RUNS_REQUIRED = ("file", "v_mps", "omega_deg_s", "surface", "config", "mount", "trial")
RUNS_ACCEL = ("accel_x_m", "accel_y_m", "accel_z_m")
RUNS_OPTIONAL = RUNS_ACCEL + ("notes",)


class DataError(ValueError):
    """A run file or dataset that cannot be used as the spec describes."""


def volts_to_m_s2(volts):
    """SCA620 output (V) to acceleration (m/s^2), as parseData converts it."""
    return 3.4 * 9.8 / 5 * (np.asarray(volts, dtype=float) - 2.6)


def m_s2_to_volts(a):
    """Inverse of :func:`volts_to_m_s2`."""
    return np.asarray(a, dtype=float) * 5 / (3.4 * 9.8) + 2.6


@dataclass(frozen=True, eq=False)
class Recording:
    """One run: time (n,) in s, the cube's accelerations (n, 3) in m/s^2 (x, y, z; gravity in)."""

    path: Path
    time_s: np.ndarray
    accel: np.ndarray

    @property
    def sample_rate_hz(self) -> float:
        return (len(self.time_s) - 1) / float(self.time_s[-1] - self.time_s[0])


@dataclass(frozen=True)
class RunInfo:
    """One row of runs.csv: the commanded motion and the setup of a run."""

    file: str
    v_mps: float
    omega_deg_s: float
    surface: str
    config: str
    mount: str
    trial: int
    accel_position_m: tuple[float, float, float] | None = None
    notes: str = ""


@dataclass
class Dataset:
    """The usable runs of a directory and, with the reason, every run that is not."""

    root: Path
    runs: list[tuple[RunInfo, Recording | None]] = field(default_factory=list)
    skipped: list[dict] = field(default_factory=list)


# --------------------------------------------------------------------------- run files

def read_run(path) -> Recording:
    """Reads a .xlsx (LabVIEW export) or .csv run file and checks it; raises DataError."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".xlsx"):
        raise DataError(f"{path}: unsupported file type {path.suffix!r} (expected .xlsx or .csv)")
    if not path.is_file():
        raise DataError(f"{path}: file not found")
    time_s, accel, where = (_read_csv if suffix == ".csv" else _read_xlsx)(path)
    _check_samples(path, time_s, accel, where)
    time_s.setflags(write=False)
    accel.setflags(write=False)
    return Recording(path, time_s, accel)


def _number(value, place: str, text: bool = False) -> float:
    """A finite float from a cell (from text too if text=True), or DataError naming the place."""
    if value is None or value == "":
        raise DataError(f"{place}: empty cell where a number is expected")
    if isinstance(value, str) and not text:
        raise DataError(f"{place}: text {value!r} where a number is expected")
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise DataError(f"{place}: {value!r} is not a number")
    try:
        x = float(value)
    except (ValueError, OverflowError):
        raise DataError(f"{place}: {value!r} is not a number") from None
    if not math.isfinite(x):
        raise DataError(f"{place}: {value!r} is not a finite number")
    return x


def _read_csv(path: Path):
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except OSError as e:
        raise DataError(f"{path}: cannot read ({e.strerror or e})") from None
    except UnicodeDecodeError as e:
        raise DataError(f"{path}: not UTF-8 text (byte {e.start})") from None
    if not text.strip():
        raise DataError(f"{path}: empty file")
    reader = csv.reader(io.StringIO(text, newline=""))
    rows, lines = [], []
    try:
        header = [c.strip() for c in next(reader)]
        _check_csv_header(path, header)
        for row in reader:
            if not "".join(row).strip():
                continue
            if len(row) != len(CSV_COLUMNS):
                raise DataError(f"{path}: row {reader.line_num}: {len(row)} fields, "
                                f"expected {len(CSV_COLUMNS)} ({CSV_HEADER})")
            rows.append([_number(v, f"{path}: row {reader.line_num}, column {c}", text=True)
                         for v, c in zip(row, CSV_COLUMNS)])
            lines.append(reader.line_num)
    except csv.Error as e:
        raise DataError(f"{path}: row {reader.line_num}: malformed CSV ({e})") from None
    data = np.array(rows, dtype=float).reshape(-1, 4)

    def where(i: int, axis: str | None) -> str:
        return f"row {lines[i]}, column " + ("time_s" if axis is None else "a" + axis)

    return data[:, 0].copy(), data[:, 1:].copy(), where


def _check_csv_header(path: Path, header: list[str]) -> None:
    if header == list(CSV_COLUMNS):
        return
    missing = [c for c in CSV_COLUMNS if c not in header]
    unexpected = [c for c in header if c not in CSV_COLUMNS]
    problems = ([f"missing column {', '.join(missing)}"] if missing else []) + \
        ([f"unexpected column {', '.join(map(repr, unexpected))}"] if unexpected else [])
    if not problems:
        problems = [f"columns repeated or out of order ({','.join(header)})"]
    raise DataError(f"{path}: header row 1: {'; '.join(problems)} (expected {CSV_HEADER})")


def _read_xlsx(path: Path):
    import openpyxl

    try:
        with warnings.catch_warnings(), open(path, "rb") as f:
            warnings.simplefilter("ignore")
            book = openpyxl.load_workbook(f, read_only=True, data_only=True)
            try:
                sheets = book.worksheets
                _check_sheets(path, [ws.title for ws in sheets])
                columns = [_sheet_columns(path, ws) for ws in sheets]
            finally:
                book.close()
    except DataError:
        raise
    except Exception as e:  # whatever a damaged or foreign file makes openpyxl raise
        raise DataError(f"{path}: not a readable .xlsx file ({type(e).__name__}: {e})") from None

    names = [ws.title for ws in sheets]
    time_s = columns[0][:, 0]
    step = np.median(np.abs(np.diff(time_s))) if len(time_s) > 1 else 0.0
    for name, col in zip(names[1:], columns[1:]):
        if len(col) != len(time_s):
            raise DataError(f"{path}: sheet {name} has {len(col)} data rows, "
                            f"sheet {names[0]} has {len(time_s)}")
        differs = np.flatnonzero(~(np.abs(col[:, 0] - time_s) <= TIME_STEP_RTOL * step))
        if differs.size:
            i = differs[0]
            raise DataError(f"{path}: sheet {name}, row {HEADER_ROWS + 1 + i}, column A: time "
                            f"{float(col[i, 0])!r} s differs from sheet {names[0]} "
                            f"({float(time_s[i])!r} s): the sheets must share one time column")
    accel = volts_to_m_s2(np.column_stack([columns[2][:, 1], columns[1][:, 1], columns[0][:, 1]]))
    sheet_of = dict(zip("zyx", names))

    def where(i: int, axis: str | None) -> str:
        return (f"sheet {sheet_of[axis or 'z']}, row {HEADER_ROWS + 1 + i}, "
                f"column {'A' if axis is None else 'B'}")

    return time_s.copy(), accel, where


def _check_sheets(path: Path, names: list[str]) -> None:
    if len(names) != 3:
        raise DataError(f"{path}: {len(names)} sheet(s) ({', '.join(names)}), expected 3: "
                        "z, y, x (LabVIEW export, Appendix A parseData)")
    for k, (name, axis) in enumerate(zip(names, SHEET_AXES)):
        if name.strip().lower() in ("x", "y", "z") and name.strip().lower() != axis:
            raise DataError(f"{path}: sheet {k + 1} is named {name!r} but holds the {axis} axis; "
                            "the sheets must be z, y, x in that order")


def _sheet_columns(path: Path, ws) -> np.ndarray:
    """Columns A (time) and B (volts) from row 11 down, as an (n, 2) array."""
    ws.reset_dimensions()  # an export's stated dimensions may be wrong: read every row
    rows = [tuple(r) + (None,) * (2 - len(r)) for r in ws.iter_rows(max_col=2, values_only=True)]
    while rows and rows[-1] == (None, None):
        rows.pop()
    header, data = rows[:HEADER_ROWS], rows[HEADER_ROWS:]
    if len(header) == HEADER_ROWS and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for r in header for v in r):
        raise DataError(f"{path}: sheet {ws.title}, rows 1-{HEADER_ROWS} hold numbers, not the "
                        f"export header; data must start at row {HEADER_ROWS + 1}")
    out = np.empty((len(data), 2))
    for i, row in enumerate(data):
        for j in (0, 1):
            v = row[j]
            if type(v) is float and math.isfinite(v):
                out[i, j] = v
            else:
                out[i, j] = _number(v, f"{path}: sheet {ws.title}, row {HEADER_ROWS + 1 + i}, "
                                       f"column {'AB'[j]}")
    return out


def _check_samples(path: Path, time_s: np.ndarray, accel: np.ndarray, where) -> None:
    """Length, time base and saturation, shared by both file types."""
    n = len(time_s)
    if n < MIN_SAMPLES:
        raise DataError(f"{path}: too short: {n} samples, at least {MIN_SAMPLES} needed "
                        "(2^11, the shortest analysis window of the thesis, Sec. 5.2)")
    with np.errstate(all="ignore"):
        step = np.diff(time_s)
        back = np.flatnonzero(~(step > 0))
        if back.size:
            i = back[0] + 1
            raise DataError(f"{path}: time does not increase at {where(i, None)} "
                            f"({float(time_s[i])!r} s after {float(time_s[i - 1])!r} s)")
        median = float(np.median(step))
        uneven = np.flatnonzero(~(np.abs(step - median) <= TIME_STEP_RTOL * median))
        if uneven.size:
            i = uneven[0] + 1
            raise DataError(f"{path}: non-uniform time base at {where(i, None)}: step "
                            f"{step[i - 1]:.6g} s, median step {median:.6g} s "
                            f"(tolerance {TIME_STEP_RTOL:g} relative)")
    # units before saturation: a file in other units saturates everywhere
    mean = float(np.linalg.norm(accel.mean(axis=0)))
    low, high = (GRAVITY_M_S2 * f for f in GRAVITY_BAND)
    if not low <= mean <= high:
        csv_file = path.suffix.lower() == ".csv"
        place = "columns ax, ay, az" if csv_file else "column B of the three sheets"
        hint = ("The accelerations must be in m/s^2 with gravity in (g would read 1, "
                "mm/s^2 9800)" if csv_file else
                "Column B must hold the SCA620's output in volts (2.6 V at 0 g)")
        raise DataError(f"{path}: {place}: the mean acceleration is {mean:.4g} "
                        f"m/s^2, but gravity alone reads {GRAVITY_M_S2} m/s^2 (accepted "
                        f"{low:.1f}-{high:.1f}): wrong units?  {hint}")
    limit = SATURATION_FRACTION * SENSOR_RANGE_M_S2
    hits = []
    for k, axis in enumerate("xyz"):
        over = np.flatnonzero(np.abs(accel[:, k]) >= limit)
        if over.size:
            hits.append(f"axis {axis} from {where(over[0], axis)} ({accel[over[0], k]:+.2f} m/s^2)")
    if hits:
        raise DataError(f"{path}: sensor saturated (|a| >= {limit:.2f} m/s^2, the SCA620's "
                        f"+-1.7 g range): {'; '.join(hits)}")


def write_run_xlsx(path, time_s, accel) -> Path:
    """Writes a run as the thesis's LabVIEW export: sheets z, y, x; 10 header rows; A s, B V."""
    import openpyxl

    time_s, accel = _as_run(time_s, accel)
    volts = m_s2_to_volts(accel)
    dt = float(np.median(np.diff(time_s))) if len(time_s) > 1 else 0.0

    def write(tmp: Path) -> None:
        book = openpyxl.Workbook(write_only=True)
        for axis, column in zip(SHEET_AXES, (2, 1, 0)):
            ws = book.create_sheet(axis)
            for row in _labview_header(axis, len(time_s), dt):
                ws.append(row)
            for t, v in zip(time_s.tolist(), volts[:, column].tolist()):
                ws.append((t, v))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            book.save(tmp)

    return write_atomically(Path(path), write)


def _labview_header(axis: str, n: int, dt: float) -> list[tuple]:
    """Ten rows in the manner of a LabVIEW Measurement export header (row 1 holds a
    number, so Matlab's xlsread keeps the rows and parseData's 11:end is row 11)."""
    return [
        ("LabVIEW Measurement", 2),
        ("Writer_Version", 2),
        ("Reader_Version", 2),
        ("Separator", "Tab"),
        ("Channels", 1),
        ("Samples", n),
        ("Date", "2012/04/16"),
        ("X_Dimension", "Time"),
        ("Delta_X", dt),
        ("X_Value", f"Accel {axis} (V)"),
    ]


def write_run(path, time_s, accel) -> Path:
    """Writes a run file in the layout its suffix names (.csv or .xlsx)."""
    path = Path(path)
    if path.suffix.lower() == ".csv":
        time_s, accel = _as_run(time_s, accel)
        return write_accelerometer_csv(path, time_s, accel)
    if path.suffix.lower() == ".xlsx":
        return write_run_xlsx(path, time_s, accel)
    raise ValueError(f"{path}: unsupported file type {path.suffix!r} (expected .xlsx or .csv)")


def _as_run(time_s, accel) -> tuple[np.ndarray, np.ndarray]:
    time_s = np.asarray(time_s, dtype=float)
    accel = np.asarray(accel, dtype=float)
    if time_s.ndim != 1 or accel.shape != (len(time_s), 3):
        raise ValueError(f"time_s must be (n,) and accel (n, 3), "
                         f"not {time_s.shape} and {accel.shape}")
    return time_s, accel


# --------------------------------------------------------------------------- datasets

_NUMBER = r"-?\d+(?:\.\d+)?"
_THESIS_NAME = re.compile(rf"v(?P<v>{_NUMBER})-w(?P<w>{_NUMBER})-t(?P<t>{_NUMBER})(?P<conf>-.*)?")
_TOKENS = {"onwheel": ("mount", "wheel"), "noframe": ("config", "platform"),
           **{s: ("surface", s) for s in SURFACES}}


def parse_thesis_name(name: str) -> dict:
    """Fields of a thesis file name, e.g. 'v0-w10-t20-OnWheel-noFrame-concrete.xlsx' (Appendix A).

    ``OnWheel`` sets mount wheel (default platform), ``noFrame`` config platform (default
    extended), the floor name the surface (required); a trailing integer token is the trial.
    """
    stem = re.sub(r"\.(xlsx|csv)$", "", Path(name).name, flags=re.IGNORECASE)
    m = _THESIS_NAME.fullmatch(stem)
    if not m:
        raise DataError(f"{name}: not a thesis run name v{{v}}-w{{omega}}-t{{duration}}-{{conf}}")
    fields = {"v_mps": float(m["v"]), "omega_deg_s": float(m["w"]), "duration_s": float(m["t"]),
              "config": "extended", "mount": "platform", "trial": 1}
    tokens = (m["conf"] or "").split("-")[1:]
    if tokens and tokens[-1].isascii() and tokens[-1].isdigit() and int(tokens[-1]) > 0:
        fields["trial"] = int(tokens.pop())
    seen = set()
    for token in tokens:
        if token.lower() not in _TOKENS:
            raise DataError(f"{name}: unknown token {token!r} in the file name (known: OnWheel, "
                            f"noFrame, {', '.join(SURFACES)}, and a trailing trial number)")
        key, value = _TOKENS[token.lower()]
        if key in seen:
            raise DataError(f"{name}: two {key} tokens in the file name")
        seen.add(key)
        fields[key] = value
    if "surface" not in fields:
        raise DataError(f"{name}: no floor token ({', '.join(SURFACES)}) in the file name")
    return fields


# A file that a writer of datasets (skidsteer.sweep) keeps in the directory while
# it is unfinished: read_dataset refuses such a directory, so that an interrupted
# sweep never passes for a complete dataset.
INCOMPLETE_MARKER = ".skidsteer-incomplete"


def read_dataset(root, *, load=True) -> Dataset:
    """The runs of a dataset directory; with load=False the recordings are None (not read)."""
    root = Path(root)
    if not root.is_dir():
        raise DataError(f"{root}: not a directory")
    if (root / INCOMPLETE_MARKER).is_file():
        raise DataError(f"{root}: an unfinished dataset ({INCOMPLETE_MARKER}: "
                        f"{(root / INCOMPLETE_MARKER).read_text().strip()})")
    files = sorted(p.relative_to(root).as_posix() for p in root.rglob("*")
                   if p.is_file() and p.suffix.lower() in (".csv", ".xlsx")
                   and p.relative_to(root).as_posix() != "runs.csv"
                   and not any(part.startswith((".", "~$")) for part in p.relative_to(root).parts))
    if (root / "runs.csv").is_file():
        infos, skipped = _read_runs_csv(root, files)
    else:
        infos, skipped = _infos_from_names(files)
    dataset = Dataset(root, [], skipped)
    for info in infos:
        try:
            dataset.runs.append((info, read_run(root / info.file) if load else None))
        except DataError as e:
            dataset.skipped.append({"file": info.file, "reason": str(e)})
    return dataset


def _infos_from_names(files: list[str]) -> tuple[list[RunInfo], list[dict]]:
    infos, skipped = [], []
    for file in files:
        try:
            f = parse_thesis_name(file)
        except DataError as e:
            skipped.append({"file": file, "reason": f"{e} (and there is no runs.csv)"})
            continue
        infos.append(RunInfo(file, f["v_mps"], f["omega_deg_s"], f["surface"], f["config"],
                             f["mount"], f["trial"]))
    return infos, skipped


def _read_runs_csv(root: Path, files: list[str]) -> tuple[list[RunInfo], list[dict]]:
    infos, skipped, described = [], [], {}
    try:
        text = (root / "runs.csv").read_bytes().decode("utf-8-sig")
        reader = csv.reader(io.StringIO(text, newline=""))
        header = [c.strip() for c in next(reader, [])]
        missing = [c for c in RUNS_REQUIRED if c not in header]
        unknown = [c for c in header if c not in RUNS_REQUIRED + RUNS_OPTIONAL]
        if missing or unknown or len(set(header)) != len(header):
            raise DataError(f"runs.csv row 1: missing column(s) {missing}, unknown column(s) "
                            f"{unknown} (required {','.join(RUNS_REQUIRED)}; optional "
                            f"{','.join(RUNS_OPTIONAL)}; each once)")
        for row in reader:
            k = reader.line_num
            if not "".join(row).strip():
                continue
            cells = dict(zip(header, (c.strip() for c in row)))
            try:
                if len(row) != len(header):
                    raise DataError(f"{len(row)} fields, the header has {len(header)}")
                info = _run_info(cells)
                if not (root / info.file).is_file():
                    raise DataError(f"file {info.file!r} not found in {root}")
                if info.file in described:
                    raise DataError(f"file {info.file!r} already described in row "
                                    f"{described[info.file]}")
            except DataError as e:
                skipped.append({"file": _relative(cells.get("file", "")) or "runs.csv",
                                "reason": f"runs.csv row {k}: {e}"})
                continue
            described[info.file] = k
            infos.append(info)
    except (OSError, UnicodeDecodeError, csv.Error, DataError) as e:
        skipped.append({"file": "runs.csv", "reason": f"{root / 'runs.csv'}: unusable: {e}"})
    skipped += [{"file": f, "reason": f"{f}: no row of runs.csv describes this file"}
                for f in files if f not in described and f not in {s["file"] for s in skipped}]
    return infos, skipped


def _relative(file: str) -> str:
    """A runs.csv file entry in the form read_dataset lists files ('./a.xlsx' is 'a.xlsx')."""
    return os.path.normpath(file).replace(os.sep, "/") if file else ""


def _run_info(cells: dict) -> RunInfo:
    """A RunInfo from one runs.csv row (stripped strings); DataError names the column."""
    file = _relative(cells.get("file", ""))
    if not file:
        raise DataError("no file given")

    def number(column: str) -> float:
        return _number(cells.get(column, ""), column, text=True)

    def choice(column: str, allowed: tuple[str, ...]) -> str:
        value = cells.get(column, "").lower()
        if value not in allowed:
            raise DataError(f"{column} {cells.get(column, '')!r} has no simulation counterpart "
                            f"(known: {', '.join(allowed)})")
        return value

    trial = cells.get("trial", "")
    if not (trial.isascii() and trial.isdigit() and int(trial) > 0):
        raise DataError(f"trial {trial!r} is not a positive integer")
    given = [c for c in RUNS_ACCEL if cells.get(c, "")]
    if given and len(given) != 3:
        raise DataError(f"{', '.join(RUNS_ACCEL)} must be given together "
                        f"(row has {', '.join(given)})")
    position = tuple(number(c) for c in RUNS_ACCEL) if given else None
    return RunInfo(file, number("v_mps"), number("omega_deg_s"), choice("surface", SURFACES),
                   choice("config", CONFIGS), choice("mount", MOUNTS), int(trial), position,
                   cells.get("notes", ""))


def write_runs_csv(root, infos: list[RunInfo]) -> Path:
    """Writes root/runs.csv atomically; accel_*_m and notes columns only if some run sets them."""
    with_accel = any(i.accel_position_m is not None for i in infos)
    with_notes = any(i.notes for i in infos)
    header = list(RUNS_REQUIRED) + (list(RUNS_ACCEL) if with_accel else []) + \
        (["notes"] if with_notes else [])

    def row(i: RunInfo) -> list:
        cells = [i.file, f"{i.v_mps:.12g}", f"{i.omega_deg_s:.12g}", i.surface, i.config,
                 i.mount, i.trial]
        if with_accel:
            position = i.accel_position_m
            cells += [f"{x:.12g}" for x in position] if position else ["", "", ""]
        return cells + ([i.notes] if with_notes else [])

    def write(tmp: Path) -> None:
        with open(tmp, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(header)
            w.writerows(row(i) for i in infos)

    return write_atomically(Path(root) / "runs.csv", write)
