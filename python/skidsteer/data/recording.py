"""Run files: one accelerometer recording each (docs/data-format.md, "Run files").

A run file is either the thesis's LabVIEW export (Appendix A, ``parseData``:
three sheets, the first z, the second y, the third x; rows 1-10 header; from
row 11 column A time in s and column B the SCA620's output in V) or a CSV
``time_s,ax,ay,az`` in m/s^2.  ``read_run`` reads and checks one; ``write_run``
writes one in the layout its suffix names, atomically.

Bad input raises :class:`DataError`, whose message names the file and the
sheet, row or column at fault.  Rows are numbered as a spreadsheet shows them
(in a CSV the header is row 1).
"""

from __future__ import annotations

import csv
import io
import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import openpyxl

from skidsteer.data.files import write_atomically

GRAVITY_M_S2 = 9.8  # the thesis's g (Appendix A's volts formula)
SENSOR_RANGE_M_S2 = 1.7 * GRAVITY_M_S2  # SCA620: +-1.7 g
SATURATION_FRACTION = 0.999  # |a| at or above this fraction of the range is saturated
MIN_SAMPLES = 2**11  # the shortest analysis window of the thesis (Sec. 5.2)
TIME_STEP_RTOL = 1e-3  # relative to the median step
# Gravity is in every recording (the spec: "as an accelerometer reads them"), so the
# specific force's magnitude is about 1 g at every sample, however the sensor is
# turned: the swivel's centripetal and vibration terms are below 0.1 g (Sec. 3.2).
# Its median over the record outside 0.5-1.5 g is a file in other units: g (1/9.8
# of it) or mm/s^2 (1000x).  The magnitude, not the mean vector: on a wheel (the
# thesis's OnWheel runs) gravity turns with the sensor and its mean vector averages
# towards zero over the revolutions.
GRAVITY_BAND = (0.5, 1.5)
HEADER_ROWS = 10  # LabVIEW export header; data from row 11
SHEET_AXES = ("z", "y", "x")  # sheet order in the LabVIEW export (parseData reads sheet 4-i)
CSV_HEADER = "time_s,ax,ay,az"
CSV_COLUMNS = tuple(CSV_HEADER.split(","))


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


def read_utf8(path: Path) -> str:
    """A text file's contents (UTF-8, a BOM dropped); DataError naming the file and
    what is wrong with it."""
    try:
        return path.read_bytes().decode("utf-8-sig")
    except OSError as e:
        raise DataError(f"{path}: cannot read ({e.strerror or e})") from None
    except UnicodeDecodeError as e:
        raise DataError(f"{path}: not UTF-8 text (byte {e.start})") from None


def _read_csv(path: Path):
    text = read_utf8(path)
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
    magnitude = float(np.median(np.linalg.norm(accel, axis=1)))
    low, high = (GRAVITY_M_S2 * f for f in GRAVITY_BAND)
    if not low <= magnitude <= high:
        csv_file = path.suffix.lower() == ".csv"
        place = "columns ax, ay, az" if csv_file else "column B of the three sheets"
        hint = ("The accelerations must be in m/s^2 with gravity in (g would read 1, "
                "mm/s^2 9800)" if csv_file else
                "Column B must hold the SCA620's output in volts (2.6 V at 0 g)")
        raise DataError(f"{path}: {place}: the acceleration's magnitude is {magnitude:.4g} "
                        f"m/s^2 (median over the record), but gravity alone reads "
                        f"{GRAVITY_M_S2} m/s^2 (accepted {low:.1f}-{high:.1f}): wrong units?  "
                        f"{hint}")
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
        return write_run_csv(path, time_s, accel)
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


def write_run_csv(path, time_s, accel) -> Path:
    """Writes a run as CSV: time_s and the accelerations in m/s^2, gravity included."""
    time_s, accel = _as_run(time_s, accel)
    data = np.column_stack([time_s, accel])

    def write(tmp: Path) -> None:
        np.savetxt(tmp, data, delimiter=",", header=CSV_HEADER, comments="",
                   fmt=["%.6f", "%.9g", "%.9g", "%.9g"])

    return write_atomically(Path(path), write)
