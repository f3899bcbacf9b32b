"""IMU runs: accelerometer and gyro at any uniform rate, with the wheel speeds of the
run when it has them (docs/data-format.md, "IMU runs").

A robot logged the way people log robots: an IMU (specific force in m/s^2 with
gravity in, angular rate in rad/s, robot axes), usually at 100-1000 Hz, and the
speeds of the left and right wheels, usually slower and on another clock.  Two
layouts are read:

- the BorealTC layout (LaRocque et al., IROS 2024): ``imu_NN.csv``
  (``time,wx,wy,wz,ax,ay,az``) and ``pro_NN.csv`` (``time,curL,curR,velL,velR``,
  wheel speeds as linear speeds in m/s), one pair per run, ``time`` in s from the
  start of each file (:func:`read_borealtc_run`, :func:`read_imu_folder`);
- ROS 1 bags, ROS 2 bags and MCAP through the ``rosbags`` library
  (:func:`read_bag`): ``sensor_msgs/Imu`` on one topic; wheel speeds from
  ``sensor_msgs/JointState`` (joint velocities, rad/s, times the wheel radius) or
  ``nav_msgs/Odometry`` (twist, with the track the odometry assumes).

Every problem raises :class:`DataError` naming the file and the row, column or
topic.  What a reader finds and repairs (duplicate time stamps, a clock offset
between the two files) it says in the run's ``notes``; a folder's bad run is
listed in ``skipped`` and never sinks the rest.
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Sequence

import numpy as np
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from skidsteer.data.files import write_text
from skidsteer.data.recording import DataError, _number, read_utf8

GRAVITY_M_S2 = 9.81
# the median |specific force| of a recording is about 1 g however the IMU is turned
# (recording.py, GRAVITY_BAND): outside 0.5-1.5 g the file is in other units
GRAVITY_BAND = (0.5, 1.5)
UNIFORM_RTOL = 0.01  # a sample step within 1 % of the median step is "uniform"
MAX_GAP_STEPS = 3.0  # a gap of more than 3 median steps in the IMU is not a uniform record
MIN_IMU_SAMPLES = 64  # shorter than ~1 s at 64 Hz is not a run
# Clock alignment of the wheel file to the IMU (BorealTC: the two files' clocks differ
# by up to ~1.5 s, found by cross-correlation; docs/real-data/borealtc.md): the lag is
# searched within +-MAX_CLOCK_LAG_S and applied only when the yaw rate the wheels
# predict correlates with the gyro's at least ALIGN_MIN_CORRELATION at it, on a
# record whose wheel signal varies (a constant command has no lag to find).
MAX_CLOCK_LAG_S = 3.0
ALIGN_MIN_CORRELATION = 0.8
ALIGN_WINDOW_S = 40.0
IMU_COLUMNS = ("time", "wx", "wy", "wz", "ax", "ay", "az")
WHEEL_COLUMNS = ("time", "curL", "curR", "velL", "velR")


@dataclass(frozen=True, eq=False)
class WheelSpeeds:
    """The speeds of the left and right wheels, m/s at the rim (rad/s times the
    radius), on the IMU's clock; optional motor currents (A)."""

    time_s: np.ndarray  # (m,)
    left_mps: np.ndarray  # (m,)
    right_mps: np.ndarray  # (m,)
    current_a: np.ndarray | None = None  # (m, 2): left, right

    def at(self, t) -> tuple[np.ndarray, np.ndarray]:
        """(left, right) at times t (s), held from each sample to the next (the
        schedule a logger or a controller holds between messages)."""
        i = self._held(t)
        return self.left_mps[i], self.right_mps[i]

    def current_at(self, t) -> np.ndarray | None:
        """(len(t), 2) motor currents at times t, held as the speeds are; None without."""
        return None if self.current_a is None else self.current_a[self._held(t)]

    def _held(self, t) -> np.ndarray:
        return np.clip(np.searchsorted(self.time_s, np.asarray(t, float), side="right") - 1,
                       0, len(self.time_s) - 1)


