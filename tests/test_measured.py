"""The readers of docs/data-format.md: run files and datasets, round trips, names, bad input."""

from __future__ import annotations

import numpy as np
import openpyxl
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from skidsteer import FLOORS
from skidsteer.data import dataset as ds_
from skidsteer.data import recording as m
from skidsteer.data.dataset import RunInfo
from skidsteer.data.recording import DataError
from skidsteer.robot import Setup


def info(file, v, w, floor, build, mount, trial, position=None, notes=""):
    """A RunInfo of the default robot."""
    return RunInfo(file, v, w, Setup(build=build, floor=floor, mount=mount,
                                     accel_position_m=position), trial, notes)

N = m.MIN_SAMPLES + 52  # 2100 samples at 1 kHz


def signal(n: int = N, fs: float = 1000.0) -> tuple[np.ndarray, np.ndarray]:
    """A swivel-like run: vibrations on x, y; gravity (specific force, +9.81) and vibration on z."""
    t = np.arange(n) / fs
    return t, np.column_stack([0.5 * np.sin(2 * np.pi * 7 * t),
                               0.3 * np.cos(2 * np.pi * 3 * t),
                               9.81 + 0.2 * np.sin(2 * np.pi * 11 * t)])


def write_csv(path, time_s=None, accel=None, header="time_s,ax,ay,az", edit=None):
    """A CSV run; edit(lines) may change the data lines (index 0 is file row 2)."""
    if time_s is None:
        time_s, accel = signal()
    lines = [",".join(repr(float(x)) for x in (t, *a)) for t, a in zip(time_s, accel)]
    if edit:
        edit(lines)
    path.write_text("\n".join([header, *lines]) + "\n")
    return path


def write_xlsx(path, time_s=None, accel=None, names=("z", "y", "x"), header_rows=10, cells=None):
    """A LabVIEW-like xlsx built by hand; cells {(sheet, row, col): value} overrides (1-based)."""
    if time_s is None:
        time_s, accel = signal()
    volts = m.m_s2_to_volts(accel)
    book = openpyxl.Workbook()
    book.remove(book.active)
    for k, name in enumerate(names):
        ws = book.create_sheet(name)
        for r in range(header_rows):
            ws.append([f"header {r + 1}", "text"])
        for t, v in zip(time_s.tolist(), volts[:, 2 - k % 3].tolist()):
            ws.append([t, v])
    for (sheet, row, col), value in (cells or {}).items():
        book[sheet].cell(row, col).value = value
    book.save(path)
    return path


# ------------------------------------------------------------------------- conversions, round trips

def test_volts_formula_and_inverse():
    assert m.SENSOR_RANGE_M_S2 == pytest.approx(16.66)
    assert m.volts_to_m_s2(2.6) == 0
    assert m.volts_to_m_s2(5.0) == pytest.approx(3.4 * 9.8 / 5 * 2.4)
    assert m.m_s2_to_volts(9.81) == pytest.approx(2.6 + 9.81 * 5 / (3.4 * 9.8))
    a = np.linspace(-16, 16, 7)
    np.testing.assert_allclose(m.volts_to_m_s2(m.m_s2_to_volts(a)), a, atol=1e-12)


def test_csv_round_trip(tmp_path):
    t, a = signal()
    rec = m.read_run(m.write_run(tmp_path / "run.csv", t, a))
    np.testing.assert_allclose(rec.time_s, t, atol=1e-6)
    np.testing.assert_allclose(rec.accel, a, rtol=1e-8, atol=1e-8)
    assert rec.sample_rate_hz == pytest.approx(1000.0)
    assert rec.path == tmp_path / "run.csv"


def test_xlsx_round_trip_thesis_size_labview_layout(tmp_path):
    t, a = signal(20000)  # the thesis's 20 s at 1 kHz
    path = m.write_run(tmp_path / "v0-w10-t20-concrete.xlsx", t, a)
    rec = m.read_run(path)
    assert rec.time_s.shape == (20000,) and rec.accel.shape == (20000, 3)
    np.testing.assert_allclose(rec.time_s, t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rec.accel, a, rtol=0, atol=1e-12)
    assert rec.sample_rate_hz == pytest.approx(1000.0)
    book = openpyxl.load_workbook(path, read_only=True)
    assert book.sheetnames == ["z", "y", "x"]
    rows = list(book["z"].iter_rows(max_row=11, values_only=True))
    assert rows[0][0] == "LabVIEW Measurement"
    assert rows[10][0] == 0.0 and rows[10][1] == pytest.approx(m.m_s2_to_volts(a[0, 2]))
    book.close()
    assert list(tmp_path.iterdir()) == [path]  # atomic: no temporary left behind


