"""The vibration of real recordings: lines at fixed orders of the wheels' rotation.

On the straight segments of the rigid terrains (both sides at one rate, so a line
that follows the wheels is sharp), per axis: the wheel-order lines (local maxima over
orders of the segments' median prominence, at least LINE_DB over the PSD beside them
and MIN_LINE_POWER) and the RMS in the band the records hold.  Lines the recordings
hold and the model lacks are explained by a robot's cause, fitted on the training
half of every rigid terrain's straight segments together and judged on the held-out
half, per line and axis (dB) and per axis's RMS:

- ``drivetrain``: a transmission error (simulation.drive.ripple): the wheel turns
  ahead of and behind its motor n, 2n, 3n times a revolution (gear mesh, belt
  teeth); it pushes the robot along its track (fore-aft, and in yaw where the two
  sides differ);
- ``tread_lugs``: the wheel rolls as a polygon of n lugs (the tire plugin's lug_count
  and lug_depth); it lifts the robot (vertical);
- ``drivetrain + imu_mount``: the drivetrain's error read by an IMU that sways
  sideways on its mount (one lateral mode: frequency and damping ratio, chosen on a
  grid over their priors by the training half's error, the amplitudes refitted at
  each).

The order n is read off the recordings (lug_count_of); each cause's amplitudes are
fitted through surrogate straight runs at the segments' speeds, at one reference
amplitude per harmonic: a line's power grows as the square of its amplitude (checked
by replaying the held-out speeds at the fitted values).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from skidsteer.data.imu import ImuRun, WheelSpeeds
from skidsteer.diagnosis import causes, identify, motion
from skidsteer.diagnosis.verdict import verdict
from skidsteer.experiments.replay import replay
from skidsteer.features import signals
from skidsteer.features.extract import AXES
from skidsteer.features.segments import Segment, order_lines, segment_vibration
from skidsteer.robot import load_model, roles, tire
from skidsteer.simulation.backends import LocalBackend

KIND = "straight"
LINE_DB = 6.0  # a Welch bin of K >= 2 averages scatters by ~+-3 dB: 6 dB is clear of it
MIN_LINE_POWER = 1e-6  # (1e-3 m/s^2)^2, a MEMS accelerometer's noise in one 0.2 Hz bin
MIN_SEGMENTS = 5
HARMONICS = 3
# Surrogate speeds: the straight segments' speeds in clusters no wider than
# SPEED_TOLERANCE (from a cluster's slowest segment), one surrogate at each cluster's
# median.  A line's power rises at most as speed^4 (an imposed displacement, whose
# acceleration grows as frequency^2), so a segment read at a surrogate within 10 % of its
# speed errs by at most 40 log10(1.1) = 1.7 dB, inside MIN_LINE_DB.  At most MAX_SPEEDS
# clusters (one simulation each per fit): a wider spread widens the tolerance.
SPEED_TOLERANCE = 1.1
MAX_SPEEDS = 6
SURROGATE_S = 8.0
# The reference amplitudes the surrogates run at (assumed, each well inside the linear
# range the fit scales from): a transmission error of 0.1 mm at the rim per harmonic
# (a gear mesh's is of order 10 um at the tooth, Smith, Gear Noise and Vibration, 2003,
# times the reduction to the rim); a lug drop of 0.5 mm, a fifth of the 2.5 mm a rigid
# 18-sided polygon of the Husky's 0.165 m radius drops (its carcass smooths it)
REFERENCE_ERROR_M = 1e-4
REFERENCE_LUG_DEPTH_M = 5e-4
# a line's power within NOISE_Z robust standard errors of the segments' median log power,
# never finer than MIN_LINE_DB (a Welch line of a few averages scatters +-1.5 dB; the
# replay's wheel phases differ from the robot's); RMS: 10 % (settling, differing speeds)
MIN_LINE_DB = 3.0
MIN_RMS_RATIO = 1.10
# The IMU's mount (assumed: where and how a recording's IMU is fixed is rarely published;
# BorealTC's README gives "robot axes as recorded").  A sensor on a plate, a bracket or a
# payload rail sways at tens of Hz: the lateral frequency from 10 Hz to the 45 Hz band
# top (6 log-spaced points); the damping ratio 0.03 and 0.1 (a bolted or clamped bracket;
# a foam or rubber pad's ~0.3 is not offered; how these points were set: the notebook
# docs/notebook-2026-12-06.md).  Each point costs one surrogate simulation per speed: 6 x 2
# keeps one terrain's diagnosis under 3 minutes.  The mount's mass, 0.1 kg (an IMU of the
# MEMS-in-a-box class), is 0.2 % of the Husky's: it reads the body's motion without moving
# it, so a surrogate at the reference amplitudes is read through the base-excited mount's
# transmissibility (checked against the simulated mount in the tests), not simulated again.
MOUNT_FREQUENCIES_HZ = tuple(float(f) for f in np.geomspace(10.0, 45.0, 6))
MOUNT_DAMPING_RATIOS = (0.03, 0.1)
MOUNT_MASS_KG = 0.1


def lug_count_of(orders) -> int | None:
    """The fundamental of a set of line orders: the order n (one of them) the largest
    share of whose multiples up to the highest line lie within one order of a line,
    needing at least two (the line and a harmonic); ties to the lower n."""
    orders = sorted(set(int(o) for o in orders))
    best, best_share = None, 0.0
    for n in orders:
        multiples = range(n, orders[-1] + 2, n)
        hits = sum(any(abs(o - k) <= 1 for o in orders) for k in multiples)
        share = hits / len(multiples)
        if hits >= 2 and share > best_share:
            best, best_share = n, share
    return best


def _log_power(power) -> float:
    return float(10 * np.log10(max(power, 1e-30))) if np.isfinite(power) else np.nan


def _median_db(values) -> dict:
    v = np.asarray([x for x in values if np.isfinite(x)], float)
    return identify.median_summary(v) if len(v) else {"value": None, "stderr": None, "n": 0}


def straight_segments(rows: list[dict], half: str | None = None) -> list[dict]:
    return [r for r in rows if r["kind"] == KIND and r.get("vibration") is not None
            and r["vibration"]["power"] is not None and (half is None or r["half"] == half)]


def found_lines(rows: list[dict], key: str = "vibration") -> list[tuple[int, int]]:
    """(order, axis) of the lines in the median prominence of a terrain's straight
    segments (key: "vibration" recorded, "vibration_base" simulated)."""
    segs = [r for r in straight_segments(rows) if r.get(key) is not None]
    if len(segs) < MIN_SEGMENTS:
        return []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        prominence = np.nanmedian([r[key]["prominence_db"] for r in segs], axis=0)
        power = np.nanmedian([r[key]["power"] for r in segs], axis=0)
    out = []
    for a in range(len(AXES)):
        audible = np.where(power[:, a] >= MIN_LINE_POWER, prominence[:, a], np.nan)
        out += [(o + 1, a) for o in order_lines(audible, LINE_DB)]
    return out


def speed_of(row: dict) -> float:
    return (abs(row["left_mps"]) + abs(row["right_mps"])) / 2


def straight_run(speed_mps: float, fs: float, duration_s: float = SURROGATE_S) -> ImuRun:
    """A straight run at one logged wheel speed (its IMU is replayed)."""
    t = np.arange(0, duration_s, 1 / fs)
    wheels = WheelSpeeds(np.array([0.0]), np.array([speed_mps]), np.array([speed_mps]))
    return ImuRun(Path(f"straight_{speed_mps:.3f}.csv"), t, np.zeros((len(t), 3)),
                  np.zeros((len(t), 3)), wheels)


def surrogate(model, speeds, fs: float, radius_m: float, nthread: int) -> list[dict]:
    """segment_vibration of a straight run at each speed on the model (first 2 s out)."""
    runs = [straight_run(v, fs) for v in speeds]
    backend = LocalBackend(nthread)
    try:
        sims = list(backend.map(replay, [(model, r) for r in runs]))
    finally:
        backend.close()
    return [segment_vibration(Segment(s.path.name, 1.0, float(s.time_s[-1]), KIND, v, v), s,
                              radius_m) for s, v in zip(sims, speeds)]


def drivetrain_edit(order: float, errors_m):
    def edit(spec):
        roles.set_spec_numeric(spec, "drive.ripple_order", float(order))
        numeric = spec.numeric("skidsteer.drive.ripple_error_m")
        if numeric is None:
            numeric = spec.add_numeric(name="skidsteer.drive.ripple_error_m",
                                       size=len(errors_m))
        numeric.data = [float(e) for e in errors_m]
    return edit


def imu_mount_edit(frequency_hz: float, damping_ratio: float):
    """The accelerometer and gyro moved onto a small body that slides sideways (the
    robot's y) on a spring and a damper at the IMU's site."""
    def edit(spec):
        causes.mount_sensors(spec, "imu_mount", MOUNT_MASS_KG, frequency_hz, damping_ratio,
                             {"imu_mount_y": [0, 1, 0]})
    return edit


def mount_gain(frequency_hz, mount_hz: float, damping_ratio: float) -> np.ndarray:
    """|H|^2 of a light mount's absolute acceleration over its base's at frequency_hz:
    (1 + (2 zeta r)^2) / ((1 - r^2)^2 + (2 zeta r)^2), r = f / f_mount."""
    r = np.asarray(frequency_hz, float) / mount_hz
    damping = (2 * damping_ratio * r) ** 2
    return (1 + damping) / ((1 - r ** 2) ** 2 + damping)


def through_mount(vibration: dict, speed_mps: float, radius_m: float, mount_hz: float,
                  damping_ratio: float) -> dict:
    """A segment_vibration as an IMU on a lateral mount reads it: a_y's PSD and its
    wheel-order lines times mount_gain, the RMS from that PSD."""
    out = dict(vibration)
    freq = np.asarray(vibration["frequency_hz"], float)
    psd = np.array(vibration["psd"], float)
    psd[:, 1] *= mount_gain(freq, mount_hz, damping_ratio)
    power = np.array(vibration["power"], float)
    order_hz = np.arange(1, len(power) + 1) * speed_mps / (2 * np.pi * radius_m)
    power[:, 1] *= mount_gain(order_hz, mount_hz, damping_ratio)
    rms = np.sqrt(signals.band_power(freq, psd, vibration["band_hz"]))
    out.update(psd=psd, power=power, rms_m_s2=[float(x) for x in rms])
    return out


def tread_edit(order: int, depth_m: float):
    def edit(spec):
        tire.configure(spec, {"lug_count": int(order), "lug_depth": float(depth_m)})
    return edit


# per candidate: what it adds, the reference amplitude its surrogates run at, and the
# cause whose amplitudes are fitted (the mount adds a lateral mode to the drivetrain's)
CANDIDATES = {
    "drivetrain": ("a transmission error repeating n times a wheel revolution (gear mesh, "
                   "belt teeth): the wheels surge ahead of and behind their motors",
                   REFERENCE_ERROR_M, "drivetrain"),
    "tread_lugs": ("a lugged tread: the wheels roll as polygons of n lugs",
                   REFERENCE_LUG_DEPTH_M, "tread_lugs"),
    "drivetrain + imu_mount": ("the drivetrain's error, read by an IMU whose mount sways "
                               "sideways at one frequency", REFERENCE_ERROR_M, "drivetrain"),
}


def speed_clusters(speeds) -> tuple[list[float], np.ndarray]:
    """(the clusters' median speeds, each speed's cluster): speeds sorted and cut where one
    exceeds its cluster's slowest by more than SPEED_TOLERANCE (widened so that there are
    at most MAX_SPEEDS clusters)."""
    speed = np.asarray(speeds, float)
    # a hair above the ratio's MAX_SPEEDS-th root, so the fastest speed cannot open one more
    tolerance = max(SPEED_TOLERANCE, (speed.max() / speed.min()) ** (1 / MAX_SPEEDS) * 1.0001)
    group = np.empty(len(speed), int)
    start, g = None, -1
    for i in np.argsort(speed, kind="stable"):
        if start is None or speed[i] > start * tolerance:
            g, start = g + 1, speed[i]
        group[i] = g
    return [float(np.median(speed[group == k])) for k in range(g + 1)], group


def speed_coverage(terrain) -> str | None:
    """A sentence when a terrain's held-out straight segments are faster than every
    training one by more than SPEED_TOLERANCE: the fit is then judged at speeds it never
    saw (a line's frequency, and so what the robot's and the IMU's modes make of it,
    moves with the speed)."""
    fastest = {h: max((speed_of(s) for s in terrain.segs if s["half"] == h), default=None)
               for h in ("fit", "held_out")}
    if None in fastest.values() or fastest["held_out"] <= fastest["fit"] * SPEED_TOLERANCE:
        return None
    return (f"{terrain.name}'s held-out straight segments reach {fastest['held_out']:.2f} m/s, "
            f"its training ones {fastest['fit']:.2f} m/s: the fit never sees the speeds it is "
            f"judged at (straight runs at {fastest['held_out']:.2f} m/s among the training "
            "runs would show it)")


def _db(vibration: dict, order: int, axis: int) -> float:
    power = vibration["power"][order - 1, axis]
    return _log_power(max(power, MIN_LINE_POWER)) if np.isfinite(power) else np.nan


def _rms_db(vibration: dict, axis: int) -> float:
    return 20 * np.log10(max(vibration["rms_m_s2"][axis], 1e-9))


class _Terrain:
    """One rigid terrain's straight segments, their speed groups and targets."""

    def __init__(self, name, setup, rows, targets):
        self.name, self.setup = name, setup
        self.segs = straight_segments(rows)
        self.speeds, self.group = speed_clusters([speed_of(r) for r in self.segs])
        self.targets = targets  # (order, axis)

    def measured(self, half):
        return self._table(lambda i, seg: seg["vibration"], half)

    def model(self, vibrations, half):
        return self._table(lambda i, seg: vibrations[self.group[i]], half)

    def base(self, half):
        return self._table(lambda i, seg: seg.get("vibration_base"), half)

    def _table(self, pick, half) -> dict:
        """feature -> median dB over the half's segments: lines "o@axis" and "rms@axis"."""
        out = {}
        chosen = [(i, s) for i, s in enumerate(self.segs) if half is None or s["half"] == half]
        for o, a in self.targets:
            out[f"{o}@a_{AXES[a]}"] = _median_db([_db(pick(i, s), o, a) for i, s in chosen
                                                  if pick(i, s) is not None])
        for a, axis in enumerate(AXES):
            out[f"rms@a_{axis}"] = _median_db([_rms_db(pick(i, s), a) for i, s in chosen
                                               if pick(i, s) is not None])
        return out