@dataclass(frozen=True, eq=False)
class ImuRun:
    """One run: time (n,) s, specific force (n, 3) m/s^2 (gravity in) and angular rate
    (n, 3) rad/s in the robot's axes (x forward, y left, z up), the wheel speeds if
    recorded, the accelerometer's range (m/s^2) if known, and what the reader found."""

    path: Path
    time_s: np.ndarray
    accel: np.ndarray
    gyro: np.ndarray
    wheels: WheelSpeeds | None = None
    accel_range_m_s2: float | None = None
    terrain: str | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def sample_rate_hz(self) -> float:
        return (len(self.time_s) - 1) / float(self.time_s[-1] - self.time_s[0])

    @property
    def nyquist_hz(self) -> float:
        return self.sample_rate_hz / 2

    @property
    def duration_s(self) -> float:
        return float(self.time_s[-1] - self.time_s[0])

    def saturated(self) -> np.ndarray:
        """(n,) True where an accelerometer axis sits at its range (unknown range:
        none)."""
        if self.accel_range_m_s2 is None:
            return np.zeros(len(self.time_s), bool)
        return np.any(np.abs(self.accel) >= 0.999 * self.accel_range_m_s2, axis=1)


@dataclass
class ImuDataset:
    """The usable runs of a folder and, with the reason, every file that is not."""

    root: Path
    runs: list[ImuRun] = field(default_factory=list)
    skipped: list[dict] = field(default_factory=list)


# --------------------------------------------------------------------------- CSV

def _read_table(path: Path, columns: Sequence[str]) -> dict[str, np.ndarray]:
    """A CSV with a header naming at least `columns` (other columns ignored), every
    cell a finite number; raises DataError naming the file, row and column."""
    if not path.is_file():
        raise DataError(f"{path}: file not found")
    rows = list(csv.reader(io.StringIO(read_utf8(path), newline="")))
    if not rows or not any(c.strip() for c in rows[0]):
        raise DataError(f"{path}: empty file")
    header = [c.strip() for c in rows[0]]
    missing = [c for c in columns if c not in header]
    if missing:
        raise DataError(f"{path}: row 1: missing column(s) {missing} (header {header}; "
                        f"expected {list(columns)})")
    index = {c: header.index(c) for c in columns}
    data = {c: np.empty(len(rows) - 1) for c in columns}
    n = 0
    for line, row in enumerate(rows[1:], start=2):
        if not row or not any(c.strip() for c in row):
            continue  # blank line
        for c, j in index.items():
            if j >= len(row):
                raise DataError(f"{path}: row {line}: no value in column {c!r}")
            data[c][n] = _number(row[j].strip(), f"{path}: row {line}, column {c!r}", text=True)
        n += 1
    if n == 0:
        raise DataError(f"{path}: no data rows")
    return {c: v[:n] for c, v in data.items()}


def _clean_time(path: Path, t: np.ndarray, what: str) -> tuple[np.ndarray, list[str]]:
    """Indices of the samples to keep and notes: exact duplicate time stamps are dropped
    (the first kept); a time that goes backwards is an error naming its row."""
    notes = []
    dt = np.diff(t)
    back = np.flatnonzero(dt < 0)
    if len(back):
        row = back[0] + 3  # header is row 1, sample i is row i + 2, the later one
        raise DataError(f"{path}: row {row}: time {t[back[0] + 1]:g} s goes back from "
                        f"{t[back[0]]:g} s ({len(back)} such place(s)); {what} needs one "
                        "increasing clock")
    keep = np.concatenate([[True], dt > 0])
    if not keep.all():
        notes.append(f"{path.name}: {int((~keep).sum())} duplicate time stamp(s) dropped")
    return np.flatnonzero(keep), notes


def _check_imu(path: Path, t: np.ndarray, accel: np.ndarray) -> list[str]:
    notes = []
    if len(t) < MIN_IMU_SAMPLES:
        raise DataError(f"{path}: {len(t)} samples; an IMU run needs at least {MIN_IMU_SAMPLES}")
    dt = np.diff(t)
    step = float(np.median(dt))
    gaps = np.flatnonzero(dt > MAX_GAP_STEPS * step)
    if len(gaps):
        i = gaps[0]
        raise DataError(f"{path}: row {i + 3}: a gap of {dt[i]:.3g} s after {t[i]:g} s "
                        f"({dt[i] / step:.1f} sample steps of {step:.3g} s; {len(gaps)} such "
                        "gap(s)): not a uniform record; split the file at the gaps")
    off = np.abs(dt - step) > UNIFORM_RTOL * step
    if off.any():
        notes.append(f"{path.name}: {int(off.sum())} sample step(s) differ from the median "
                     f"{step * 1e3:.3g} ms by more than {UNIFORM_RTOL:.0%}; resampled onto a "
                     "uniform clock")
    g = float(np.median(np.linalg.norm(accel, axis=1)))
    lo, hi = GRAVITY_BAND
    if not lo * GRAVITY_M_S2 <= g <= hi * GRAVITY_M_S2:
        raise DataError(f"{path}: the median |specific force| is {g:.4g}, not about "
                        f"{GRAVITY_M_S2} m/s^2: the accelerometer columns are not m/s^2 with "
                        "gravity in (g units? gravity removed?)")
    return notes