def test_write_run_rejects_bad_shapes_and_suffix(tmp_path):
    t, a = signal(10)
    with pytest.raises(ValueError, match="accel"):
        m.write_run(tmp_path / "r.csv", t, a[:, :2])
    with pytest.raises(ValueError, match="unsupported"):
        m.write_run(tmp_path / "r.txt", t, a)


# --------------------------------------------------------------------------- thesis names

def _fields(v, w, t, floor, build, mount, trial):
    return dict(v_mps=v, omega_deg_s=w, duration_s=t, floor=floor, build=build,
                mount=mount, trial=trial)


@pytest.mark.parametrize("name, fields", [
    ("v0-w10-t20-OnWheel-noFrame-concrete.xlsx",
     _fields(0, 10, 20, "concrete", "platform", "wheel", 1)),
    ("v0-w30-t20-concrete-2.xlsx", _fields(0, 30, 20, "concrete", "extended", "platform", 2)),
    ("v0.2-w-15-t10-noFrame-carpet-3.csv",
     _fields(0.2, -15, 10, "carpet", "platform", "platform", 3)),
    ("v0-w4-t20-tile.xlsx", _fields(0, 4, 20, "tile", "extended", "platform", 1)),
])
def test_parse_thesis_name(name, fields):
    assert ds_.parse_thesis_name(name, FLOORS) == fields


@pytest.mark.parametrize("name, message", [
    ("v0-w10-t20-OnWheel-grass.xlsx", "unknown token 'grass'"),
    ("v0-w10-t20-OnWheel.xlsx", "no floor token"),
    ("v0-w10-t20-tile-carpet.xlsx", "two floor tokens"),
    ("run1.xlsx", "not a thesis run name"),
])
def test_parse_thesis_name_errors(name, message):
    with pytest.raises(DataError, match=message) as e:
        ds_.parse_thesis_name(name, FLOORS)
    assert name in str(e.value)


# --------------------------------------------------------------------------- bad run files

def _raw(name, content: bytes):
    def make(d):
        (d / name).write_bytes(content)
        return d / name
    return make


def _csv(**kw):
    return lambda d: write_csv(d / "bad.csv", **kw)


def _xlsx(**kw):
    return lambda d: write_xlsx(d / "bad.xlsx", **kw)


def _set_row(row: int, text: str):
    """An edit for write_csv: file row `row` (the header is row 1) becomes `text`."""
    return lambda lines: lines.__setitem__(row - 2, text)


def _swap_rows(lines):
    lines[99], lines[100] = lines[100], lines[99]


def _drop_row(lines):
    del lines[500]


