"""The command line: the main job writes a run in the measured-data layout."""

from __future__ import annotations

import json

import numpy as np

from skidsteer.cli import main


def test_swivel_writes_accelerometer_log_in_measured_data_layout(tmp_path, capsys):
    out = tmp_path / "v0-w30-t2-concrete.csv"
    assert main(["swivel", "--omega", "30", "--duration", "2", "--settle", "0.5",
                 "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    with open(out) as f:
        assert f.readline().strip() == "time_s,ax,ay,az"  # shared/spec/measured-data.md
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


def test_tire_loads_json(capsys):
    assert main(["tire-loads", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert len(result["normal_forces_N"]) == 4