def _sigma_db(summary: dict, feature: str) -> float:
    floor = MIN_LINE_DB if not feature.startswith("rms") else 20 * np.log10(MIN_RMS_RATIO)
    return max(summary["stderr"] or 0.0, floor / identify.NOISE_Z)


def _z(measured: dict, model: dict) -> dict:
    return {k: (model[k]["value"] - m["value"]) / _sigma_db(m, k) for k, m in measured.items()
            if m["value"] is not None and model.get(k, {}).get("value") is not None}


class LineFit:
    """A line cause fitted: what verdict() reads, and the per-feature held-out errors."""

    def __init__(self, cause, parameters, z, n_fitted, n_train):
        self.cause, self.parameters = cause, parameters
        self.z = z
        self.train_error = identify.rms(v for t in z["fit"].values() for v in t.values())
        self.held_out_error = identify.rms(v for t in z["held_out"].values() for v in t.values())
        self.score = identify.score(self.held_out_error, n_fitted, n_train)
        self.fitted = list(parameters)
        self.removed = 0.0


def fit_candidate(name: str, terrains: list[_Terrain], order: int, fs: float, radius: float,
                  nthread: int, motion_values: dict, settings: dict, extra_edit=None,
                  reference_runs: dict | None = None):
    """Fits a candidate's amplitudes (dB offsets from its reference) on the training half,
    then simulates it at the fitted amplitudes for every terrain's speeds; extra_edit:
    a further edit of the model (the IMU's mount) held while they are fitted;
    reference_runs: the surrogates at the reference amplitudes, when already known.
    Returns the amplitudes, the fitted surrogates and the reference ones."""
    _, reference, _ = CANDIDATES[name]
    harmonics = HARMONICS if name == "drivetrain" else 1

    def model_for(terrain, amplitudes):
        # on the model's own step: a line's power at 1 ms implicit is 1.4-2.4 dB off the
        # 0.1 ms explicit one (scripts/bench/bench_motion_step.py), the yaw rate 0.01 %
        edit = (drivetrain_edit(order, amplitudes) if name == "drivetrain"
                else tread_edit(order, amplitudes[0]))

        def edited(spec):
            motion.apply(spec, motion_values.get(terrain.name, {}))
            edit(spec)
            if extra_edit is not None:
                extra_edit(spec)
        return load_model(terrain.setup, tire=settings or None, edit=edited)

    ref = reference_runs or {
        t.name: surrogate(model_for(t, [reference] * harmonics), t.speeds, fs, radius,
                          nthread) for t in terrains}
    # dB offset per harmonic: the median over training segments, axes and terrains of the
    # measured line less the reference's at that segment's speed
    offsets = []
    for k in range(1, harmonics + 1):
        diffs = []
        for t in terrains:
            for o, a in t.targets:
                if harmonics > 1 and abs(o - k * order) > 1:
                    continue
                for i, s in enumerate(t.segs):
                    if s["half"] != "fit":
                        continue
                    m, r = _db(s["vibration"], o, a), _db(ref[t.name][t.group[i]], o, a)
                    if np.isfinite(m) and np.isfinite(r):
                        diffs.append(m - r)
        offsets.append(float(np.median(diffs)) if diffs else 0.0)
    amplitudes = [reference * 10 ** (d / 20) for d in offsets]
    if harmonics == 1:
        amplitudes = amplitudes[:1]
    fitted = {t.name: surrogate(model_for(t, amplitudes), t.speeds, fs, radius, nthread)
              for t in terrains}
    return amplitudes, fitted, ref