BAD_RUNS = {
    "empty csv": (_raw("bad.csv", b""), ["empty file"]),
    "empty xlsx": (_raw("bad.xlsx", b""), ["not a readable .xlsx file"]),
    "missing sheet": (_xlsx(names=("z", "y")), ["2 sheet(s) (z, y), expected 3"]),
    "extra sheet": (_xlsx(names=("z", "y", "x", "w")), ["4 sheet(s)", "expected 3"]),
    "sheets in the wrong order": (_xlsx(names=("x", "y", "z")),
                                  ["sheet 1 is named 'x' but holds the z axis"]),
    "text in a numeric cell": (_xlsx(cells={("y", 57, 2): "oops"}),
                               ["sheet y, row 57, column B: text 'oops'"]),
    "empty xlsx cell": (_xlsx(cells={("x", 300, 1): None}),
                        ["sheet x, row 300, column A: empty cell"]),
    "numbers in the header rows": (_xlsx(header_rows=0),
                                   ["sheet z, rows 1-10 hold numbers", "row 11"]),
    "sheets disagree on time": (_xlsx(cells={("x", 40, 1): 0.5}),
                                ["sheet x, row 40, column A: time 0.5 s differs from sheet z "
                                 "(0.029 s)"]),
    "NaN": (_csv(edit=_set_row(11, "0.009,nan,0,9.8")),
            ["row 11, column ax: 'nan' is not a finite number"]),
    "text in csv": (_csv(edit=_set_row(4, "0.002,0,x,9.8")),
                    ["row 4, column ay: 'x' is not a number"]),
    "short csv row": (_csv(edit=_set_row(7, "0.005,0,9.8")), ["row 7: 3 fields, expected 4"]),
    "non-monotonic time": (_csv(edit=_swap_rows),
                           ["time does not increase at row 102, column time_s "
                            "(0.099 s after 0.1 s)"]),
    "non-uniform time": (_csv(edit=_drop_row),
                         ["non-uniform time base at row 502, column time_s: step 0.002 s, "
                          "median step 0.001 s"]),
    "non-uniform time xlsx": (lambda d: write_xlsx(d / "bad.xlsx", *_uneven()),
                              ["non-uniform time base at sheet z, row 1011, column A"]),
    "too short": (lambda d: write_csv(d / "bad.csv", *signal(100)),
                  ["too short: 100 samples, at least 2048"]),
    "saturated csv": (_csv(edit=_set_row(56, "0.054,0.1,0.2,16.7")),
                      ["sensor saturated", "axis z from row 56, column az"]),
    "saturated xlsx": (_xlsx(cells={("y", 20, 2): 5.1}),  # 5.1 V is +1.7 g
                       ["sensor saturated", "axis y from sheet y, row 20, column B"]),
    "missing csv column": (_csv(header="time_s,ax,ay"), ["header row 1: missing column az"]),
    "unexpected csv column": (_csv(header="time_s,ax,ay,a_z"),
                              ["missing column az; unexpected column 'a_z'"]),
    "unsupported suffix": (_raw("bad.txt", b"x"), ["unsupported file type '.txt'"]),
    "missing file": (lambda d: d / "absent.xlsx", ["absent.xlsx: file not found"]),
}


def _uneven():
    t, a = signal()
    t[1000:] += 0.0005
    return t, a


@pytest.mark.parametrize("case", BAD_RUNS)
def test_bad_run_is_reported_by_file_and_place(tmp_path, case):
    make, fragments = BAD_RUNS[case]
    path = make(tmp_path)
    with pytest.raises(DataError) as e:
        m.read_run(path)
    message = str(e.value)
    assert message.startswith(str(path))
    for fragment in fragments:
        assert fragment in message


def test_saturation_names_every_axis_and_first_row(tmp_path):
    t, a = signal()
    a[30, 0] = -17.0
    a[[80, 90], 2] = 16.7
    with pytest.raises(DataError) as e:
        m.read_run(write_csv(tmp_path / "r.csv", t, a))
    assert ("axis x from row 32, column ax (-17.00 m/s^2); "
            "axis z from row 82, column az (+16.70 m/s^2)") in str(e.value)
    # samples just under the limit are fine (a few of them: a whole record at
    # 1.7 g would be refused as wrong units, its magnitude being no longer 1 g)
    a[80:120, 2] = 0.999 * m.SENSOR_RANGE_M_S2 - 1e-6
    a[30, 0] = 0
    m.read_run(write_csv(tmp_path / "r.csv", t, a))


def test_a_sensor_turning_with_a_wheel_is_not_refused_as_wrong_units(tmp_path):
    # Sec. 3.2's OnWheel runs: gravity turns with the cube, so the mean vector of the
    # record averages towards zero over whole revolutions while every sample still
    # reads 1 g; the units check reads the magnitude, not the mean vector
    t = np.arange(20000) / 1000.0
    angle = 2 * np.pi * 0.13 * t  # a wheel at 10 deg/s of swivel turns at ~0.13 Hz
    a = np.column_stack([9.81 * np.sin(angle), 0.05 * np.sin(2 * np.pi * 7 * t),
                         9.81 * np.cos(angle)])
    assert np.linalg.norm(a.mean(axis=0)) < 0.5 * 9.8  # what the old check refused
    rec = m.read_run(write_csv(tmp_path / "v0-w10-t20-OnWheel-concrete.csv", t, a))
    assert rec.accel.shape == (20000, 3)


