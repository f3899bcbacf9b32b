"""The command line: the main job writes a run in the data format (docs/data-format.md)."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from skidsteer.cli import main
from skidsteer.data import DataError, read_dataset


def test_swivel_writes_accelerometer_log_in_measured_data_layout(tmp_path, capsys):
    out = tmp_path / "v0-w30-t2-concrete.csv"
    assert main(["swivel", "--omega", "30", "--duration", "2", "--settle", "0.5",
                 "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    with open(out) as f:
        assert f.readline().strip() == "time_s,ax,ay,az"  # docs/data-format.md
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (2000, 4)
    np.testing.assert_allclose(np.diff(data[:, 0]), 1e-3, atol=1e-6)  # 1 kHz as the thesis
    # an accelerometer reads +g on z when level (specific force), within the
    # vibration of the swivel
    assert abs(data[:, 3].mean() - 9.81) < 0.05
    # skid-steer: the robot turns the commanded way, slower than commanded
    assert 5 < summary["mean_yaw_rate_deg_s"] < 30
    assert summary["wheel_lift_fraction"] == 0.0
    assert summary["accelerometer_log"] == str(out)
    assert set(summary["amplitude_m_s2"]) == {"x", "y", "z"}
    assert not list(tmp_path.glob("*.part"))  # written atomically


def test_plugin_path_prints_the_library_and_its_folder(capsys):
    assert main(["plugin-path"]) == 0
    library = Path(capsys.readouterr().out.strip())
    assert library.is_absolute() and library.is_file()
    assert library.name == "libskidsteer_tire.so"
    assert main(["plugin-path", "--dir"]) == 0
    assert Path(capsys.readouterr().out.strip()) == library.parent


def test_tire_loads_json(capsys):
    assert main(["tire-loads", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert len(result["normal_forces_N"]) == 4


@pytest.mark.slow
def test_free_response_json(capsys):
    assert main(["free-response", "--axis", "pitch", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["axis"] == "pitch" and result["accelerometer_axis"] == "x"
    assert {"peak_hz", "refined_peak_hz", "decay_per_s"} <= set(result)


def test_pull_json_and_trace_file(tmp_path, capsys):
    trace = tmp_path / "trace.csv"
    assert main(["pull", "--direction", "lateral", "--height", "0", "--wheels", "locked",
                 "--distance", "0.003", "--out", str(trace), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["build"] == "platform"  # the rig of Sec. 3.3 pulls the platform
    assert len(result["trace"]["travel_m"]) == len(result["trace"]["force_N"]) > 100
    data = np.loadtxt(trace, delimiter=",", skiprows=1)
    assert data.shape[1] == 2 and data[-1, 0] == pytest.approx(0.003, abs=1e-4)


def test_pull_rejects_spinning_without_slip_velocity(capsys):
    assert main(["pull", "--wheels", "spinning"]) == 2
    assert "--slip-velocity" in capsys.readouterr().err


def test_sweep_then_analyze_a_simulated_dataset(tmp_path, capsys):
    data, out = tmp_path / "data", tmp_path / "analysis"
    assert main(["sweep", "--out", str(data), "--omega", "10", "--omega", "30",
                 "--surface", "carpet", "--duration", "3", "--format", "xlsx",
                 "--quiet"]) == 0
    names = sorted(p.name for p in data.iterdir())
    assert names == ["runs.csv", "v0-w10-t3-carpet-1.xlsx", "v0-w30-t3-carpet-1.xlsx"]
    assert main(["analyze", str(data), "--out", str(out), "--no-figures", "--json"]) == 0
    capsys.readouterr()
    result = json.loads((out / "analysis.json").read_text())
    assert [r["omega_deg_s"] for r in result["summary"]] == [10.0, 30.0]
    assert not result["skipped"]
    # rerunning the sweep finds every file present and simulates nothing
    mtimes = {p.name: p.stat().st_mtime_ns for p in data.glob("*.xlsx")}
    assert main(["sweep", "--out", str(data), "--omega", "10", "--omega", "30",
                 "--surface", "carpet", "--duration", "3", "--format", "xlsx",
                 "--quiet"]) == 0
    assert mtimes == {p.name: p.stat().st_mtime_ns for p in data.glob("*.xlsx")}


@pytest.mark.slow
def test_a_killed_sweep_looks_unfinished_and_its_rerun_equals_an_uninterrupted_one(tmp_path):
    # issue 7: kill a sweep midway (SIGKILL: no cleanup runs), rerun the same
    # command, and get the files an uninterrupted sweep writes, byte for byte
    args = ["sweep", "--omega", "10", "--omega", "20", "--omega", "30", "--omega", "40",
            "--surface", "concrete", "--surface", "carpet", "--duration", "4",
            "--threads", "1", "--quiet"]
    whole, killed = tmp_path / "whole", tmp_path / "killed"
    assert main(args + ["--out", str(whole)]) == 0
    expected = {p.name: p.read_bytes() for p in whole.iterdir()}
    assert len(expected) == 9  # 8 runs and runs.csv, no marker, no temporaries

    process = subprocess.Popen(
        [sys.executable, "-c", "import sys; from skidsteer.cli import main; "
         "sys.exit(main(sys.argv[1:]))", *args, "--out", str(killed)])
    deadline = time.monotonic() + 120
    while not list(killed.glob("v0-*.csv")) and time.monotonic() < deadline:
        time.sleep(0.01)
    process.send_signal(signal.SIGKILL)
    process.wait()
    runs = list(killed.glob("v0-*.csv"))
    # killed after its first run file and before its last (8 runs of 4 s on one
    # thread take several seconds; the poll is 10 ms)
    assert 1 <= len(runs) < 8, len(runs)
    assert not (killed / "runs.csv").exists()
    with pytest.raises(DataError, match="unfinished"):
        read_dataset(killed)
    for run in runs:  # what is there is whole
        assert run.read_bytes() == expected[run.name]

    assert main(args + ["--out", str(killed)]) == 0
    assert {p.name: p.read_bytes() for p in killed.iterdir()} == expected


SIMULATING_COMMANDS = [["swivel"], ["free-response"], ["pull"], ["straight"],
                       ["sweep", "--out", "x"], ["reproduce", "--out", "x"],
                       ["compare", "x"], ["diagnose", "x"]]


@pytest.mark.parametrize("command", SIMULATING_COMMANDS, ids=lambda c: c[0])
@pytest.mark.parametrize("bad", ["0", "-1e-3", "nan", "inf", "fast"])
def test_every_simulating_command_refuses_a_bad_timestep_by_name(command, bad, capsys):
    # argparse exits with 2 before anything simulates
    with pytest.raises(SystemExit) as exit_info:
        main(command + [f"--timestep={bad}"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "--timestep" in err and repr(bad) in err, err


def test_straight_and_pull_run_at_the_timestep_given(capsys):
    # a step they would not take by default: the run must say so in its result
    assert main(["straight", "--speed", "0.3", "--duration", "1", "--timestep", "5e-4",
                 "--json"]) == 0
    straight = json.loads(capsys.readouterr().out)
    assert main(["pull", "--distance", "0.01", "--timestep", "5e-4", "--json"]) == 0
    pull = json.loads(capsys.readouterr().out)
    assert straight["timestep_s"] == 5e-4 and pull["timestep_s"] == 5e-4