def diagnose(terrains: list[tuple], fs: float, radius: float, nthread: int,
             motion_values: dict, settings: dict) -> dict:
    """The vibration verdict of the rigid terrains' straight segments.  terrains: (name,
    setup, rows) with each straight row's "vibration" (recorded) and "vibration_base"
    (base replay); motion_values: per terrain, the motion model's fitted values, which
    the candidates are added to.  Returns the verdict, the features (measured, base and
    each candidate, per half), the fits and one spectrum per terrain for the report."""
    prepared = []
    for name, setup, rows in terrains:
        lines = found_lines(rows)
        if lines and len(straight_segments(rows)) >= MIN_SEGMENTS:
            prepared.append((name, setup, rows, lines))
    out = {"candidates": {k: v[0] for k, v in CANDIDATES.items()}, "terrains": {}}
    if not prepared:
        out.update(verdict="unexplained", cause=None, reason=(
            f"no rigid terrain with {MIN_SEGMENTS} straight segments holding a wheel-order line"))
        return out
    order = lug_count_of([o for *_, lines in prepared for o, _ in lines])
    if order is None:
        out.update(verdict="unexplained", cause=None, reason=(
            "the recordings' lines have no common fundamental (a line and a harmonic): "
            + ", ".join(f"{n}: {sorted({o for o, _ in lines})}" for n, _, _, lines in prepared)))
        return out
    cases = []
    for name, setup, rows, lines in prepared:
        targets = sorted({(order * max(1, round(o / order)), a) for o, a in lines
                          if abs(o - order * round(o / order)) <= 1 and round(o / order) >= 1})
        cases.append(_Terrain(name, setup, rows, targets))
    measured = {h: {t.name: t.measured(h) for t in cases} for h in ("fit", "held_out")}
    base_z = {h: {t.name: _z(measured[h][t.name], t.base(h)) for t in cases}
              for h in ("fit", "held_out")}
    n_train = max(1, sum(len(v) for v in base_z["fit"].values()))
    base_train = identify.rms(v for t in base_z["fit"].values() for v in t.values())
    base_held = identify.rms(v for t in base_z["held_out"].values() for v in t.values())
    fits, models = [], {}

    def line_fit(name, extra_edit=None, extra=None, reference_runs=None):
        cause = CANDIDATES[name][2]
        amplitudes, fitted, reference = fit_candidate(
            cause, cases, order, fs, radius, nthread, motion_values, settings, extra_edit,
            reference_runs)
        z = {h: {t.name: _z(measured[h][t.name], t.model(fitted[t.name], h)) for t in cases}
             for h in ("fit", "held_out")}
        key = "ripple_error_m" if cause == "drivetrain" else "lug_depth_m"
        parameters = {"order": order, key: amplitudes, **(extra or {})}
        return LineFit(name, parameters, z, len(amplitudes) + len(extra or {}),
                       n_train), fitted, reference

    references = {}  # the rigidly mounted IMU's reference surrogates, per fitted cause
    for name, (_, _, cause) in CANDIDATES.items():
        if cause in references:  # the cause's rigid candidate came first: this one mounts it
            # every mount of the grid, its amplitudes refitted: the cause's reference
            # surrogates read through the mount's transmissibility, the fitted ones
            # simulated; the mount kept is the one the training half prefers
            trials = [line_fit(name, imu_mount_edit(f, d),
                               {"mount_frequency_hz": f, "mount_damping_ratio": d},
                               {t.name: [through_mount(v, speed, radius, f, d) for v, speed
                                         in zip(references[cause][t.name], t.speeds)]
                                for t in cases})
                      for f in MOUNT_FREQUENCIES_HZ for d in MOUNT_DAMPING_RATIOS]
            fit, fitted, _ = min(trials, key=lambda trial: trial[0].train_error)
        else:
            fit, fitted, references[cause] = line_fit(name)
        fits.append(fit)
        models[name] = fitted
    fits.sort(key=lambda f: f.score)
    noise = identify.rms(min(1.0, (m["stderr"] or 0) / _sigma_db(m, k))
                         for t in measured["held_out"].values() for k, m in t.items()
                         if m["value"] is not None)
    base_all = identify.rms([*[v for t in base_z["fit"].values() for v in t.values()],
                             *[v for t in base_z["held_out"].values() for v in t.values()]])
    for f in fits:
        f.removed = (0.0 if base_held ** 2 <= noise ** 2 else
                     float(min(1.0, (base_held ** 2 - f.held_out_error ** 2)
                               / (base_held ** 2 - noise ** 2))))
    name, named, reason = verdict(base_all, base_held, fits, noise, base_train=base_train,
                                  n_train=n_train, scale="the segments' scatter")
    coverage = [c for c in map(speed_coverage, cases) if c]
    if coverage and name != "explained":
        reason = f"{reason}; {'; '.join(coverage)}"
    out.update(verdict=name, cause=named.cause if named else None, reason=reason,
               speed_coverage=coverage,
               order=order, base={"train_error": base_train, "held_out_error": base_held},
               fits=[{"cause": f.cause, "parameters": f.parameters, "train_error": f.train_error,
                      "held_out_error": f.held_out_error, "score": f.score,
                      "removed": f.removed, "z": f.z} for f in fits])
    for t in cases:
        best = models[fits[0].cause][t.name]
        out["terrains"][t.name] = {
            "targets": [f"{o}@a_{AXES[a]}" for o, a in t.targets],
            "speeds_mps": t.speeds,
            "held_out": {"measured": _values(measured["held_out"][t.name]),
                         "base": _values(t.base("held_out")),
                         **{c: _values(t.model(models[c][t.name], "held_out"))
                            for c in models}}}
        out.setdefault("spectra", {})[t.name] = _spectrum(t, best)
    return out


def _values(table: dict) -> dict:
    return {k: v["value"] for k, v in table.items()}


def _spectrum(terrain: _Terrain, fitted: list[dict]) -> dict:
    """The held-out straight segment nearest the terrain's median speed: its recorded and
    base-replay PSD and the fitted candidate's at that speed group."""
    held = [(i, s) for i, s in enumerate(terrain.segs) if s["half"] == "held_out"] or list(
        enumerate(terrain.segs))
    median = np.median([speed_of(s) for _, s in held])
    i, seg = min(held, key=lambda p: abs(speed_of(p[1]) - median))
    def pick(v):
        return None if v is None else {"frequency_hz": np.asarray(v["frequency_hz"]).tolist(),
                                       "psd": np.asarray(v["psd"]).tolist()}
    return {"run": seg["run"], "segment_s": seg["segment_s"], "speed_mps": speed_of(seg),
            "recorded": pick(seg["vibration"]), "base": pick(seg.get("vibration_base")),
            "extended": pick(fitted[terrain.group[i]])}
