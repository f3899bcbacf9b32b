"""Any skid-steer robot: a model folder or an MJCF file, no Python edit (issue 17).

A minimal four-wheel robot written here (its own geometry, masses and names; one
velocity servo per wheel instead of one per side; no skidsteer text in it) is
swivelled, turned into a dataset and compared, as a user's own robot would be.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest

from skidsteer.data import read_dataset
from skidsteer.diagnosis.synth import make_dataset
from skidsteer.reports.diagnosis import compare
from skidsteer.robot import Setup, load_model, load_robot, models_dir, roles_of
from skidsteer.simulation import DriveGeometry, run_commanded

WHEELS = {"fl": (0.2, 0.25), "fr": (0.2, -0.25), "rl": (-0.2, 0.25), "rr": (-0.2, -0.25)}
RADIUS = 0.12


def mini_robot_xml() -> str:
    wheels = "\n".join(f"""
      <body name="{name}_hub" pos="{x} {y} -0.08">
        <joint name="{name}_axle" type="hinge" axis="0 1 0"/>
        <geom name="{name}_tread" type="cylinder" size="{RADIUS} 0.04" zaxis="0 1 0" mass="0.5"
              contype="0" conaffinity="0"/>
        <plugin instance="treads"/>
      </body>""" for name, (x, y) in WHEELS.items())
    servos = "\n".join(f'<velocity name="{n}_servo" joint="{n}_axle" kv="40" '
                       'ctrlrange="-10 10"/>' for n in WHEELS)
    return f"""<mujoco model="mini">
  <option timestep="0.0001" integrator="implicitfast"/>
  <extension>
    <plugin plugin="skidsteer.tire">
      <instance name="treads">
        <config key="mu_static" value="0.7"/>
        <config key="mu_kinetic" value="0.6"/>
      </instance>
    </plugin>
  </extension>
  <worldbody>
    <geom name="ground" type="plane" size="0 0 0.05"/>
    <body name="hull" pos="0 0 {RADIUS + 0.08 + 0.0}">
      <freejoint/>
      <geom type="box" size="0.3 0.2 0.06" mass="12"/>
      <site name="imu" pos="0.1 0 0.05"/>{wheels}
    </body>
  </worldbody>
  <actuator>{servos}</actuator>
  <sensor>
    <accelerometer name="imu_acc" site="imu"/>
    <gyro name="imu_gyro" site="imu"/>
  </sensor>
</mujoco>
"""


@pytest.fixture(scope="module")
def mini(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("robot") / "mini.xml"
    path.write_text(mini_robot_xml())
    return path


def test_a_robot_file_is_read_for_its_wheels_drive_and_sensors(mini):
    m = load_model(Setup(robot=str(mini)))
    r = roles_of(m)
    names = lambda ids, obj: [mujoco.mj_id2name(m, obj, i) for i in ids]  # noqa: E731
    assert names(r.left, mujoco.mjtObj.mjOBJ_ACTUATOR) == ["fl_servo", "rl_servo"]
    assert names(r.right, mujoco.mjtObj.mjOBJ_ACTUATOR) == ["fr_servo", "rr_servo"]
    assert m.sensor(r.accelerometer).name == "imu_acc" and m.sensor(r.gyro).name == "imu_gyro"
    assert m.body(r.chassis).name == "hull"
    drive = DriveGeometry.from_model(m)
    assert drive.wheel_radius == pytest.approx(RADIUS) and drive.half_track == pytest.approx(0.25)
    # a single MJCF file is a robot with one build and the tire plugin's own floors
    robot = load_robot(str(mini))
    assert robot.single_file == mini.resolve() and "carpet" in robot.floors


def test_the_robot_swivels_the_commanded_way(mini):
    m = load_model(Setup(robot=str(mini), floor="concrete"))
    run = run_commanded(m, 0.0, 30.0, 3.0, settle_s=0.5)
    assert np.isfinite(run.accel).all()
    assert 3.0 < run.mean_yaw_rate_deg_s() < 30.0  # turns left, slower than commanded
    assert run.tire_forces.shape[1] == 4  # the tire forces sensor is found, or NaN
    assert run.wheel_speed.shape == (len(run.time_s), 4)
    # left wheels backwards, right wheels forwards: the swivel's feed-forward
    steady = run.wheel_speed[-1000:].mean(axis=0)
    assert steady[0] < 0 < steady[1] and steady[2] < 0 < steady[3]


@pytest.mark.slow
def test_compare_runs_on_data_simulated_from_the_robot(mini, tmp_path):
    setup = Setup(robot=str(mini), floor="concrete")
    # 3 trials: the trials' spread needs 3 degrees of freedom (MIN_SPREAD_DOF)
    make_dataset(tmp_path / "data", None, seed=1, omegas=(20.0, 40.0), trials=3,
                 duration_s=7.0, setup=setup, file_format="csv")
    dataset = read_dataset(tmp_path / "data", robot=str(mini))
    assert len(dataset.runs) == 6 and not dataset.skipped
    result = compare(tmp_path / "data", tmp_path / "out", model=str(mini), progress=False,
                     figures=False)
    # the model is the truth: no discrepancy beyond the trials' own scatter
    assert result["verdict"] == "no-discrepancy", result
    assert (tmp_path / "out" / "comparison.json").is_file()


def test_a_robot_folder_with_a_description_is_a_robot(mini, tmp_path):
    folder = tmp_path / "minibot"
    folder.mkdir()
    shutil.copy(mini, folder / "mini.xml")
    (folder / "robot.toml").write_text(
        'name = "minibot"\ndefault_build = "base"\ndefault_floor = "lino"\n'
        '[builds.base]\nfile = "mini.xml"\n'
        '[floors.lino]\nmu_static = 0.5\nmu_kinetic = 0.45\nsource = "assumed: a test floor"\n')
    robot = load_robot(str(folder))
    assert robot.name == "minibot" and robot.default_floor == "lino"
    m = load_model(Setup(robot=str(folder), floor="lino"))
    assert m.nu == 4
    with pytest.raises(ValueError, match="unknown floor 'carpet'"):
        load_model(Setup(robot=str(folder), floor="carpet"))


def test_the_shipped_robots_have_a_description():
    assert (models_dir() / "pioneer3at" / "robot.toml").is_file()
    robot = load_robot("pioneer3at")
    assert list(robot.builds) == ["extended", "platform"] and robot.default_floor == "concrete"
