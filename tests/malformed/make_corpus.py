"""Writes the malformed-dataset corpus (issue 7): tests/malformed/dataset/ and expected.json.

One dataset directory in the data format (docs/data-format.md)
whose runs.csv describes three good runs and every kind of bad input a user
has fed us or could: bad run files (empty, missing or extra sheets, text in
numeric cells, NaN, non-monotonic or non-uniform time, truncated, saturated,
wrong units, ...), runs.csv rows without files, a file without a row, and
rows with bad values.  expected.json gives, for each bad file, the fragments
its message must contain: they are written by hand here, from the spec's
requirement (file and place named), not taken from the reader's output.

The files are committed; rerun this only to change the corpus:

    python tests/malformed/make_corpus.py
"""

from __future__ import annotations

import json
import shutil
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # tests/: the file builders of test_measured

import numpy as np  # noqa: E402

from skidsteer.data import recording as m  # noqa: E402
from skidsteer.data.dataset import RunInfo, write_runs_csv  # noqa: E402
from skidsteer.robot import Setup  # noqa: E402
from test_measured import BAD_RUNS, signal, write_csv, write_xlsx  # noqa: E402

# BAD_RUNS cases (tests/test_measured.py) -> the file name they get in the corpus
FROM_TEST_MEASURED = {
    "empty csv": "empty.csv",
    "empty xlsx": "empty.xlsx",
    "missing sheet": "missing_sheet.xlsx",
    "extra sheet": "extra_sheet.xlsx",
    "sheets in the wrong order": "sheets_in_wrong_order.xlsx",
    "text in a numeric cell": "text_in_numeric_cell.xlsx",
    "empty xlsx cell": "empty_cell.xlsx",
    "numbers in the header rows": "numbers_in_header_rows.xlsx",
    "sheets disagree on time": "sheets_disagree_on_time.xlsx",
    "NaN": "nan.csv",
    "text in csv": "text_in_numeric_cell.csv",
    "short csv row": "short_row.csv",
    "non-monotonic time": "non_monotonic_time.csv",
    "non-uniform time": "non_uniform_time.csv",
    "non-uniform time xlsx": "non_uniform_time.xlsx",
    "too short": "too_short.csv",
    "saturated csv": "saturated.csv",
    "saturated xlsx": "saturated.xlsx",
    "missing csv column": "missing_column.csv",
    "unexpected csv column": "unexpected_column.csv",
}


def truncated_csv(path: Path) -> Path:
    """A run cut off mid-row, as a logger killed while writing leaves it: the header,
    2050 whole rows, and two fields of file row 2052."""
    lines = write_csv(path).read_text().splitlines()
    partial = ",".join(lines[2051].split(",")[:2])
    path.write_text("\n".join(lines[:2051] + [partial]))
    return path


def truncated_xlsx(path: Path) -> Path:
    """An xlsx cut off at two thirds: the zip's directory is gone."""
    t, a = signal()
    full = m.write_run(path, t, a).read_bytes()
    path.write_bytes(full[:len(full) * 2 // 3])
    return path


def in_g(path: Path) -> Path:
    t, a = signal()
    return write_csv(path, t, a / 9.81)


def in_mm_per_s2(path: Path) -> Path:
    t, a = signal()
    return write_csv(path, t, a * 1000)


def xlsx_in_m_s2(path: Path) -> Path:
    """The LabVIEW layout with m/s^2 where the volts belong (z reads 9.8 'V'):
    write_xlsx converts to volts, so hand it what converts back to a itself."""
    t, a = signal()
    return write_xlsx(path, t, m.volts_to_m_s2(a))


# new cases: file name -> (builder, fragments its message must contain)
NEW = {
    "truncated.csv": (truncated_csv, ["truncated.csv", "row 2052: 2 fields, expected 4"]),
    "truncated.xlsx": (truncated_xlsx, ["truncated.xlsx", "not a readable .xlsx file"]),
    "in_g.csv": (in_g, ["in_g.csv", "columns ax, ay, az", "acceleration's magnitude is 1.0",
                        "wrong units"]),
    "in_mm_per_s2.csv": (in_mm_per_s2, ["in_mm_per_s2.csv", "acceleration's magnitude is 98",
                                        "wrong units"]),
    "m_s2_in_volt_cells.xlsx": (xlsx_in_m_s2, ["m_s2_in_volt_cells.xlsx",
                                               "column B of the three sheets", "wrong units",
                                               "in volts"]),
}

def info(file: str, omega: float, floor: str, trial: int = 1) -> RunInfo:
    return RunInfo(file, 0.0, omega, Setup(build="extended", floor=floor), trial)


GOOD = [info("good_1.csv", 10.0, "concrete"), info("good_2.xlsx", 10.0, "concrete", 2),
        info("good_3.csv", 30.0, "carpet")]


def main() -> None:
    out = HERE / "dataset"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir()
    expected: dict[str, list[str]] = {}
    infos = list(GOOD)
    t, a = signal()
    for info in GOOD:
        m.write_run(out / info.file, t, a)
    for case, name in FROM_TEST_MEASURED.items():
        make, fragments = BAD_RUNS[case]
        with tempfile.TemporaryDirectory() as tmp:
            made = make(Path(tmp))
            shutil.move(str(made), out / name)
        expected[name] = [name, *fragments]
        infos.append(info(name, 20.0, "tile"))
    for name, (make, fragments) in NEW.items():
        make(out / name)
        expected[name] = fragments
        infos.append(info(name, 20.0, "tile"))
    (out / "notes.txt").write_text("not a run\n")
    infos.append(info("notes.txt", 20.0, "tile"))
    expected["notes.txt"] = ["notes.txt", "unsupported file type '.txt'"]
    # runs.csv rows without files, a file without a row, rows with bad values
    infos.append(info("never_recorded.csv", 40.0, "tile"))
    expected["never_recorded.csv"] = ["runs.csv row", "file 'never_recorded.csv' not found"]
    m.write_run(out / "orphan.csv", t, a)
    expected["orphan.csv"] = ["orphan.csv: no row of runs.csv describes this file"]
    m.write_run(out / "on_ice.csv", t, a)
    m.write_run(out / "no_omega.csv", t, a)
    write_runs_csv(out, infos)
    rows = (out / "runs.csv").read_text().splitlines()
    # the corpus is a dataset as shared/spec/measured-data.md wrote it: its runs.csv
    # names floor and build "surface" and "config", which the reader still accepts
    rows[0] = rows[0].replace("floor,build", "surface,config")
    rows += ["on_ice.csv,0,10,ice,extended,platform,1", "no_omega.csv,0,fast,tile,extended,platform,1"]
    (out / "runs.csv").write_text("\n".join(rows) + "\n")
    expected["on_ice.csv"] = [f"runs.csv row {len(rows) - 1}", "surface", "'ice'"]
    expected["no_omega.csv"] = [f"runs.csv row {len(rows)}", "omega_deg_s", "'fast'"]
    data = {"good": [i.file for i in GOOD], "skipped": expected}
    (HERE / "expected.json").write_text(json.dumps(data, indent=2) + "\n")
    size = sum(p.stat().st_size for p in out.iterdir())
    print(f"wrote {out} ({len(list(out.iterdir()))} files, {size / 1e6:.1f} MB) and expected.json")


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