# --------------------------------------------------------------------------- datasets

INFOS = [
    info("v0-w10-t20-concrete-1.xlsx", 0.0, 10.0, "concrete", "extended", "platform", 1),
    info("v0-w10-t20-concrete-2.csv", 0.0, 10.0, "concrete", "extended", "platform", 2),
    info("sub/wheel.xlsx", 0.0, -20.0, "tile", "platform", "wheel", 1, (0.1, 0.2, -0.05),
         "cube on wheel, rear"),
]


def test_runs_csv_dataset_loads_good_runs_and_skips_malformed(tmp_path):
    t, a = signal()
    m.write_run(tmp_path / INFOS[0].file, t, a)
    m.write_run(tmp_path / INFOS[1].file, t, a)
    (tmp_path / "sub").mkdir()
    write_xlsx(tmp_path / INFOS[2].file, t, a, cells={("y", 57, 2): "oops"})
    ds_.write_runs_csv(tmp_path, INFOS)
    ds = ds_.read_dataset(tmp_path)
    assert [i for i, _ in ds.runs] == INFOS[:2]
    assert all(rec.accel.shape == (N, 3) for _, rec in ds.runs)
    [skip] = ds.skipped
    assert skip["file"] == "sub/wheel.xlsx"
    assert "wheel.xlsx" in skip["reason"] and "sheet y, row 57, column B" in skip["reason"]


def test_runs_csv_round_trip_and_optional_columns(tmp_path):
    ds_.write_runs_csv(tmp_path, INFOS)
    assert (tmp_path / "runs.csv").read_text().splitlines()[0] == \
        "file,v_mps,omega_deg_s,floor,build,mount,trial,accel_x_m,accel_y_m,accel_z_m,notes"
    for i in INFOS:
        (tmp_path / i.file).parent.mkdir(exist_ok=True)
        (tmp_path / i.file).touch()
    ds = ds_.read_dataset(tmp_path, load=False)
    assert ds.runs == [(i, None) for i in INFOS] and ds.skipped == []
    ds_.write_runs_csv(tmp_path, INFOS[:2])
    assert (tmp_path / "runs.csv").read_text().splitlines()[0] == \
        "file,v_mps,omega_deg_s,floor,build,mount,trial"


def test_runs_csv_reads_the_thesis_layouts_column_names(tmp_path):
    # the thesis layout (shared/spec/measured-data.md) named them "surface" and "config"
    (tmp_path / "a.csv").touch()
    (tmp_path / "runs.csv").write_text("file,v_mps,omega_deg_s,surface,config,mount,trial\n"
                                       "a.csv,0,10,carpet,platform,platform,1\n")
    ds = ds_.read_dataset(tmp_path, load=False)
    assert [i for i, _ in ds.runs] == [info("a.csv", 0, 10, "carpet", "platform", "platform", 1)]


def test_runs_csv_bad_rows_are_skipped_with_row_number(tmp_path):
    for name in ("a.csv", "b.csv", "c.csv", "d.csv", "orphan.csv"):
        (tmp_path / name).touch()
    (tmp_path / "runs.csv").write_text(
        "file,v_mps,omega_deg_s,surface,config,mount,trial\n"
        "a.csv,0,10,concrete,extended,platform,1\n"
        ",0,10,concrete,extended,platform,2\n"
        "b.csv,0,10,grass,extended,platform,1\n"
        "c.csv,0,10,tile,extended,roof,1\n"
        "d.csv,0,ten,tile,extended,platform,1\n"
        "gone.csv,0,10,tile,extended,platform,1\n"
        "a.csv,0,10,tile,extended,platform,3\n")
    ds = ds_.read_dataset(tmp_path, load=False)
    assert [i.file for i, _ in ds.runs] == ["a.csv"]
    reasons = {s["reason"] for s in ds.skipped}
    assert reasons == {
        "runs.csv row 3: no file given",
        "runs.csv row 4: surface 'grass' has no simulation counterpart "
        "(known: concrete, tile, carpet)",
        "runs.csv row 5: mount 'roof' has no simulation counterpart (known: platform, wheel)",
        "runs.csv row 6: omega_deg_s: 'ten' is not a number",
        f"runs.csv row 7: file 'gone.csv' not found in {tmp_path}",
        "runs.csv row 8: file 'a.csv' already described in row 2",
        "orphan.csv: no row of runs.csv describes this file",
    }