def _uniform(t: np.ndarray, *columns: np.ndarray):
    """The columns linearly interpolated onto a uniform clock from t[0] at the median
    step (identity when the record is already uniform)."""
    step = float(np.median(np.diff(t)))
    n = int(round((t[-1] - t[0]) / step)) + 1
    tu = t[0] + step * np.arange(n)
    if len(tu) == len(t) and np.allclose(tu, t, rtol=0, atol=UNIFORM_RTOL * step):
        return (t,) + columns
    return (tu,) + tuple(np.stack([np.interp(tu, t, c[:, j]) for j in range(c.shape[1])],
                                  axis=1) for c in columns)


def read_borealtc_run(imu_path, wheel_path=None, terrain: str | None = None,
                      track_m: float | None = None) -> ImuRun:
    """One BorealTC run: ``imu_NN.csv`` and its ``pro_NN.csv`` (default: beside it).

    A missing wheel file leaves ``wheels`` None (noted).  With track_m (the robot's
    track, m) the wheel file's clock is aligned to the IMU's by the lag that best
    correlates the yaw rate the wheels predict with the gyro's (see ALIGN_*)."""
    imu_path = Path(imu_path)
    cols = _read_table(imu_path, IMU_COLUMNS)
    keep, notes = _clean_time(imu_path, cols["time"], "an IMU run")
    t = cols["time"][keep]
    accel = np.stack([cols[c][keep] for c in ("ax", "ay", "az")], axis=1)
    gyro = np.stack([cols[c][keep] for c in ("wx", "wy", "wz")], axis=1)
    notes += _check_imu(imu_path, t, accel)
    t, accel, gyro = _uniform(t, accel, gyro)
    if wheel_path is None:
        wheel_path = imu_path.with_name(re.sub(r"^imu", "pro", imu_path.name))
    wheel_path = Path(wheel_path)
    wheels = None
    if wheel_path.is_file():
        w = _read_table(wheel_path, WHEEL_COLUMNS)
        wkeep, wnotes = _clean_time(wheel_path, w["time"], "a wheel-speed record")
        notes += wnotes
        wheels = WheelSpeeds(w["time"][wkeep], w["velL"][wkeep], w["velR"][wkeep],
                             np.stack([w["curL"][wkeep], w["curR"][wkeep]], axis=1))
    else:
        notes.append(f"{imu_path.name}: no wheel-speed file {wheel_path.name}")
    run = ImuRun(imu_path, t, accel, gyro, wheels, terrain=terrain, notes=tuple(notes))
    if wheels is not None and track_m is not None:
        run = align_clocks(run, track_m)
    return run


def read_imu_folder(folder, track_m: float | None = None) -> ImuDataset:
    """Every run of a folder in the BorealTC layout (``imu_NN.csv`` with
    ``pro_NN.csv``); the folder's name is the runs' terrain.  A run that cannot be
    read is in ``skipped`` with the reason; a wheel file without its IMU file too."""
    root = Path(folder)
    if not root.is_dir():
        raise DataError(f"{root}: not a directory")
    data = ImuDataset(root)
    imus = sorted(root.glob("imu_*.csv"))
    if not imus:
        raise DataError(f"{root}: no imu_NN.csv files (the BorealTC layout: imu_NN.csv with "
                        "pro_NN.csv)")
    for path in imus:
        try:
            data.runs.append(read_borealtc_run(path, terrain=root.name, track_m=track_m))
        except DataError as err:
            data.skipped.append({"file": str(path), "reason": str(err)})
    names = {p.name for p in imus}
    for path in sorted(root.glob("pro_*.csv")):
        if re.sub(r"^pro", "imu", path.name) not in names:
            data.skipped.append({"file": str(path), "reason": f"{path}: no IMU file "
                                 f"{re.sub(r'^pro', 'imu', path.name)} for these wheel speeds"})
    return data


