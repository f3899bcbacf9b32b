"""diagnose on real recordings: the robot and its terrains identified apart, an unknown
terrain identified, deformable ground told from rigid by its evidence, the wheel-order
lines explained; effects hidden in recordings the model itself made."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from skidsteer.cli import main
from skidsteer.data import DataError
from skidsteer.data.imu import ImuRun, WheelSpeeds, write_borealtc_run
from skidsteer.data.terrains import terrain_paths
from skidsteer.diagnosis import ground, identify, lines, motion
from skidsteer.experiments.replay import replay
from skidsteer.features.segments import Segment, centripetal_ratio, segment_vibration
from skidsteer.reports.real_data import diagnose_recordings
from skidsteer.robot import Setup, load_model, load_robot, load_spec, roles

EXCERPT = Path(__file__).parent / "data" / "borealtc"
TRACK_M = 0.5708  # the Husky's (URDF)
RADIUS_M = 0.1651


def _husky(floor="flooring", edit=None, tire=None):
    return load_model(Setup(robot="husky_a200", build="base", floor=floor), edit=edit,
                      tire=tire)


def _schedule(number: int, pieces) -> ImuRun:
    """A run of held wheel commands (left, right m/s, seconds each) at 100 Hz; its IMU
    is filled in by replaying it."""
    starts = np.concatenate([[0.0], np.cumsum([p[2] for p in pieces])])
    t = np.arange(0, starts[-1], 0.01)
    wheels = WheelSpeeds(starts[:-1], np.array([p[0] for p in pieces]),
                         np.array([p[1] for p in pieces]),
                         np.tile([2.0, 2.0], (len(pieces), 1)))
    return ImuRun(Path(f"imu_{number:02d}.csv"), t, np.tile([0, 0, 9.81], (len(t), 1)),
                  np.zeros((len(t), 3)), wheels)


# turning in place both ways, tight and gentle arcs, straight: an operator's drive; the
# first run of a terrain trains, the second is held out.  A straight run at 0.78 m/s, as
# BorealTC's asphalt has: the wheels turning faster than logged lower chi as the tyres'
# sideways friction does, and the robot's top speed (1.0 m/s) is what rules it out
SCHEDULES = {  # (left, right m/s, s); successive arcs turn opposite ways (one segment each)
    "FLOORING": [[(-0.08, 0.08, 5), (0.12, -0.12, 5), (0.10, 0.22, 5), (0.25, 0.20, 5),
                  (0.20, 0.25, 5), (0.22, 0.08, 5), (0.23, 0.23, 5)],
                 [(0.10, -0.10, 5), (-0.06, 0.06, 5), (0.22, 0.10, 5), (0.19, 0.23, 5),
                  (0.25, 0.20, 5), (0.06, 0.20, 5), (0.20, 0.20, 5)]],
    "ASPHALT": [[(0.15, -0.15, 5), (0.30, 0.55, 5), (0.55, 0.45, 5), (0.42, 0.52, 5),
                 (0.55, 0.25, 5), (0.78, 0.78, 5)],
                [(-0.12, 0.12, 5), (0.55, 0.30, 5), (0.45, 0.55, 5), (0.52, 0.43, 5),
                 (0.28, 0.55, 5), (0.78, 0.78, 5)]],
}
# the hidden robot: Coulomb friction on the resultant slip, its tyres sliding sideways at
# 0.6 of their longitudinal friction (what the BorealTC Husky's hard floors point to)
TRUTH_TIRE = {"slip_law": "combined", "tread_lateral_friction_ratio": "0.6"}


def _write_terrains(root: Path, tire: dict | None) -> Path:
    for name, runs in SCHEDULES.items():
        m = _husky(name.lower(), tire=tire)
        for i, pieces in enumerate(runs):
            write_borealtc_run(root / name, i, replay(m, _schedule(i, pieces)))
    return root


@pytest.fixture(scope="module")
def hidden_robot(tmp_path_factory):
    root = _write_terrains(tmp_path_factory.mktemp("hidden_robot"), TRUTH_TIRE)
    out = tmp_path_factory.mktemp("hidden_robot_out")
    result = diagnose_recordings([root], out, progress=False, lines=False)
    return root, out, result


# ------------------------------------------------------------------ fast: the pieces

def test_terrain_paths_take_terrain_folders_or_a_folder_of_them(tmp_path):
    for name in ("FLOORING", "SANDY_LOAM"):
        shutil.copytree(EXCERPT / name, tmp_path / "data" / name)
    found = terrain_paths([tmp_path / "data"])
    assert [p.name for p in found] == ["FLOORING", "SANDY_LOAM"]
    assert [p.name for p in terrain_paths([tmp_path / "data" / "FLOORING"])] == ["FLOORING"]
    with pytest.raises(DataError, match="given twice"):
        terrain_paths([tmp_path / "data", tmp_path / "data" / "FLOORING"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(DataError, match="empty: neither recordings"):
        terrain_paths([tmp_path / "empty"])


def test_the_centripetal_ratio_is_the_slope_of_a_y_over_v_omega():
    rng = np.random.default_rng(0)
    x = rng.uniform(-0.1, 0.1, 40)
    k = centripetal_ratio(x, 1.3 * x + rng.normal(0, 0.002, 40))
    # 40 points of 0.002 m/s^2 noise over a spread of 0.06 m/s^2: k to ~0.01
    assert k["k"] == pytest.approx(1.3, abs=0.03) and 0 < k["stderr"] < 0.03
    assert centripetal_ratio(x[:2], x[:2])["k"] is None
    # each run's IMU bias (0.06 and -0.03 m/s^2: a tilt) is an intercept of its own
    run = np.repeat([0, 1], 20)
    biased = 1.3 * x + np.where(run == 0, 0.06, -0.03) + rng.normal(0, 0.002, 40)
    assert centripetal_ratio(x, biased, run)["k"] == pytest.approx(1.3, abs=0.03)


def test_the_stuck_limit_is_twice_what_isotropic_coulomb_friction_gives():
    a, c = 0.256, 0.2854  # the Husky's half wheelbase and half track (URDF)
    assert identify.stuck_chi(_husky()) == pytest.approx(2 * (1 + (a / c) ** 2), rel=1e-3)


def _row(kind, chi, current=None, half="fit", left=-0.1, right=0.1):
    return {"kind": kind, "half": half, "left_mps": left, "right_mps": right,
            "yaw_rate_predicted_deg_s": 20.0, "chi_measured": chi, "current_a": current}


def test_rolling_resistance_names_deformable_ground_and_stuck_turns_alone_do_not():
    rigid = [_row("straight", None, 2.0, left=0.3, right=0.3) for _ in range(5)]
    soft = [_row("straight", None, 4.0, left=0.3, right=0.3) for _ in range(5)]
    turns = [_row("turn_in_place", c) for c in (1.4, 1.45, 1.5, 1.42, 1.44)]
    judged = ground.judge(soft + turns, 3.6, ground.rolling_current(rigid))
    assert judged["deformable"] and judged["rolling_current_ratio"] == pytest.approx(2.0)
    assert "2.0x the motor current" in judged["evidence"][0]
    # a drive that stalls on a grippy hard floor: stuck turns, rolling current as rigid
    stalled = [_row("turn_in_place", c) for c in (1.4, 20.0, 30.0, 1.45, 25.0)]
    judged = ground.judge(rigid + stalled, 3.6, 2.0)
    assert judged["stuck_segments"] == 3 and not judged["deformable"]


def test_segments_that_scatter_like_a_stuck_robot_are_a_sign_of_deformable_ground():
    # SNOW in BorealTC: the robot turns in some segments, at chi from 1.6 to 3, and is
    # stuck in others
    chis = [2.0, 2.2, 9.0, 30.0, 2.1, 15.0, 40.0, 3.0, 1.6, 2.8]
    judged = ground.judge([_row("turn_in_place", c) for c in chis], 3.6, None)
    assert judged["deformable"], judged
    assert any("scatters" in e for e in judged["evidence"])
    assert any("barely turn" in e for e in judged["evidence"])


def test_every_turning_segment_has_surrogate_commands_of_its_class():
    rows = [_row("turn_in_place", 1.4, left=-0.1, right=0.1),
            _row("turn_in_place", 1.4, left=0.1, right=-0.1),
            _row("arc", 1.4, left=0.1, right=0.3), _row("arc", 1.5, left=0.2, right=0.24),
            _row("arc", 1.4, left=0.05, right=0.35),
            _row("arc", 50.0, left=0.1, right=0.3)]  # stuck: not scored
    groups, group_of = identify.plan_groups(rows, 3.6)
    assert set(group_of) == {0, 1, 2, 3, 4}
    assert [identify.class_of(rows[i]) for i in (2, 3, 4)] == ["arc_tight", "arc_gentle",
                                                               "arc_tight"]
    # the two tight arcs' sizes (|d / v| 0.5 and 0.75) span two commands at their median
    # forward speed (0.2 m/s), between which each is interpolated
    tight = [groups[g] for g in group_of[2]]
    assert group_of[2] == group_of[4] and len(tight) == 2
    assert [g.size for g in tight] == pytest.approx([0.5625, 0.6875])
    assert all((g.left_mps + g.right_mps) / 2 == pytest.approx(0.2) for g in tight)
    assert len(group_of[3]) == 1 and len(group_of[0]) == 1


def test_motion_parameters_set_what_base_values_reads_back():
    spec = load_spec(Setup(robot="husky_a200", build="base", floor="asphalt"))
    values = {"logged_speed_scale": 1.2, "com_x_m": 0.03, "com_y_m": -0.01,
              "lambda_max": 0.05, "lateral_friction_ratio": 0.8,
              "tread_lateral_friction_ratio": 0.7, "mu_static": 0.6}
    motion.apply(spec, values)
    assert motion.base_values(spec) == pytest.approx(values)
    m = spec.compile()
    assert roles.model_numeric(m, "drive.logged_speed_scale", 1.0) == pytest.approx(1.2)


def test_the_drivetrain_error_pushes_fore_aft_at_its_order():
    # a transmission error of 0.1 mm at the rim, 18 times a wheel revolution: a fore-aft
    # line at order 18 clear of the background, none on the round-wheeled base model
    edit = lines.drivetrain_edit(18, [1e-4])
    run = lines.straight_run(0.4, 100.0)
    seg = Segment(run.path.name, 1.0, float(run.time_s[-1]), "straight", 0.4, 0.4)
    rippled = segment_vibration(seg, replay(_husky(edit=edit), run), RADIUS_M)
    plain = segment_vibration(seg, replay(_husky(), run), RADIUS_M)
    assert rippled["prominence_db"][17, 0] > 20 > plain["prominence_db"][17, 0]
    assert rippled["power"][17, 0] > 1e3 * plain["power"][17, 0]


def test_an_imu_mount_sways_sideways_at_its_frequency():
    # the order-36 line of a 0.1 mm order-18 transmission error at 0.576 m/s lies at 20
    # Hz; a mount tuned there at 3 % of critical damping amplifies it ~1/(2 zeta) = 17x in
    # a_y and leaves a_x alone (it slides sideways only); 10 dB and 1 dB: clear of the
    # +-3 dB a line of a few Welch averages scatters by, and of the mount's 0.1 kg moving
    # the 57 kg robot
    speed = 20.0 * 2 * np.pi * RADIUS_M / 36
    run = lines.straight_run(speed, 100.0)
    seg = Segment(run.path.name, 1.0, float(run.time_s[-1]), "straight", speed, speed)
    ripple = lines.drivetrain_edit(18, [1e-4, 1e-4])
    mount = lines.imu_mount_edit(20.0, 0.03)
    m = _husky(edit=lambda spec: (ripple(spec), mount(spec)))
    assert m.sensor("accelerometer").objid == m.site("imu_mount_site").id
    mounted = segment_vibration(seg, replay(m, run), RADIUS_M)
    rigid = segment_vibration(seg, replay(_husky(edit=ripple), run), RADIUS_M)
    gain_db = 10 * np.log10(mounted["power"][35] / rigid["power"][35])
    assert gain_db[1] > 10 and abs(gain_db[0]) < 1, gain_db
    # the diagnosis screens mounts through the transmissibility of a massless one: on the
    # line it tunes and on the lateral RMS it must read what the simulated mount does,
    # within 1 dB (the mount's 0.2 % of the robot's mass, the line's bin straddling 20 Hz)
    read = lines.through_mount(rigid, speed, RADIUS_M, 20.0, 0.03)
    assert 10 * np.log10(read["power"][35, 1] / mounted["power"][35, 1]) == pytest.approx(
        0, abs=1.0)
    assert 20 * np.log10(read["rms_m_s2"][1] / mounted["rms_m_s2"][1]) == pytest.approx(
        0, abs=1.0)


def test_every_straight_segment_is_read_at_a_surrogate_within_a_tenth_of_its_speed():
    speeds = [0.23, 0.23, 0.24, 0.32, 0.44, 0.46, 0.47, 0.75, 0.78, 0.78]
    centres, group = lines.speed_clusters(speeds)
    assert len(centres) == 4
    for v, g in zip(speeds, group):
        assert abs(centres[g] / v - 1) <= lines.SPEED_TOLERANCE - 1
    # a continuous sweep keeps the simulations to MAX_SPEEDS
    centres, group = lines.speed_clusters(np.linspace(0.1, 1.0, 50))
    assert len(centres) <= lines.MAX_SPEEDS and len(set(group)) == len(centres)


def test_held_out_segments_faster_than_any_training_one_are_said():
    class Terrain:
        name = "ASPHALT"
        segs = [{"half": h, "left_mps": v, "right_mps": v}
                for h, v in (("fit", 0.23), ("fit", 0.47), ("held_out", 0.78))]
    said = lines.speed_coverage(Terrain)
    assert "0.78 m/s" in said and "0.47 m/s" in said
    Terrain.segs = Terrain.segs[:2] + [{"half": "held_out", "left_mps": 0.5, "right_mps": 0.5}]
    assert lines.speed_coverage(Terrain) is None


def test_the_lug_count_is_the_line_whose_multiples_are_lines():
    assert lines.lug_count_of([4, 18, 19, 35, 36, 53, 54]) == 18
    assert lines.lug_count_of([18, 36, 54]) == 18
    assert lines.lug_count_of([22]) is None
    assert lines.lug_count_of([12, 24, 36, 48]) == 12


# ------------------------------------------------------------------ slow: end to end

@pytest.mark.slow
def test_diagnose_identifies_a_robot_hidden_in_two_terrains(hidden_robot):
    root, out, result = hidden_robot
    m = result["motion"]
    assert m["verdict"] in ("explained", "partly-explained"), m["reason"]
    assert set(m["cause"].split(" + ")) >= {"tread_anisotropy", "combined_slip"}, m["cause"]
    ratio = m["named"]["robot"]["tread_lateral_friction_ratio"]
    # within 15 % of the truth: chi moves about as the ratio does, and the features are
    # scored at a few % (set before the run)
    assert ratio == pytest.approx(0.6, rel=0.15)
    low, high = m["named"]["intervals"]["tread_lateral_friction_ratio"]
    assert low <= ratio <= high
    # no terrain parameter: the terrains are the robot's own floors
    assert not any(m["named"]["terrain"].values())
    saved = json.loads((out / "diagnosis.json").read_text())
    rows = saved["terrains"]["FLOORING"]["rows"]
    assert {"run", "segment_s", "yaw_rate_measured_deg_s", "yaw_rate_base_deg_s",
            "yaw_rate_extended_deg_s", "chi_extended"} <= set(rows[0])
    # held-out runs replayed on the extended model: chi within 10 % of the measured
    for t in saved["terrains"].values():
        for key, e in t["chi"].items():
            if key.endswith("/held_out"):
                assert e["extended"] == pytest.approx(e["measured"], rel=0.1), (key, e)


@pytest.mark.slow
def test_the_identified_robot_travels_to_a_terrain_it_never_fitted(hidden_robot, tmp_path):
    root, out, _ = hidden_robot
    robot = load_robot(out / "extended_model.xml")
    assert robot.identified["causes"] and "flooring" in robot.floors
    # a third floor the robot never drove on, as the truth drives it there
    m = _husky("flooring", tire={**TRUTH_TIRE, "mu_static": "0.6", "mu_kinetic": "0.55"})
    for i, pieces in enumerate(SCHEDULES["FLOORING"]):
        write_borealtc_run(tmp_path / "TILE_NEW", i, replay(m, _schedule(i, pieces)))
    assert main(["diagnose", str(tmp_path / "TILE_NEW"), "--model",
                 str(out / "extended_model.xml"), "--out", str(tmp_path / "out"),
                 "--no-progress"]) == 0
    result = json.loads((tmp_path / "out" / "diagnosis.json").read_text())
    # the identified robot is not fitted again, and predicts the new floor as it is
    assert not any(f["robot"] for f in result["motion"]["fits"])
    assert result["motion"]["verdict"] == "no-discrepancy", result["motion"]["reason"]


@pytest.mark.slow
def test_the_base_models_own_recordings_name_nothing(tmp_path):
    root = _write_terrains(tmp_path / "data", None)
    result = diagnose_recordings([root], tmp_path / "out", progress=False)
    assert result["motion"]["verdict"] == "no-discrepancy", result["motion"]["reason"]
    assert result["lines"]["cause"] is None, result["lines"]["reason"]
    assert not any(t["ground"]["deformable"] for t in result["terrains"].values())


@pytest.mark.slow
def test_sandy_loam_beside_a_flooring_is_deformable_from_the_command_line(tmp_path, capsys):
    # the real sandy loam (4.16 A driving straight in the excerpt) beside a flooring the
    # model drove at the current the real flooring draws driving straight (1.9 A):
    # deformable, named why, moving no robot parameter
    shutil.copytree(EXCERPT / "SANDY_LOAM", tmp_path / "data" / "SANDY_LOAM")
    m = _husky("flooring")
    for i, pieces in enumerate(SCHEDULES["FLOORING"]):
        run = replay(m, _schedule(i, pieces))
        wheels = run.wheels
        run = ImuRun(run.path, run.time_s, run.accel, run.gyro, WheelSpeeds(
            wheels.time_s, wheels.left_mps, wheels.right_mps,
            np.full((len(wheels.time_s), 2), 1.9)))
        write_borealtc_run(tmp_path / "data" / "FLOORING", i, run)
    assert main(["diagnose", str(tmp_path / "data"), "--model", "husky_a200", "--out",
                 str(tmp_path / "out"), "--no-progress", "--no-leave-one-out"]) == 0
    result = json.loads((tmp_path / "out" / "diagnosis.json").read_text())
    sandy = result["terrains"]["SANDY_LOAM"]
    assert sandy["floor"] is None and sandy["ground"]["deformable"]
    assert sandy["ground"]["rolling_current_ratio"] == pytest.approx(4.16 / 1.9, rel=0.02)
    assert "rolling resistance" in sandy["ground"]["evidence"][0]
    assert "SANDY_LOAM" not in result["motion"]["features"]
    out = capsys.readouterr().out
    assert "SANDY_LOAM: deformable" in out and "identified robot:" in out
    assert (tmp_path / "out" / "report.md").is_file()
    assert (tmp_path / "out" / "figures" / "chi_per_segment.png").is_file()


def test_a_terrain_without_a_rigid_reference_is_taken_as_rigid_and_said_so():
    # the excerpt's two flooring runs hold no straight driving: no rigid rolling current
    # to hold sandy loam's against
    rows = [_row("straight", None, 4.16, left=0.24, right=0.24)]
    judged = ground.judge(rows, 3.6, None)
    assert not judged["deformable"]
    assert "for want of evidence" in judged["evidence"][0]


def test_a_tie_with_a_wheel_speed_scale_proposes_the_speed_that_rules_it_out():
    from types import SimpleNamespace

    from skidsteer.diagnosis.recordings import next_recording
    case = SimpleNamespace(setup=Setup(robot="husky_a200", build="base", floor="flooring"),
                           rows=[_row("straight", None, 4.16, left=0.24, right=0.24)])
    scaled = SimpleNamespace(cause="wheel_speed_scale", robot={"logged_speed_scale": 1.6})
    law = SimpleNamespace(cause="combined_slip + tread_anisotropy", robot={})
    said = next_recording([law, scaled], [case])
    # the Husky's 1.0 m/s top speed over the scale: 0.625 m/s
    assert "above 0.62 m/s (these reach 0.24)" in said and "wheel_speed_scale" in said
    assert next_recording([law, law], [case]) is None  # nothing known separates them


@pytest.mark.parametrize("option", [["--model-spread"], ["--search-starts", "3"],
                                    ["--hold-out", "v0-w60"]])
def test_options_of_a_swivel_datasets_fits_are_refused_on_real_recordings(tmp_path, capsys,
                                                                         option):
    data = tmp_path / "SANDY_LOAM"
    shutil.copytree(EXCERPT / "SANDY_LOAM", data)
    out = tmp_path / "out"
    assert main(["diagnose", str(data), "--model", "husky_a200", "--out", str(out),
                 "--no-progress", *option]) == 2
    err = capsys.readouterr().err
    assert " ".join(option) in err and str(data) in err and "real recordings" in err
    assert not out.exists()