def test_runs_csv_with_bad_header_skips_everything_but_returns(tmp_path):
    (tmp_path / "a.csv").touch()
    (tmp_path / "runs.csv").write_text("file,v_mps,omega,surface,config,mount,trial\n")
    ds = ds_.read_dataset(tmp_path)
    assert ds.runs == []
    assert ds.skipped[0]["file"] == "runs.csv"
    reason = ds.skipped[0]["reason"]
    assert "missing column(s) ['omega_deg_s'], unknown column(s) ['omega']" in reason
    assert ds.skipped[1] == {"file": "a.csv",
                             "reason": "a.csv: no row of runs.csv describes this file "
                                       "(runs.csv is unusable: see its own entry)"}


def test_dataset_from_thesis_names(tmp_path):
    t, a = signal()
    m.write_run(tmp_path / "v0-w10-t20-OnWheel-noFrame-concrete.xlsx", t, a)
    m.write_run(tmp_path / "v0-w12-t20-carpet-2.csv", t, a)
    m.write_run(tmp_path / "notes.csv", t, a)
    write_csv(tmp_path / "v0-w14-t20-tile.csv", *signal(50))
    ds = ds_.read_dataset(tmp_path)
    assert [i for i, _ in ds.runs] == [
        info("v0-w10-t20-OnWheel-noFrame-concrete.xlsx", 0, 10, "concrete", "platform", "wheel",
             1),
        info("v0-w12-t20-carpet-2.csv", 0, 12, "carpet", "extended", "platform", 2),
    ]
    reasons = {s["file"]: s["reason"] for s in ds.skipped}
    assert "not a thesis run name" in reasons["notes.csv"] and "no runs.csv" in reasons["notes.csv"]
    assert "too short: 50 samples" in reasons["v0-w14-t20-tile.csv"]


def test_dataset_root_must_exist(tmp_path):
    with pytest.raises(DataError, match="not a directory"):
        ds_.read_dataset(tmp_path / "nowhere")


# --------------------------------------------------------------------------- fuzz: only DataError

def _read_or_data_error(path):
    try:
        m.read_run(path)
    except DataError:
        pass


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(content=st.one_of(
    st.binary(max_size=300),
    st.text(max_size=300).map(str.encode),
    st.lists(st.lists(st.one_of(st.floats(), st.integers(), st.text(max_size=5)), max_size=5),
             max_size=30).map(lambda rows: ("time_s,ax,ay,az\n" + "\n".join(
                 ",".join(map(str, r)) for r in rows)).encode()),
))
def test_fuzz_csv_only_data_error(tmp_path_factory, content):
    path = tmp_path_factory.mktemp("fuzz") / "run.csv"
    path.write_bytes(content)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(m, "MIN_SAMPLES", 4)
        _read_or_data_error(path)


_CELL = st.one_of(st.none(), st.booleans(), st.integers(min_value=-10**300, max_value=10**300),
                  st.floats(), st.datetimes(),
                  st.text(st.characters(blacklist_categories=("Cs", "Cc")), max_size=8))
_SHEET_NAMES = [("z", "y", "x"), ("z", "y"), ("Sheet1", "Sheet2", "Sheet3"), ("x", "y", "z")]


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cells=st.dictionaries(st.tuples(st.integers(0, 2), st.integers(1, 40), st.integers(1, 3)),
                             _CELL, max_size=6),
       names=st.sampled_from(_SHEET_NAMES))
def test_fuzz_xlsx_only_data_error(tmp_path_factory, cells, names):
    path = tmp_path_factory.mktemp("fuzz") / "run.xlsx"
    cells = {(names[min(k, len(names) - 1)], r, c): v for (k, r, c), v in cells.items()}
    write_xlsx(path, *signal(30), names=names, cells=cells)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(m, "MIN_SAMPLES", 4)
        _read_or_data_error(path)
