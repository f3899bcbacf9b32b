"""Real recordings: the IMU readers (BorealTC layout, ROS bags, MCAP), what they do with
messy input, and the replay of a run's own wheel speeds (their diagnosis:
test_real_diagnosis.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin, Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from skidsteer.data import DataError
from skidsteer.data.imu import ImuRun, WheelSpeeds, read_bag, read_borealtc_run, read_imu_folder
from skidsteer.experiments.replay import replay
from skidsteer.features.segments import kind_of, run_segments, run_yaw_features
from skidsteer.robot import Setup, load_model

EXCERPT = Path(__file__).parent / "data" / "borealtc"
TRACK_M = 0.5708  # the Husky's (URDF)


def test_the_excerpt_reads_as_the_recording_it_is():
    data = read_imu_folder(EXCERPT / "FLOORING", track_m=TRACK_M)
    assert not data.skipped and [r.path.name for r in data.runs] == ["imu_01.csv", "imu_08.csv"]
    run = data.runs[1]
    assert run.sample_rate_hz == pytest.approx(100.0) and run.nyquist_hz == pytest.approx(50.0)
    # gravity in, robot axes: z up
    assert np.median(run.accel[:, 2]) == pytest.approx(9.81, abs=0.2)
    # the two files' clocks differ; the reader found the lag by the yaw rates and says so
    assert any("wheel clock shifted" in n for n in run.notes), run.notes
    kinds = {s.kind for s in run_segments(run)}
    assert kinds and kinds <= {"arc", "turn_in_place", "straight", "stop"}


def _imu_csv(path: Path, rows: list[str]) -> None:
    path.write_text("time,wx,wy,wz,ax,ay,az\n" + "\n".join(rows) + "\n")


def _rows(n=200, dt=0.01, start=0):
    return [f"{(i + start) * dt:.4f},0,0,0.1,0,0,9.81" for i in range(n)]


@pytest.mark.parametrize("edit, message", [
    (lambda rows: ["time,wx,wy,wz,ax,ay"] + rows[1:], "missing column(s) ['az']"),
    (lambda rows: rows[:5] + ["0.05,0,0,abc,0,0,9.81"] + rows[6:], "row 6, column 'wz'"),
    (lambda rows: rows[:50] + ["0.2,0,0,0,0,0,9.81"] + rows[51:], "row 51: time 0.2 s goes back"),
    (lambda rows: rows[:100] + rows[120:], "a gap of 0.21 s"),
    (lambda rows: [r.replace(",9.81", ",1.0") for r in rows], "not about 9.81 m/s^2"),
])
def test_a_malformed_imu_file_is_refused_naming_its_place(tmp_path, edit, message):
    rows = ["time,wx,wy,wz,ax,ay,az"] + _rows()
    path = tmp_path / "imu_00.csv"
    path.write_text("\n".join(edit(rows)) + "\n")
    with pytest.raises(DataError) as err:
        read_borealtc_run(path)
    assert str(path) in str(err.value) and message in str(err.value), str(err.value)


def test_duplicate_stamps_are_dropped_and_a_bad_run_does_not_sink_the_folder(tmp_path):
    rows = _rows()
    _imu_csv(tmp_path / "imu_00.csv", rows[:100] + [rows[99]] + rows[100:])
    (tmp_path / "pro_00.csv").write_text("time,curL,curR,velL,velR\n0,1,1,-0.1,0.1\n"
                                         "1,1,1,-0.1,0.1\n")
    _imu_csv(tmp_path / "imu_01.csv", ["0,0,0,0,0,0"])  # one short row
    (tmp_path / "pro_02.csv").write_text("time,curL,curR,velL,velR\n0,1,1,0,0\n")
    data = read_imu_folder(tmp_path)
    assert [r.path.name for r in data.runs] == ["imu_00.csv"]
    run = data.runs[0]
    assert len(run.time_s) == 200 and any("1 duplicate time stamp" in n for n in run.notes)
    reasons = {Path(s["file"]).name: s["reason"] for s in data.skipped}
    assert "imu_01.csv" in reasons and "row 2" in reasons["imu_01.csv"]
    assert "pro_02.csv" in reasons and "no IMU file imu_02.csv" in reasons["pro_02.csv"]


def _write_bag(path: Path, kind: str, typestore, imu_topics=("/imu/data",), wheel="joints"):
    Imu = typestore.types["sensor_msgs/msg/Imu"]
    Header = typestore.types["std_msgs/msg/Header"]
    Time = typestore.types["builtin_interfaces/msg/Time"]
    Vector3 = typestore.types["geometry_msgs/msg/Vector3"]
    Quaternion = typestore.types["geometry_msgs/msg/Quaternion"]
    JointState = typestore.types["sensor_msgs/msg/JointState"]
    Odometry = typestore.types["nav_msgs/msg/Odometry"]
    ros1 = kind == "ros1"
    writer = (Writer1(path) if ros1 else
              Writer2(path, version=9, storage_plugin=(StoragePlugin.MCAP if kind == "mcap"
                                                       else StoragePlugin.SQLITE3)))
    serialize = typestore.serialize_ros1 if ros1 else typestore.serialize_cdr
    cov = np.zeros(9)
    with writer:
        imu_conns = [writer.add_connection(t, Imu.__msgtype__, typestore=typestore)
                     for t in imu_topics]
        wheel_conn = None
        if wheel == "joints":
            wheel_conn = writer.add_connection("/joint_states", JointState.__msgtype__,
                                               typestore=typestore)
        elif wheel == "odometry":
            wheel_conn = writer.add_connection("/odom", Odometry.__msgtype__,
                                               typestore=typestore)
        for i in range(300):  # 3 s at 100 Hz, stamps from 1000 s
            t_ns = 1_000_000_000_000 + i * 10_000_000
            stamp = Time(sec=t_ns // 10**9, nanosec=t_ns % 10**9)
            header = Header(stamp=stamp, frame_id="imu") if not ros1 else \
                Header(seq=i, stamp=stamp, frame_id="imu")
            msg = Imu(header=header, orientation=Quaternion(x=0, y=0, z=0, w=1),
                      orientation_covariance=cov,
                      angular_velocity=Vector3(x=0.0, y=0.0, z=0.2 + 0.001 * i),
                      angular_velocity_covariance=cov,
                      linear_acceleration=Vector3(x=0.1, y=0.0, z=9.81),
                      linear_acceleration_covariance=cov)
            for conn in imu_conns:
                writer.write(conn, t_ns, serialize(msg, Imu.__msgtype__))
            if wheel_conn is not None and i % 10 == 0:
                if wheel == "joints":
                    js = JointState(header=header, name=["front_left_wheel", "rear_left_wheel",
                                                         "front_right_wheel",
                                                         "rear_right_wheel"],
                                    position=np.zeros(4), velocity=np.array([-1.0, -1.0, 1.0, 1.0]),
                                    effort=np.zeros(4))
                    writer.write(wheel_conn, t_ns, serialize(js, JointState.__msgtype__))
                else:
                    Pose = typestore.types["geometry_msgs/msg/PoseWithCovariance"]
                    Twist = typestore.types["geometry_msgs/msg/TwistWithCovariance"]
                    PoseM = typestore.types["geometry_msgs/msg/Pose"]
                    TwistM = typestore.types["geometry_msgs/msg/Twist"]
                    Point = typestore.types["geometry_msgs/msg/Point"]
                    odom = Odometry(header=header, child_frame_id="base",
                                    pose=Pose(pose=PoseM(position=Point(x=0, y=0, z=0),
                                                         orientation=Quaternion(x=0, y=0, z=0,
                                                                                w=1)),
                                              covariance=np.zeros(36)),
                                    twist=Twist(twist=TwistM(linear=Vector3(x=0.0, y=0, z=0),
                                                             angular=Vector3(x=0, y=0, z=0.5)),
                                                covariance=np.zeros(36)))
                    writer.write(wheel_conn, t_ns, serialize(odom, Odometry.__msgtype__))


@pytest.mark.parametrize("kind, suffix", [("ros1", ".bag"), ("ros2", ""), ("mcap", "")])
def test_a_bag_reads_as_the_imu_and_wheel_messages_it_holds(tmp_path, kind, suffix):
    store = get_typestore(Stores.ROS1_NOETIC if kind == "ros1" else Stores.ROS2_HUMBLE)
    path = tmp_path / f"run{suffix}"
    _write_bag(path, kind, store)
    run = read_bag(path, wheel_radius_m=0.1651)
    assert len(run.time_s) == 300 and run.sample_rate_hz == pytest.approx(100.0)
    assert run.time_s[0] == 0.0  # the first stamp is the run's zero
    np.testing.assert_allclose(run.gyro[:, 2], 0.2 + 0.001 * np.arange(300), atol=1e-12)
    np.testing.assert_allclose(run.accel[:, 0], 0.1)
    assert run.wheels is not None and len(run.wheels.time_s) == 30
    np.testing.assert_allclose(run.wheels.left_mps, -0.1651)
    np.testing.assert_allclose(run.wheels.right_mps, 0.1651)


def test_a_bag_names_what_it_cannot_decide(tmp_path):
    store = get_typestore(Stores.ROS2_HUMBLE)
    two = tmp_path / "two"
    _write_bag(two, "ros2", store, imu_topics=("/imu/a", "/imu/b"))
    with pytest.raises(DataError, match=r"2 IMU topics \(\['/imu/a', '/imu/b'\]\); name one"):
        read_bag(two, wheel_radius_m=0.1651)
    assert len(read_bag(two, imu_topic="/imu/b", wheel_radius_m=0.1651).time_s) == 300
    with pytest.raises(DataError, match="JointState wheel velocities are rad/s; give the wheel"):
        read_bag(two, imu_topic="/imu/a")
    with pytest.raises(DataError, match="no topic '/imu/c'"):
        read_bag(two, imu_topic="/imu/c")
    odom = tmp_path / "odom"
    _write_bag(odom, "ros2", store, wheel="odometry")
    with pytest.raises(DataError, match="give the track"):
        read_bag(odom)
    run = read_bag(odom, odometry_track_m=0.5)
    np.testing.assert_allclose(run.wheels.right_mps - run.wheels.left_mps, 0.5 * 0.5)
    with pytest.raises(DataError, match="not a readable ROS bag"):
        (tmp_path / "junk.bag").write_bytes(b"not a bag")
        read_bag(tmp_path / "junk.bag")


def test_segment_kinds_follow_the_wheel_command():
    assert kind_of(-0.1, 0.1) == "turn_in_place"
    assert kind_of(0.3, 0.3) == "straight"
    assert kind_of(0.2, 0.4) == "arc"
    assert kind_of(0.005, -0.01) == "stop"


def _husky(floor="flooring", edit=None):
    return load_model(Setup(robot="husky_a200", build="base", floor=floor), edit=edit)


def test_replay_drives_the_model_by_the_runs_own_wheel_speeds():
    # a turn in place of 6 s at +-0.1 m/s rim speed: the replayed gyro's yaw rate equals
    # the same model's constant swivel; its chi is the model's (wheel-predicted / measured)
    t = np.arange(0, 6, 0.01)
    wheels = WheelSpeeds(np.array([0.0]), np.array([-0.1]), np.array([0.1]))
    run = ImuRun(Path("imu_00.csv"), t, np.tile([0, 0, 9.81], (len(t), 1)),
                 np.zeros((len(t), 3)), wheels)
    sim = replay(_husky(), run)
    assert sim.time_s.shape == t.shape and sim.sample_rate_hz == pytest.approx(100.0)
    (seg,) = run_segments(sim)
    assert seg.kind == "turn_in_place"
    feats = run_yaw_features(seg, sim, TRACK_M)
    assert feats["yaw_rate_predicted_deg_s"] == pytest.approx(np.rad2deg(0.2 / TRACK_M))
    # the skid-steer turns slower than its wheels' geometry says: chi > 1
    assert feats["chi"] > 1.2


def test_replay_applies_the_models_rim_speed_per_logged_speed():
    # a model stating that its rims turn 1.5 times the logged wheel speed turns as the
    # plain model does at 1.5 times the command (a turn in place: chi per logged speed
    # falls by 1.5)
    t = np.arange(0, 6, 0.01)
    wheels = WheelSpeeds(np.array([0.0]), np.array([-0.1]), np.array([0.1]))
    fast = WheelSpeeds(np.array([0.0]), np.array([-0.15]), np.array([0.15]))
    run = ImuRun(Path("imu_00.csv"), t, np.tile([0, 0, 9.81], (len(t), 1)),
                 np.zeros((len(t), 3)), wheels)
    from skidsteer.robot import roles
    scaled = _husky(edit=lambda spec: roles.set_spec_numeric(
        spec, "drive.logged_speed_scale", 1.5))
    a = replay(scaled, run)
    b = replay(_husky(), ImuRun(run.path, t, run.accel, run.gyro, fast))
    np.testing.assert_allclose(a.gyro[:, 2], b.gyro[:, 2], rtol=1e-9, atol=1e-12)