def write_borealtc_run(folder, number: int, run: ImuRun) -> tuple[Path, Path]:
    """Writes a run in the BorealTC layout (imu_NN.csv, pro_NN.csv; currents 0 when
    the run has none), atomically; what the hidden-effect tests and generators write."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    imu = io.StringIO()
    imu.write(",".join(IMU_COLUMNS) + "\n")
    for row in np.column_stack([run.time_s, run.gyro, run.accel]).tolist():
        imu.write(",".join(map(repr, row)) + "\n")  # repr of a float: exact round trip
    paths = folder / f"imu_{number:02d}.csv", folder / f"pro_{number:02d}.csv"
    write_text(paths[0], imu.getvalue())
    if run.wheels is not None:
        w = run.wheels
        current = w.current_a if w.current_a is not None else np.zeros((len(w.time_s), 2))
        pro = io.StringIO()
        pro.write(",".join(WHEEL_COLUMNS) + "\n")
        for row in np.column_stack([w.time_s, current, w.left_mps, w.right_mps]).tolist():
            pro.write(",".join(map(repr, row)) + "\n")
        write_text(paths[1], pro.getvalue())
    return paths


# --------------------------------------------------------------------------- clocks

def predicted_yaw_rate(wheels: WheelSpeeds, track_m: float) -> np.ndarray:
    """(right - left) / track, rad/s: the yaw rate of wheels that do not slip."""
    return (wheels.right_mps - wheels.left_mps) / track_m


def clock_lag(run: ImuRun, track_m: float, span: tuple[float, float] | None = None
              ) -> tuple[float, float] | None:
    """(lag_s, correlation): the shift of the wheel clock that best correlates the
    wheel-predicted yaw rate with the gyro's z over span (IMU seconds; default the
    whole overlap); positive: the wheel file's events appear later than the IMU's.
    None when the wheel signal does not vary there."""
    w = run.wheels
    if w is None or len(w.time_s) < 8:
        return None
    pred = predicted_yaw_rate(w, track_m)
    step = 1.0 / run.sample_rate_hz
    lo, hi = max(run.time_s[0], w.time_s[0]), min(run.time_s[-1], w.time_s[-1])
    if span is not None:
        lo, hi = max(lo, span[0]), min(hi, span[1])
    grid = np.arange(lo, hi, step)
    if len(grid) < 16:
        return None
    gz = np.interp(grid, run.time_s, run.gyro[:, 2])
    best = (0.0, -np.inf)
    for lag in np.arange(-MAX_CLOCK_LAG_S, MAX_CLOCK_LAG_S + step / 2, step):
        p = np.interp(grid + lag, w.time_s, pred)  # the wheel sample at wheel time t + lag
        if np.std(p) == 0 or np.std(gz) == 0:
            continue
        c = float(np.corrcoef(p, gz)[0, 1])
        if c > best[1]:
            best = (float(lag), c)
    return best if np.isfinite(best[1]) else None


def align_clocks(run: ImuRun, track_m: float) -> ImuRun:
    """The run with its wheel clock mapped onto the IMU's; noted either way.

    The two files of a BorealTC run drift apart by up to ~2 s over a long run
    (their time columns are sample counts times a nominal rate): the lag is found
    in windows of ALIGN_WINDOW_S (half overlapping) and, where at least two windows
    correlate at least ALIGN_MIN_CORRELATION, interpolated between their centres
    (held beyond); with one such window, or only the whole record, it is one
    constant; below the correlation nothing is shifted (the robot does not follow
    its wheels: deformable ground, a stuck robot)."""
    w = run.wheels
    windows = []
    t_lo, t_hi = float(run.time_s[0]), float(run.time_s[-1])
    start = t_lo
    while start + ALIGN_WINDOW_S / 2 <= t_hi:
        found = clock_lag(run, track_m, (start, start + ALIGN_WINDOW_S))
        if found is not None and found[1] >= ALIGN_MIN_CORRELATION:
            windows.append((min(start + ALIGN_WINDOW_S / 2, (start + t_hi) / 2), *found))
        start += ALIGN_WINDOW_S / 2
    if len(windows) < 2:
        found = clock_lag(run, track_m)
        if found is None:
            return replace(run, notes=run.notes + (
                f"{run.path.name}: wheel and IMU clocks taken as one (the wheel speeds do "
                "not vary: no lag to find)",))
        if found[1] < ALIGN_MIN_CORRELATION:
            return replace(run, notes=run.notes + (
                f"{run.path.name}: wheel and IMU clocks taken as one (best lag "
                f"{found[0]:+.2f} s correlates only {found[1]:.2f} < "
                f"{ALIGN_MIN_CORRELATION}: the robot does not follow its wheels, e.g. "
                "deformable ground or a stuck robot)",))
        windows = [(0.0, *found)]
    centres = np.array([c for c, _, _ in windows])
    lags = np.array([lag for _, lag, _ in windows])
    lag_at = np.interp(w.time_s, centres, lags)  # held beyond the first and last window
    mapped = w.time_s - lag_at
    if np.any(np.diff(mapped) <= 0):  # a lag changing faster than time: keep one lag
        lags = np.full_like(lags, np.median(lags))
        mapped = w.time_s - lags[0]
    shifted = WheelSpeeds(mapped, w.left_mps, w.right_mps, w.current_a)
    corr = min(c for _, _, c in windows)
    how = (f"shifted by {-lags[0]:+.2f} s" if np.ptp(lags) == 0 else
           f"shifted by {-lags.max():+.2f} to {-lags.min():+.2f} s over {len(lags)} windows "
           f"of {ALIGN_WINDOW_S:g} s")
    return replace(run, wheels=shifted, notes=run.notes + (
        f"{run.path.name}: wheel clock {how} onto the IMU's (yaw-rate correlation >= "
        f"{corr:.2f})",))


# --------------------------------------------------------------------------- bags

def read_bag(path, imu_topic: str | None = None, wheel_topic: str | None = None,
             wheel_radius_m: float | None = None, left_joints: Sequence[str] = ("left",),
             right_joints: Sequence[str] = ("right",), odometry_track_m: float | None = None,
             accel_range_m_s2: float | None = None, terrain: str | None = None) -> ImuRun:
    """An IMU run from a ROS 1 bag, a ROS 2 bag folder or an MCAP file (rosbags).

    imu_topic: the ``sensor_msgs/Imu`` topic (default: the bag's only one).  Wheel
    speeds (optional) from wheel_topic (default: the only ``JointState`` topic, else
    the only ``Odometry`` topic, else none): a JointState's velocities (rad/s) of the
    joints whose names contain one of left_joints / right_joints, averaged per side,
    times wheel_radius_m; an Odometry's twist as left/right rim speeds
    v -/+ omega * odometry_track_m / 2 (the track the odometry assumed).  Times are
    the messages' header stamps (the bag's receive times when a stamp is zero)."""
    path = Path(path)
    if not path.exists():
        raise DataError(f"{path}: file not found")
    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as err:  # rosbags raises its own error types per format
        raise DataError(f"{path}: not a readable ROS bag or MCAP file ({err})") from None
    try:
        imu_conn = _topic(path, reader, imu_topic, ("sensor_msgs/msg/Imu",), "IMU")
        t, acc, gyr = [], [], []
        for conn, stamp, raw in reader.messages(connections=[imu_conn]):
            msg = reader.deserialize(raw, conn.msgtype)
            t.append(_stamp(msg.header.stamp, stamp))
            a, w = msg.linear_acceleration, msg.angular_velocity
            acc.append((a.x, a.y, a.z))
            gyr.append((w.x, w.y, w.z))
        wheels = None
        kinds = ("sensor_msgs/msg/JointState", "nav_msgs/msg/Odometry")
        wheel_conn = (_topic(path, reader, wheel_topic, kinds, "wheel-speed")
                      if wheel_topic else _only_of(reader, kinds))
        if wheel_conn is not None:
            wheels = _wheels(path, reader, wheel_conn, wheel_radius_m, left_joints,
                             right_joints, odometry_track_m)
    finally:
        reader.close()
    t = np.asarray(t, float)
    accel, gyro = np.asarray(acc, float), np.asarray(gyr, float)
    order = np.argsort(t, kind="stable")
    notes = [] if np.all(order == np.arange(len(t))) else [
        f"{path.name}: IMU messages out of stamp order; sorted"]
    t, accel, gyro = t[order], accel[order], gyro[order]
    keep, more = _clean_time(path, t, "an IMU run")
    notes += more
    t, accel, gyro = t[keep], accel[keep], gyro[keep]
    notes += _check_imu(path, t - t[0], accel)
    t0 = t[0]
    tu, accel, gyro = _uniform(t - t0, accel, gyro)
    if wheels is not None:
        wheels = replace(wheels, time_s=wheels.time_s - t0)
    return ImuRun(path, tu, accel, gyro, wheels, accel_range_m_s2, terrain, tuple(notes))


def _stamp(header_stamp, receive_ns: int) -> float:
    s = header_stamp.sec + header_stamp.nanosec * 1e-9
    return s if s > 0 else receive_ns * 1e-9


def _topic(path, reader, topic, kinds, what):
    conns = [c for c in reader.connections if c.msgtype in kinds]
    if topic is not None:
        chosen = [c for c in reader.connections if c.topic == topic]
        if not chosen:
            raise DataError(f"{path}: no topic {topic!r} (topics: "
                            f"{sorted({c.topic for c in reader.connections})})")
        if chosen[0].msgtype not in kinds:
            raise DataError(f"{path}: topic {topic!r} is {chosen[0].msgtype}, not a {what} "
                            f"message ({', '.join(kinds)})")
        return chosen[0]
    if len({c.topic for c in conns}) != 1:
        raise DataError(f"{path}: {len({c.topic for c in conns})} {what} topics "
                        f"({sorted({c.topic for c in conns})}); name one")
    return conns[0]


def _only_of(reader, kinds):
    for kind in kinds:
        topics = {c.topic: c for c in reader.connections if c.msgtype == kind}
        if len(topics) == 1:
            return next(iter(topics.values()))
    return None


def _wheels(path, reader, conn, radius, left_joints, right_joints, track) -> WheelSpeeds:
    t, left, right = [], [], []
    where = f"{path}: topic {conn.topic!r}"
    joint_state = conn.msgtype == "sensor_msgs/msg/JointState"
    if joint_state and radius is None:
        raise DataError(f"{where}: JointState wheel velocities are rad/s; give the wheel radius")
    if not joint_state and track is None:
        raise DataError(f"{where}: Odometry gives the robot's twist; give the track its "
                        "odometry assumed to turn it into wheel speeds")
    for _, stamp, raw in reader.messages(connections=[conn]):
        msg = reader.deserialize(raw, conn.msgtype)
        t.append(_stamp(msg.header.stamp, stamp))
        if joint_state:
            names, vel = list(msg.name), np.asarray(msg.velocity, float)
            if len(vel) != len(names):
                raise DataError(f"{where}: a message has {len(names)} joint names and "
                                f"{len(vel)} velocities")
            sides = []
            for keys, side in ((left_joints, "left"), (right_joints, "right")):
                idx = [i for i, n in enumerate(names) if any(k in n for k in keys)]
                if not idx:
                    raise DataError(f"{where}: no {side} wheel joint among {names} (names "
                                    f"containing {list(keys)})")
                sides.append(float(np.mean(vel[idx])) * radius)
            left.append(sides[0])
            right.append(sides[1])
        else:
            v, w = msg.twist.twist.linear.x, msg.twist.twist.angular.z
            left.append(v - w * track / 2)
            right.append(v + w * track / 2)
    if not t:
        raise DataError(f"{where}: no messages")
    t = np.asarray(t)
    order = np.argsort(t, kind="stable")
    t = t[order]
    keep = np.concatenate([[True], np.diff(t) > 0])
    return WheelSpeeds(t[keep], np.asarray(left)[order][keep], np.asarray(right)[order][keep])


def is_imu_folder(path) -> bool:
    """Whether a path is something the IMU readers read: a folder of imu_NN.csv files,
    a ROS bag folder (metadata.yaml), a .bag or an .mcap file."""
    p = Path(path)
    if p.is_dir():
        return any(p.glob("imu_*.csv")) or (p / "metadata.yaml").is_file()
    return p.suffix.lower() in (".bag", ".mcap")
