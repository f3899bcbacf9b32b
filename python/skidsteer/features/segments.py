"""Steady segments of a recorded run and their features: yaw rates, vibration.

A real run is not one constant command: the operator turns in place, drives
straight, arcs and stops.  ``segments`` cuts a run wherever the kind of its wheel
command changes or the robot reverses its turn or its travel; every span of at
least MIN_SEGMENT_S is scored like a trial.  ``yaw_features``
gives each segment's yaw rate as the gyro measures it (after the robot has
settled into the command) and as the wheel geometry predicts it, and their
ratio, the effective-track factor chi: 1 for wheels that do not slip, about
1 + (a/c)^2 for a skid-steer robot with isotropic Coulomb friction turning in
place (a: half wheelbase, c: half track).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import signal

from skidsteer.features import signals

MIN_SEGMENT_S = 3.0  # shorter spans are transitions, not trials
SETTLE_S = 1.0  # the first second of a segment is the robot taking up the command
# Kinds, from v = (left + right)/2 and d = (right - left)/2 (m/s): stopped below
# STOP_MPS in both; turning in place while |v| < IN_PLACE_RATIO |d| (the turning
# centre within a fifth of the half track of the robot's centre); straight while
# |d| < STRAIGHT_RATIO |v| (turning radius above 20 half tracks); an arc otherwise.
STOP_MPS = 0.02
IN_PLACE_RATIO = 0.2
STRAIGHT_RATIO = 0.05
KINDS = ("stop", "turn_in_place", "straight", "arc")


@dataclasses.dataclass(frozen=True)
class Segment:
    """A span [start_s, end_s] of a run (the IMU file's clock) whose wheel command is
    of one kind; left_mps, right_mps: the command's means over the span."""

    run: str  # the IMU file name
    start_s: float
    end_s: float
    kind: str
    left_mps: float
    right_mps: float

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


def kind_of(left_mps: float, right_mps: float) -> str:
    v, d = (left_mps + right_mps) / 2, (right_mps - left_mps) / 2
    if max(abs(v), abs(d)) < STOP_MPS:
        return "stop"
    if abs(v) < IN_PLACE_RATIO * abs(d):
        return "turn_in_place"
    if abs(d) < STRAIGHT_RATIO * abs(v):
        return "straight"
    return "arc"


def segments(wheel_time_s, left_mps, right_mps, t_start: float, t_end: float,
             run: str = "", min_duration_s: float = MIN_SEGMENT_S) -> list[Segment]:
    """The spans of a record in which every wheel-speed sample (held until the next) is
    of one kind (and one direction of turn and of travel), lasting at least
    min_duration_s within [t_start, t_end] (the IMU record), in time order.  The
    command may vary inside a span (an operator's joystick): a segment's left_mps,
    right_mps are its means, and yaw_features compares the yaw rates sample by
    sample."""
    w_t = np.asarray(wheel_time_s, float)
    left, right = np.asarray(left_mps, float), np.asarray(right_mps, float)
    kinds = [kind_of(a, b) for a, b in zip(left, right)]
    # a segment also ends where the robot reverses its turn or its travel
    labels = [(k, np.sign(b - a) if k in ("turn_in_place", "arc") else 0,
               np.sign(a + b) if k in ("straight", "arc") else 0)
              for k, a, b in zip(kinds, left, right)]
    out, i, n = [], 0, len(kinds)
    while i < n:
        j = i + 1
        while j < n and labels[j] == labels[i]:
            j += 1
        start = max(float(w_t[i]), t_start)
        end = min(float(w_t[j]) if j < n else t_end, t_end)
        if end - start >= min_duration_s:
            out.append(Segment(run, start, end, kinds[i], float(np.mean(left[i:j])),
                               float(np.mean(right[i:j]))))
        i = j
    return out


def yaw_features(segment: Segment, time_s, gyro_z, left_mps, right_mps,
                 track_m: float) -> dict:
    """The segment's yaw rates (deg/s), means from SETTLE_S after its start to its end:
    measured (gyro_z, rad/s, at time_s), predicted by the wheels ((right - left) /
    track, the wheel speeds at the same samples), and chi = predicted / measured
    (None when the robot hardly turns: |measured| below 0.2 deg/s or 2 % of
    |predicted|)."""
    time_s = np.asarray(time_s, float)
    window = (time_s >= segment.start_s + SETTLE_S) & (time_s <= segment.end_s)
    if not window.any():
        return {"yaw_rate_deg_s": None, "yaw_rate_predicted_deg_s": None, "chi": None}
    measured = float(np.rad2deg(np.mean(np.asarray(gyro_z)[window])))
    difference = np.asarray(right_mps)[window] - np.asarray(left_mps)[window]
    predicted = float(np.rad2deg(np.mean(difference) / track_m))
    turning = abs(measured) >= 0.2 and abs(measured) >= 0.02 * abs(predicted)
    return {"yaw_rate_deg_s": measured, "yaw_rate_predicted_deg_s": predicted,
            "chi": predicted / measured if turning and abs(predicted) > 0 else None}


# ------------------------------------------------------------ vibration of a segment
#
# What real spectra hold (BorealTC's Husky on flooring and asphalt, 0.23-0.78 m/s):
# lines at 17.3 and 34.6 Hz per m/s of rim speed, i.e. at 18 and 36 times the wheels'
# rotation rate (wheel orders: something turning with the wheels), on a broad floor.  A
# line that follows the wheels is seen on an order axis: the PSD read at k times the
# wheel rate, for every order k whose frequency the record can hold.
SPECTRUM_NPERSEG = 512  # 0.2 Hz bins at 100 Hz; shorter segments: one Hann window
MIN_LINE_HZ = 1.0  # below: the robot's manoeuvres and gyro drift, not lines
NYQUIST_SHARE = 0.9  # above 0.9 x Nyquist the logger's anti-alias filter rolls off
BACKGROUND_HZ = 2.0  # a line's background: the PSD's median within 2 Hz beside it
MAX_ORDER = 60  # the highest wheel order examined (36 is the highest line seen)


def band_top_hz(fs: float, top_hz: float = 50.0) -> float:
    """The highest frequency a record at fs can be judged at: top_hz or NYQUIST_SHARE of
    the Nyquist frequency, whichever is lower."""
    return min(top_hz, NYQUIST_SHARE * fs / 2)


def wheel_order_lines(accel, fs: float, wheel_rate_hz: float, max_order: int = MAX_ORDER,
                      axis: int = 0) -> dict:
    """Lines at multiples of a wheel's rotation rate in an accelerometer record.

    accel: samples along `axis` (any number of channels), fs in Hz, wheel_rate_hz: the
    wheels' rotation rate (rim speed / 2 pi r).  Returns, for orders k = 1..max_order:
    "orders", "frequency_hz" (k x rate), "prominence_db" (per order and channel: the
    largest PSD bin within one bin width of the line over the median PSD of the bins
    from three bin widths to BACKGROUND_HZ beside it) and "power" (the PSD of those
    line bins times the bin width, (units)^2), plus "bin_hz".  An order whose line lies
    below MIN_LINE_HZ or above band_top_hz(fs) is NaN: the record cannot show it.
    Neighbouring orders closer than a bin are not told apart: a line shows at the
    orders around it, and the features take the local maxima over orders."""
    x = np.moveaxis(np.asarray(accel, float), axis, 0)
    channels = x.reshape(len(x), -1)
    orders = np.arange(1, max_order + 1)
    shape = (len(orders), channels.shape[1])
    out = {"orders": orders, "frequency_hz": orders * float(wheel_rate_hz),
           "prominence_db": np.full(shape, np.nan), "power": np.full(shape, np.nan),
           "bin_hz": None}
    if len(channels) < 16 or not np.isfinite(wheel_rate_hz) or wheel_rate_hz <= 0:
        return out
    freq, psd = signal.welch(channels, fs=fs, nperseg=min(SPECTRUM_NPERSEG, len(channels)),
                             axis=0, detrend="linear")
    step = float(freq[1] - freq[0])
    out["bin_hz"] = step
    top = band_top_hz(fs)
    for i, f in enumerate(out["frequency_hz"]):
        if f < MIN_LINE_HZ or f > top:
            continue
        distance = np.abs(freq - f)
        line = distance <= step
        beside = (distance >= 3 * step) & (distance <= BACKGROUND_HZ)
        if not line.any() or beside.sum() < 3:
            continue
        background = np.median(psd[beside], axis=0)
        peak = psd[line].max(axis=0)
        with np.errstate(divide="ignore"):
            out["prominence_db"][i] = 10 * np.log10(peak / background)
        out["power"][i] = psd[line].sum(axis=0) * step
    return out


def order_lines(prominence_db, min_db: float) -> list[int]:
    """Indices of the local maxima over orders (axis 0) of a prominence curve that reach
    min_db: the lines, each once though it shows at its neighbouring orders."""
    p = np.asarray(prominence_db, float)
    out = []
    for i in range(len(p)):
        if not np.isfinite(p[i]) or p[i] < min_db:
            continue
        left = p[i - 1] if i > 0 and np.isfinite(p[i - 1]) else -np.inf
        right = p[i + 1] if i + 1 < len(p) and np.isfinite(p[i + 1]) else -np.inf
        if p[i] >= left and p[i] > right:
            out.append(i)
    return out


# ------------------------------------------------------------ features of a run's segments

def run_segments(run, min_duration_s: float = MIN_SEGMENT_S) -> list[Segment]:
    """The segments of an ImuRun with wheel speeds (none without)."""
    if run.wheels is None or len(run.wheels.time_s) == 0:
        return []
    w = run.wheels
    return segments(w.time_s, w.left_mps, w.right_mps, float(run.time_s[0]),
                    float(run.time_s[-1]), run.path.name, min_duration_s)


def run_yaw_features(segment: Segment, run, track_m: float) -> dict:
    """yaw_features of a segment of an ImuRun with wheel speeds."""
    left, right = run.wheels.at(run.time_s)
    return yaw_features(segment, run.time_s, run.gyro[:, 2], left, right, track_m)


def settled_window(segment: Segment, time_s) -> np.ndarray:
    """The samples of a segment from SETTLE_S after its start to its end."""
    time_s = np.asarray(time_s, float)
    return (time_s >= segment.start_s + SETTLE_S) & (time_s <= segment.end_s)


def lateral_acceleration(segment: Segment, run) -> float | None:
    """The mean lateral specific force a_y (m/s^2) over the segment's settled window."""
    window = settled_window(segment, run.time_s)
    return float(np.mean(run.accel[window, 1])) if window.any() else None


def centripetal_ratio(x, y, group=None) -> dict:
    """How fast the robot moves for its logged speed, from its centripetal acceleration.

    In a steady arc the IMU's lateral specific force is a_y = v Omega whatever the
    tires do (the body-frame acceleration of a point moving at v while turning at
    Omega; the IMU's fore-aft offset adds -Omega^2 x on a_x only), on top of the IMU's
    tilt and bias.  With x = v_logged Omega_measured (a segment's mean of the product,
    sample by sample) and y its mean a_y, the slope k of y = k x + b is the true speed
    over the logged one, times the gyro's scale error, independent of any friction law.
    group: per segment its run, each with an intercept b of its own (the IMU's bias,
    which a run's straight driving, x about 0, and its turns both ways pin); None: one
    intercept at 0 (y already bias-free).  Returns k, its standard error (segment
    residuals) and the number of segments (k None with fewer than 3 turning ones)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    labels = np.zeros(len(x), int) if group is None else np.unique(
        np.asarray(group)[ok], return_inverse=True)[1]
    if group is not None:
        for g in np.unique(labels):  # the intercepts, by demeaning within each run
            x[labels == g] -= x[labels == g].mean()
            y[labels == g] -= y[labels == g].mean()
    n_free = len(x) - (len(np.unique(labels)) if group is not None else 0)
    if n_free < 3 or not np.any(x):
        return {"k": None, "stderr": None, "n": int(len(x))}
    k = float(x @ y / (x @ x))
    residual = y - k * x
    return {"k": k, "stderr": float(np.sqrt(residual @ residual / (n_free - 1) / (x @ x))),
            "n": int(len(x))}


def segment_vibration(segment: Segment, run, wheel_radius_m: float) -> dict:
    """A segment's vibration from SETTLE_S after its start: per axis the RMS (m/s^2) in
    band_hz = [MIN_LINE_HZ, band_top_hz(fs)] and the wheel-order prominence and power
    (orders x axes; wheel_order_lines) at each side's wheel rate (the logged command's),
    the larger of the two sides (an arc's sides turn at two rates); None without 16
    samples."""
    window = settled_window(segment, run.time_s)
    fs = run.sample_rate_hz
    band = [MIN_LINE_HZ, band_top_hz(fs)]
    accel = run.accel[window]
    if len(accel) < 16:
        return {"band_hz": band, "rms_m_s2": None, "prominence_db": None, "power": None}
    freq, psd = signals.welch_spectrum(accel, fs)
    rms = np.sqrt(signals.band_power(freq, psd, band))
    sides = [wheel_order_lines(accel, fs, abs(v) / (2 * np.pi * wheel_radius_m))
             for v in (segment.left_mps, segment.right_mps)]
    with np.errstate(invalid="ignore"):
        prominence = np.fmax(sides[0]["prominence_db"], sides[1]["prominence_db"])
        power = np.fmax(sides[0]["power"], sides[1]["power"])
    return {"band_hz": band, "rms_m_s2": [float(x) for x in rms], "prominence_db": prominence,
            "power": power, "frequency_hz": freq, "psd": psd}
