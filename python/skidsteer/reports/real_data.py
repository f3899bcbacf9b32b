"""``skidsteer diagnose`` on real recordings: IMU runs with their wheel speeds (issue 20).

robot -> recordings (data.imu) -> replay on the model (simulation.replay) ->
segments and their yaw rates (features.segments) -> comparison -> diagnosis ->
diagnosis.json and report.md.

What is compared: every segment of every run is scored like a trial; its yaw
rate as measured, as the wheels predict it and as the base model replaying the
run's own wheel speeds gives it.  The features are the effective-track factor
chi (predicted / measured yaw rate) of the segments turning in place and of the
arcs (each kind its own feature: a skid-steer robot slips differently in each),
over segments whose predicted yaw rate is at least MIN_TURN_DEG_S.  The verdict:

- ``no-discrepancy``: for every kind the model's median chi is within the
  measured segments' scatter (NOISE_Z robust standard errors of their median, or
  MIN_RELATIVE of it);
- ``explained``: a motion cause (diagnosis.motion), fitted on the even-numbered
  runs' segments, brings every discrepant kind's chi on the odd-numbered runs
  within that scatter and removes at least EXPLAINED_SHARE of the discrepancy;
- ``unexplained``: otherwise, with the most likely cause and what it closes and
  leaves; or on a terrain that is not a rigid floor of the model's (deformable
  ground is not rigid-floor friction), with that reason.

The vibration has its own verdict (``vibration_verdict``, result["vibration"]): per
kind of segment, the wheel-order lines and the RMS per axis within the band each
record holds; lines the recordings hold and the model lacks are fitted with the
tread (``explain_lines``, diagnosis.tread) on the even-numbered runs and judged on
the others.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np
from tqdm import tqdm

from skidsteer.data.files import write_json, write_text
from skidsteer.data.imu import ImuDataset, ImuRun, WheelSpeeds, read_bag, read_imu_folder
from skidsteer.diagnosis.motion import MOTION_CAUSES
from skidsteer.diagnosis.tread import TREAD_LUGS
from skidsteer.features import signals
from skidsteer.features.extract import AXES
from skidsteer.features.segments import (MIN_LINE_HZ, SETTLE_S, Segment, band_top_hz,
                                         order_lines, segments, wheel_order_lines,
                                         yaw_features)
from skidsteer.reports.markdown import table
from skidsteer.robot import Setup, load_model, load_robot
from skidsteer.simulation.backends import LocalBackend
from skidsteer.simulation.drive import DriveGeometry
from skidsteer.experiments.replay import replay
from skidsteer.simulation.run import run_batch

MIN_TURN_DEG_S = 3.0  # a segment turning slower says little about chi (gyro bias ~0.01 deg/s)
NOISE_Z = 3.0  # discrepancy within 3 robust standard errors of the measured median: none
MIN_RELATIVE = 0.05  # and never finer than 5 % of chi (the model's own step/settling spread)
# segments whose chi scatters by more than this (robust standard error of the median
# over the median) do not behave like repeated trials of one thing (a robot that
# sometimes turns and sometimes is stuck): such a feature decides nothing
MAX_RELATIVE_SCATTER = 0.1
MIN_SCATTER_SEGMENTS = 5  # fewer segments give no robust spread to judge (the MAD of 2)
EXPLAINED_SHARE = 0.5  # a cause must remove at least half of the held-out discrepancy
FIT_GRID = 11  # points of the cause's prior the surrogate is simulated at (linear between)
SURROGATE_COMMANDS = 3  # representative commands of the surrogate (terciles of |yaw rate|)
SURROGATE_S = 8.0  # the constant-command swivel the fit uses per distinct command
# Vibration (the real spectra's wheel-order lines and broad level; features.segments).
# A line: a local maximum over wheel orders of the segments' median prominence of at
# least LINE_DB: its PSD bin 4x the background's median.  One Welch bin of K >= 2
# averaged Hann windows scatters by about +-3 dB (chi-square with 2K degrees of
# freedom, 90 %), the median over >= MIN_SCATTER_SEGMENTS segments by less: 6 dB is
# clear of it (set before looking at the data).  A measured line the model shows
# LINE_DB weaker is missing from the model (and the other way round, extra).
LINE_DB = 6.0
# and a line must carry at least this power ((m/s^2)^2): (1e-3 m/s^2)^2, about a MEMS
# accelerometer's noise in one 0.2 Hz bin (150 ug/sqrt(Hz)); below it a "line" is the
# simulation's numerical floor, which no recording could show
MIN_LINE_POWER = 1e-6
# the broad level: per axis the median over a kind's segments of log10(RMS) in
# [MIN_LINE_HZ, band_top_hz(fs)], within NOISE_Z robust standard errors of the
# measured median or MIN_RMS_RATIO of it, like chi's rule (10 %: settling and the
# segments' differing commands move a segment's RMS more than its yaw rate)
MIN_RMS_RATIO = 1.10


def run_segments(run: ImuRun, min_duration_s: float | None = None) -> list[Segment]:
    """features.segments of a run (none without wheel speeds)."""
    if run.wheels is None or len(run.wheels.time_s) == 0:
        return []
    extra = {} if min_duration_s is None else {"min_duration_s": min_duration_s}
    w = run.wheels
    return segments(w.time_s, w.left_mps, w.right_mps, float(run.time_s[0]),
                    float(run.time_s[-1]), run.path.name, **extra)


def run_yaw_features(segment: Segment, run: ImuRun, track_m: float) -> dict:
    """features.yaw_features of a segment of a run with wheel speeds."""
    left, right = run.wheels.at(run.time_s)
    return yaw_features(segment, run.time_s, run.gyro[:, 2], left, right, track_m)


def run_vibration(segment: Segment, run: ImuRun, wheel_radius_m: float) -> dict:
    """The segment's vibration, from SETTLE_S after its start: per axis the RMS (m/s^2)
    in band_hz = [MIN_LINE_HZ, band_top_hz(fs)] (the record's Nyquist frequency sets
    the top) and the wheel-order prominence (orders x axes, dB; features.segments), at
    each side's wheel rate (the command's: recordings log set points) taking the larger
    of the two sides (an arc's sides turn at two rates)."""
    window = (run.time_s >= segment.start_s + SETTLE_S) & (run.time_s <= segment.end_s)
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
            "power": power}


def read_recordings(path, track_m: float) -> ImuDataset:
    """A folder of BorealTC-layout runs, or one bag (a dataset of one run)."""
    path = Path(path)
    if path.is_dir() and not (path / "metadata.yaml").is_file():
        return read_imu_folder(path, track_m=track_m)
    data = ImuDataset(path.parent)
    data.runs.append(read_bag(path, terrain=path.parent.name))
    return data


def diagnose_recordings(dataset, out, model: str = "husky_a200", progress: bool = True,
                        nthread: int = 2, timestep: float | None = None) -> dict:
    """Diagnoses the recordings at `dataset`; writes out/diagnosis.json and report.md."""
    started = time.perf_counter()
    dataset, out = Path(dataset), Path(out)
    robot = load_robot(model)
    terrain = dataset.name if dataset.is_dir() else dataset.parent.name
    floor = next((f for f in robot.floors if f.lower() == terrain.lower()), None)
    floor_note = (f"terrain {terrain!r} is the model's floor {floor!r}" if floor else
                  f"terrain {terrain!r} is not one of the model's floors "
                  f"({', '.join(robot.floors)}): run on its default floor "
                  f"{robot.default_floor!r}")
    setup = Setup(robot=model, build=robot.default_build, floor=floor or robot.default_floor)
    m = load_model(setup, timestep=timestep)
    geometry = DriveGeometry.from_model(m)
    track = 2 * geometry.half_track
    data = read_recordings(dataset, track)
    usable = [r for r in data.runs if r.wheels is not None]
    skipped = list(data.skipped) + [{"file": str(r.path), "reason": f"{r.path.name}: no wheel "
                                     "speeds, nothing to replay"} for r in data.runs
                                    if r.wheels is None]
    backend = LocalBackend(nthread)
    bar = tqdm(total=len(usable), unit="run", desc="replay", disable=not progress)
    simulated = []
    try:
        for sim in backend.map(replay, [(m, r) for r in usable]):
            simulated.append(sim)
            bar.update(1)
    finally:
        bar.close()
        backend.close()
    rows, spectra = [], []
    for index, (run, sim) in enumerate(zip(usable, simulated)):
        for seg in run_segments(run):
            measured = run_yaw_features(seg, run, track)
            model_side = run_yaw_features(seg, sim, track)
            vib_measured = run_vibration(seg, run, geometry.wheel_radius)
            vib_simulated = run_vibration(seg, sim, geometry.wheel_radius)
            spectra.append((vib_measured, vib_simulated))
            rows.append({"run": run.path.name, "segment": [seg.start_s, seg.end_s],
                         "kind": seg.kind, "left_mps": seg.left_mps, "right_mps": seg.right_mps,
                         "yaw_rate_measured_deg_s": measured["yaw_rate_deg_s"],
                         "yaw_rate_predicted_deg_s": measured["yaw_rate_predicted_deg_s"],
                         "yaw_rate_simulated_deg_s": model_side["yaw_rate_deg_s"],
                         "chi_measured": measured["chi"], "chi_simulated": model_side["chi"],
                         "accel_band_hz": vib_measured["band_hz"],
                         "accel_rms_measured_m_s2": vib_measured["rms_m_s2"],
                         "accel_rms_simulated_m_s2": vib_simulated["rms_m_s2"],
                         "half": "fit" if index % 2 == 0 else "held_out"})
    result = _verdict(rows, floor is not None, floor_note, setup, timestep)
    result["vibration"] = vibration_verdict(rows, spectra, floor is not None, floor_note)
    if floor is not None and result["vibration"].get("unexplained_lines"):
        explain_lines(result["vibration"], rows, spectra, setup, timestep,
                      usable[0].sample_rate_hz, geometry.wheel_radius, nthread)
    result.update({"model": model, "terrain": terrain, "floor": setup.floor,
                   "floor_note": floor_note, "dataset": str(dataset),
                   "runs": rows, "skipped": skipped,
                   "notes": {r.path.name: list(r.notes) for r in data.runs},
                   "wall_time_s": round(time.perf_counter() - started, 1)})
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "diagnosis.json", result, indent=1)
    write_text(out / "report.md", render(result))
    return result


TURN_KINDS = ("turn_in_place", "arc")  # the kinds whose chi is a feature, each its own


def _turning(rows: list[dict], kind: str) -> list[dict]:
    return [r for r in rows if r["kind"] == kind
            and r["yaw_rate_predicted_deg_s"] is not None
            and abs(r["yaw_rate_predicted_deg_s"]) >= MIN_TURN_DEG_S
            and r["chi_measured"] is not None and r["chi_simulated"] is not None]


def _summary(values) -> dict:
    v = np.asarray(values, float)
    if len(v) == 0:
        return {"n": 0, "median": None, "stderr": None}
    mad = float(np.median(np.abs(v - np.median(v)))) * 1.4826
    return {"n": int(len(v)), "median": float(np.median(v)),
            "stderr": float(1.253 * mad / np.sqrt(len(v)))}  # of a median, normal errors


def _tolerance(measured: dict) -> float:
    return max(NOISE_Z * (measured["stderr"] or 0.0), MIN_RELATIVE * measured["median"])


def _verdict(rows, rigid_floor: bool, floor_note: str, setup, timestep) -> dict:
    """The verdict on chi, one feature per kind of turning segment (TURN_KINDS) with at
    least two segments; see the module's docstring."""
    features = {}
    for kind in TURN_KINDS:
        segs = _turning(rows, kind)
        measured = _summary([r["chi_measured"] for r in segs])
        if measured["n"] < 2:
            continue
        simulated = _summary([r["chi_simulated"] for r in segs])
        features[kind] = {"measured": measured, "simulated": simulated,
                          "discrepancy": simulated["median"] - measured["median"],
                          "tolerance": _tolerance(measured)}
    every = [r for kind in TURN_KINDS for r in _turning(rows, kind)]
    out = {"feature": "chi: wheel-predicted over measured yaw rate, per kind of turning "
                      "segment", "features": features,
           "chi_measured": _summary([r["chi_measured"] for r in every]),
           "chi_simulated": _summary([r["chi_simulated"] for r in every]),
           "cause": None, "parameters": {}, "intervals": {}, "gain": None}
    if not features:
        out.update(verdict="unexplained", reason="fewer than two turning segments of any kind "
                   "with a measurable yaw rate: nothing to compare")
        return out
    described = "; ".join(f"{k}: model {f['simulated']['median']:.2f}, measured "
                          f"{f['measured']['median']:.2f} (tolerance {f['tolerance']:.2f})"
                          for k, f in features.items())
    scattered = [k for k, f in features.items() if f["measured"]["n"] >= MIN_SCATTER_SEGMENTS
                 and f["measured"]["stderr"] > MAX_RELATIVE_SCATTER * abs(f["measured"]["median"])]
    if scattered:
        out.update(verdict="unexplained", reason=(
            f"the segments' chi scatters too much to be one behaviour ({', '.join(scattered)}: "
            "robust standard error above "
            f"{MAX_RELATIVE_SCATTER:.0%} of the median: a robot that turns in some segments and "
            f"is stuck in others); {described}" + (f"; {floor_note}" if not rigid_floor else "")))
        return out
    discrepant = [k for k, f in features.items() if abs(f["discrepancy"]) > f["tolerance"]]
    if not discrepant:
        out.update(verdict="no-discrepancy", reason=f"chi within the segments' scatter: "
                   f"{described}")
        return out
    if not rigid_floor:
        out.update(verdict="unexplained", reason=(
            f"{floor_note}; chi ({described}) is a property of deformable ground (sinkage, "
            "bulldozing, a stuck robot), which no rigid-floor cause models: no cause is named"))
        return out
    best = None
    for cause in MOTION_CAUSES.values():
        candidate = _fit_motion_cause(cause, rows, discrepant, features, setup, timestep)
        if best is None or candidate["held_out_score"] < best["held_out_score"]:
            best = candidate
    out["gain"] = best
    closed = [k for k in discrepant if best["per_kind"][k]["held_out_error"]
              <= features[k]["tolerance"]]
    before = sum(abs(features[k]["discrepancy"]) for k in discrepant)
    after = sum(best["per_kind"][k]["held_out_error"] for k in discrepant)
    best["share_removed"] = 1 - after / before if before > 0 else 0.0
    effect = "; ".join(f"{k}: {best['per_kind'][k]['held_out_model']:.2f} against "
                       f"{best['per_kind'][k]['held_out_measured']:.2f} measured "
                       f"({'closed' if k in closed else 'left open'})" for k in discrepant)
    if len(closed) == len(discrepant) and best["share_removed"] >= EXPLAINED_SHARE:
        out.update(verdict="explained", cause=best["cause"], parameters=best["parameters"],
                   intervals=best["intervals"], reason=(
                       f"{best['cause']} fitted on the even-numbered runs' segments; on the "
                       f"others {effect} ({best['share_removed']:.0%} of the discrepancy "
                       "removed)"))
    else:
        out.update(verdict="unexplained", reason=(
            f"the model's chi differs ({described}); the most likely motion cause, "
            f"{best['cause']} at {next(iter(best['parameters'].values())):.3g}, on the "
            f"held-out runs: {effect} ({best['share_removed']:.0%} removed): what is left "
            "has no candidate"))
    return out


def _fit_motion_cause(cause, rows, kinds, features, setup, timestep) -> dict:
    """The cause's main parameter fitted on the even-numbered runs' segments of the
    given kinds through a surrogate: a constant-command swivel at up to
    SURROGATE_COMMANDS representative commands per kind (the segments' medians in
    terciles of |predicted yaw rate|), simulated at FIT_GRID points of the prior and
    interpolated between them.  The score: the sum over kinds of |model - measured|
    median chi over the kind's tolerance.  Interval: the values whose fit score is
    within one tolerance per kind of the best."""
    grid = np.linspace(0, 1, FIT_GRID)
    values = cause.main.from_unit(grid)
    groups = {k: _command_groups(_turning(rows, k)) for k in kinds}
    commands = [g["command"] for k in kinds for g in groups[k]]
    models = [load_model(setup, timestep=timestep,
                         edit=(lambda spec, v=v: cause.apply(spec, cause.parameters(v), 0)))
              for v in values]
    runs = run_batch([mm for mm in models for _ in commands],
                     [c for _ in models for c in commands], SURROGATE_S)
    chi = np.empty((len(commands), len(values)))
    for i in range(len(values)):
        for j, command in enumerate(commands):
            yaw = np.rad2deg(runs[i * len(commands) + j].gyro[:, 2])
            yaw = yaw[len(yaw) // 2:].mean()
            chi[j, i] = command[1] / yaw if abs(yaw) > 1e-6 else np.nan
    fine = np.linspace(values[0], values[-1], 401)
    curves = np.array([np.interp(fine, values, c) for c in chi])
    offset = {}
    j = 0
    for k in kinds:
        offset[k] = j
        j += len(groups[k])

    def model_chi(kind, half):
        segs = [r for r in _turning(rows, kind) if half is None or r["half"] == half]
        if not segs:  # one run only: fit and held-out are the same segments
            segs = _turning(rows, kind)
        index = [offset[kind] + _group_of(r, groups[kind]) for r in segs]
        return (np.nanmedian(curves[index], axis=0),
                float(np.median([r["chi_measured"] for r in segs])))

    score = np.zeros(len(fine))
    for k in kinds:
        model, measured = model_chi(k, "fit")
        score += np.abs(model - measured) / features[k]["tolerance"]
    i = int(np.nanargmin(score))
    ok = fine[score <= score[i] + len(kinds)]
    per_kind, held_score = {}, 0.0
    for k in kinds:
        model, measured = model_chi(k, "held_out")
        per_kind[k] = {"held_out_model": float(model[i]), "held_out_measured": measured,
                       "held_out_error": float(abs(model[i] - measured))}
        held_score += per_kind[k]["held_out_error"] / features[k]["tolerance"]
    return {"cause": cause.name, "parameters": {cause.main.name: float(fine[i])},
            "intervals": {cause.main.name: [float(ok.min()), float(ok.max())]},
            "per_kind": per_kind, "held_out_score": held_score,
            "surrogate": {"commands": [list(c) for c in commands], "grid": values.tolist(),
                          "chi": chi.tolist()}}


def _command_groups(rows: list[dict]) -> list[dict]:
    """Up to SURROGATE_COMMANDS groups of segments by tercile of |predicted yaw rate|,
    each with its median command (v m/s, omega deg/s) and its |omega| upper edge."""
    w = np.array([abs(r["yaw_rate_predicted_deg_s"]) for r in rows])
    edges = np.quantile(w, np.linspace(0, 1, SURROGATE_COMMANDS + 1)[1:-1])
    labels = np.searchsorted(edges, w, side="right")
    groups = []
    for k in sorted(set(labels)):
        members = [r for r, lab in zip(rows, labels) if lab == k]
        v = float(np.median([(r["left_mps"] + r["right_mps"]) / 2 for r in members]))
        omega = float(np.median([abs(r["yaw_rate_predicted_deg_s"]) for r in members]))
        groups.append({"command": (round(v, 3), round(omega, 2)),
                       "upper": float(max(abs(r["yaw_rate_predicted_deg_s"]) for r in members))})
    return groups


def _group_of(row: dict, groups: list[dict]) -> int:
    w = abs(row["yaw_rate_predicted_deg_s"])
    for k, g in enumerate(groups):
        if w <= g["upper"]:
            return k
    return len(groups) - 1


def vibration_verdict(rows: list[dict], spectra: list, rigid_floor: bool,
                      floor_note: str) -> dict:
    """The vibration of each kind of segment (with at least MIN_SCATTER_SEGMENTS), model
    against recording: the wheel-order lines (LINE_DB over their background and
    MIN_LINE_POWER) and the broad RMS per axis (NOISE_Z robust standard errors of log10
    RMS, at least MIN_RMS_RATIO).  spectra: per row, run_vibration's (measured,
    simulated)."""
    kinds = {}
    for kind in ("straight", "turn_in_place", "arc"):
        index = [i for i, r in enumerate(rows) if r["kind"] == kind
                 and r["accel_rms_measured_m_s2"] is not None
                 and spectra[i][0]["prominence_db"] is not None]
        if len(index) < MIN_SCATTER_SEGMENTS:
            continue
        with warnings.catch_warnings():  # orders a record cannot show are NaN
            warnings.simplefilter("ignore", RuntimeWarning)
            measured, simulated = ({key: np.nanmedian([spectra[i][side][key] for i in index],
                                                      axis=0) for key in ("prominence_db", "power")}
                                   for side in (0, 1))
        found = []
        for a, axis in enumerate(AXES):
            for side, this, other in (("recording", measured, simulated),
                                      ("model", simulated, measured)):
                audible = np.where(this["power"][:, a] >= MIN_LINE_POWER,
                                   this["prominence_db"][:, a], np.nan)
                for o in order_lines(audible, LINE_DB):
                    if any(f["order"] == o + 1 and f["axis"] == axis for f in found):
                        continue
                    # shown on the other side: as prominent within LINE_DB, and audible
                    theirs = other["prominence_db"][o, a]
                    shown = (np.isfinite(theirs) and theirs >= this["prominence_db"][o, a] - LINE_DB
                             and other["power"][o, a] >= MIN_LINE_POWER)
                    found.append({"order": o + 1, "axis": axis, "in": side,
                                  "measured_db": _num(measured["prominence_db"][o, a]),
                                  "simulated_db": _num(simulated["prominence_db"][o, a]),
                                  "measured_power": _num(measured["power"][o, a]),
                                  "simulated_power": _num(simulated["power"][o, a]),
                                  "missing": not shown})
        rms = {}
        for a, axis in enumerate(AXES):
            measured_log = [np.log10(rows[i]["accel_rms_measured_m_s2"][a]) for i in index]
            m_log = _summary(measured_log)
            s_log = _summary([np.log10(rows[i]["accel_rms_simulated_m_s2"][a]) for i in index])
            tolerance = _log_tolerance(measured_log, np.log10(MIN_RMS_RATIO))
            rms[axis] = {"measured_m_s2": 10 ** m_log["median"],
                         "simulated_m_s2": 10 ** s_log["median"],
                         "ratio": 10 ** (s_log["median"] - m_log["median"]),
                         "tolerance_ratio": 10 ** tolerance,
                         "discrepant": abs(s_log["median"] - m_log["median"]) > tolerance}
        kinds[kind] = {"segments": len(index), "lines": found, "rms": rms,
                       "order_prominence_db": {"measured": _rounded(measured["prominence_db"]),
                                               "simulated": _rounded(simulated["prominence_db"])}}
    out = {"features": "wheel-order lines (prominence over wheel orders, local maxima of at "
                       f"least {LINE_DB:g} dB) and RMS per axis in the band the records hold",
           "line_min_db": LINE_DB, "kinds": kinds, "unexplained_lines": [], "loud": [],
           "cause": None, "parameters": {}, "intervals": {}, "gain": None}
    if not kinds:
        out.update(verdict="unexplained", reason=f"fewer than {MIN_SCATTER_SEGMENTS} segments "
                   "of any kind with a spectrum: nothing to compare")
        return out
    missing = [(k, f) for k, v in kinds.items() for f in v["lines"] if f["missing"]]
    loud = [(k, a, e["ratio"]) for k, v in kinds.items() for a, e in v["rms"].items()
            if e["discrepant"]]
    if not missing and not loud:
        out.update(verdict="no-discrepancy", reason="every wheel-order line and every axis's "
                   "RMS within the segments' scatter")
        return out
    said = []
    in_recording = sorted({f["order"] for _, f in missing if f["in"] == "recording"})
    in_model = sorted({f["order"] for _, f in missing if f["in"] == "model"})
    if in_recording:
        said.append(f"the recordings hold lines at wheel orders {_orders(in_recording)} "
                    f"({', '.join(sorted({k for k, f in missing if f['in'] == 'recording'}))}) "
                    "that the model lacks")
    if in_model:
        said.append(f"the model has lines at wheel orders {_orders(in_model)} the recordings lack")
    if loud:
        said.append("RMS model/recording " + ", ".join(f"{k} a_{a} {r:.2g}" for k, a, r in loud))
    why = ""
    if not rigid_floor:
        why = f"; {floor_note}: deformable ground's vibration has no candidate"
    out.update(verdict="unexplained", reason="; ".join(said) + why,
               unexplained_lines=[{"kind": k, "order": f["order"], "axis": f["axis"]}
                                  for k, f in missing if f["in"] == "recording"],
               loud=[{"kind": k, "axis": a} for k, a, _ in loud])
    return out


TREAD_KIND = "straight"  # both sides at one wheel rate: the lines are sharp
TREAD_GRID = 6  # depths of the prior the surrogate is simulated at (log-log between)
TREAD_SPEEDS = 3  # representative speeds (terciles of the fit half's segments)
# a line's power is judged within NOISE_Z robust standard errors of the segments'
# median log power, and never finer than 3 dB (a Welch line estimate of a few
# averages scatters by +-1.5 dB; the replay's wheel phases drift from run to run)
MIN_LINE_POWER_DB = 3.0


def explain_lines(vibration: dict, rows: list[dict], spectra: list, setup, timestep,
                  fs: float, wheel_radius_m: float, nthread: int = 2) -> None:
    """Fits the tread (diagnosis.tread) to the recorded lines of the TREAD_KIND
    segments the model lacks, on the even-numbered runs, and judges it on the others:
    its lines (power per order and axis) and RMS per axis against the held-out
    segments' medians.  lug_count: lug_count_of the lines; lug_depth_m: fitted
    through a surrogate, a straight run at up to TREAD_SPEEDS speeds at TREAD_GRID
    depths, interpolated log-log.  Updates vibration in place (cause, parameters,
    intervals, gain, verdict, reason)."""
    found = [(f["order"], AXES.index(f["axis"])) for f in vibration["unexplained_lines"]
             if f["kind"] == TREAD_KIND]
    index = [i for i, r in enumerate(rows) if r["kind"] == TREAD_KIND
             and spectra[i][0]["power"] is not None]
    count = lug_count_of([order for order, _ in found])
    if count is None or not index:
        vibration["reason"] += (f"; no {TREAD_KIND} segments with a line and one of its "
                                "harmonics to fit a cause on: the tread (diagnosis.tread) is "
                                "not tried")
        return
    # the lines at multiples of the count (within an order: a line shows at its
    # neighbours), each judged at its exact multiple
    targets = sorted({(count * max(1, round(o / count)), a) for o, a in found
                      if abs(o - count * round(o / count)) <= 1 and round(o / count) >= 1})
    speed = np.array([(abs(rows[i]["left_mps"]) + abs(rows[i]["right_mps"])) / 2 for i in index])
    fit = [k for k, i in enumerate(index) if rows[i]["half"] == "fit"]
    held = [k for k, i in enumerate(index) if rows[i]["half"] == "held_out"] or fit
    edges = np.quantile(speed[fit], np.linspace(0, 1, TREAD_SPEEDS + 1)[1:-1])
    group = np.searchsorted(edges, speed, side="right")
    speeds = [float(np.median(speed[fit][group[fit] == g])) if np.any(group[fit] == g)
              else float(np.median(speed[group == g])) for g in range(TREAD_SPEEDS)]
    depths = TREAD_LUGS.main.from_unit(np.linspace(0, 1, TREAD_GRID))
    models = [load_model(setup, timestep=timestep, edit=(
        lambda spec, d=d: TREAD_LUGS.apply(spec, TREAD_LUGS.parameters(d, {"lug_count": count}), 0)))
        for d in depths]
    surrogate = [_straight_schedule(v, fs) for v in speeds]
    backend = LocalBackend(nthread)
    try:
        sims = list(backend.map(replay, [(mm, run) for mm in models for run in surrogate]))
    finally:
        backend.close()
    # model log10 line power and RMS: (depth, speed group, target) and (depth, group, axis)
    line_model = np.empty((len(depths), len(speeds), len(targets)))
    rms_model = np.empty((len(depths), len(speeds), len(AXES)))
    for j, sim in enumerate(sims):
        d, g = divmod(j, len(speeds))
        seg = Segment(sim.path.name, 0.0, float(sim.time_s[-1]), TREAD_KIND, speeds[g], speeds[g])
        vib = run_vibration(seg, sim, wheel_radius_m)
        line_model[d, g] = [_log_power(vib["power"][o - 1, a]) for o, a in targets]
        rms_model[d, g] = np.log10(np.maximum(vib["rms_m_s2"], 1e-30))
    fine = np.exp(np.linspace(np.log(depths[0]), np.log(depths[-1]), 401))

    def curve(values):  # (depth, group) -> (fine, group), log-log interpolation
        return np.array([np.interp(np.log(fine), np.log(depths), values[:, g])
                         for g in range(values.shape[1])]).T

    line_curves = [curve(line_model[:, :, t]) for t in range(len(targets))]
    # NaN where a segment's record cannot show the order (features.segments)
    measured_log = np.array([[_log_power(spectra[i][0]["power"][o - 1, a]) for o, a in targets]
                             for i in index])
    tolerance = np.array([_log_tolerance(measured_log[:, t], MIN_LINE_POWER_DB / 10)
                          for t in range(len(targets))])

    def errors(half, fine_index):
        model = np.array([[line_curves[t][fine_index, group[k]] for t in range(len(targets))]
                          for k in half])
        both = np.isfinite(model) & np.isfinite(measured_log[half])
        return np.array([np.median(model[both[:, t], t]) - np.median(measured_log[half][both[:, t], t])
                         if both[:, t].any() else np.nan for t in range(len(targets))])

    score = np.array([np.nansum(np.abs(errors(fit, f)) / tolerance) for f in range(len(fine))])
    best = int(np.argmin(score))
    ok = fine[score <= score[best] + len(targets)]
    held_error = errors(held, best)
    closed = np.abs(np.nan_to_num(held_error, nan=np.inf)) <= tolerance
    rms_curves = [curve(rms_model[:, :, a]) for a in range(len(AXES))]
    rms = {}
    for a, axis in enumerate(AXES):
        measured = np.log10([rows[index[k]]["accel_rms_measured_m_s2"][a] for k in held])
        model = np.median([rms_curves[a][best, group[k]] for k in held])
        tol = _log_tolerance(measured, np.log10(MIN_RMS_RATIO))
        rms[axis] = {"held_out_model_m_s2": float(10 ** model),
                     "held_out_measured_m_s2": float(10 ** np.median(measured)),
                     "closed": bool(abs(model - np.median(measured)) <= tol)}
    per_line = [{"order": o, "axis": AXES[a], "held_out_error_db": float(10 * e),
                 "tolerance_db": float(10 * t), "closed": bool(c)}
                for (o, a), e, t, c in zip(targets, held_error, tolerance, closed)]
    parameters = {"lug_count": count, TREAD_LUGS.main.name: float(fine[best])}
    vibration.update(parameters=parameters,
                     intervals={TREAD_LUGS.main.name: [float(ok.min()), float(ok.max())]},
                     gain={"cause": TREAD_LUGS.name, "kind": TREAD_KIND, "lines": per_line,
                           "rms": rms, "surrogate": {"speeds_mps": speeds,
                                                     "depths_m": depths.tolist()}})
    left = [f"{f['order']} a_{f['axis']} ({f['held_out_error_db']:+.0f} dB)" for f in per_line
            if not f["closed"]]
    rms_left = [f"a_{a} {e['held_out_model_m_s2']:.3f} against {e['held_out_measured_m_s2']:.3f}"
                for a, e in rms.items() if not e["closed"]]
    others = sorted({f["kind"] for f in vibration["unexplained_lines"] if f["kind"] != TREAD_KIND}
                    | {f["kind"] for f in vibration["loud"] if f["kind"] != TREAD_KIND})
    fitted = (f"{TREAD_LUGS.name} ({count} lugs, depth {fine[best] * 1e3:.2g} mm) fitted on the "
              f"even-numbered runs' {TREAD_KIND} segments")
    if not left and not rms_left and not others:
        vibration.update(verdict="explained", cause=TREAD_LUGS.name, reason=(
            f"{fitted}; on the others every line (orders {_orders(sorted({o for o, _ in targets}))}) "
            "and every axis's RMS within the segments' scatter"))
        return
    said = [f"lines left: {', '.join(left)}" if left else "every line closed"]
    if rms_left:
        said.append(f"RMS (m/s^2) left: {', '.join(rms_left)}")
    if others:
        said.append(f"not judged by the fit: {', '.join(others)}")
    vibration["reason"] += (f"; the most likely cause, {fitted}, on the held-out runs: "
                            f"{'; '.join(said)}: what is left has no candidate")


def lug_count_of(orders) -> int | None:
    """The fundamental of a set of line orders: the order n (one of them) the largest
    share of whose multiples up to the highest line lie within one order of a line,
    needing at least two (the line and a harmonic); ties to the lower n.  None without
    one.  A tread of n lugs makes lines at n, 2n, 3n...; a stray line has few
    multiples among the others."""
    orders = sorted(set(int(o) for o in orders))
    best, best_share = None, 0.0
    for n in orders:
        multiples = range(n, orders[-1] + 2, n)
        hits = sum(any(abs(o - k) <= 1 for o in orders) for k in multiples)
        share = hits / len(multiples)
        if hits >= 2 and share > best_share:
            best, best_share = n, share
    return best


def _log_power(power: float) -> float:
    """log10 of a line power, NaN kept (an order the record cannot show), zero floored."""
    return float(np.log10(max(power, 1e-30))) if np.isfinite(power) else np.nan


def _log_tolerance(log_values, floor: float) -> float:
    """The tolerance on a log10 feature: NOISE_Z robust standard errors of the finite
    segments' median, never below floor (chi's rule, on a log scale)."""
    v = np.asarray(log_values, float)
    return max(NOISE_Z * (_summary(v[np.isfinite(v)])["stderr"] or 0.0), floor)


def _straight_schedule(speed_mps: float, fs: float) -> ImuRun:
    """A straight run at one wheel speed for SURROGATE_S at fs (its IMU is replayed)."""
    t = np.arange(0, SURROGATE_S, 1 / fs)
    wheels = WheelSpeeds(np.array([0.0]), np.array([speed_mps]), np.array([speed_mps]))
    return ImuRun(Path(f"straight_{speed_mps:.3f}.csv"), t, np.zeros((len(t), 3)),
                  np.zeros((len(t), 3)), wheels)


def _num(x) -> float | None:
    return None if x is None or not np.isfinite(x) else float(x)


def _rounded(a: np.ndarray) -> list:
    return [[None if not np.isfinite(v) else round(float(v), 1) for v in row] for row in a]


def _orders(orders: list[int]) -> str:
    return ", ".join(str(o) for o in orders)


def render(result: dict) -> str:
    md = [f"# Diagnosis of {result['dataset']} on {result['model']}\n\n",
          f"Floor: {result['floor_note']}.\n\n",
          f"**Verdict: {result['verdict']}**"
          + (f" (cause: {result['cause']})" if result["cause"] else "") + f". {result['reason']}\n\n"]
    for kind, f in result.get("features", {}).items():
        cm, cs = f["measured"], f["simulated"]
        md.append(f"- chi, {kind} ({cm['n']} segments): measured {cm['median']:.2f} "
                  f"(+-{cm['stderr']:.2f}), base model {cs['median']:.2f} "
                  f"(+-{cs['stderr']:.2f}); tolerance {f['tolerance']:.2f}\n")
    if result.get("gain"):
        g = result["gain"]
        md.append(f"- most likely motion cause: {g['cause']} "
                  + ", ".join(f"{k} = {v:.3g}" for k, v in g["parameters"].items())
                  + "; held out: " + "; ".join(
                      f"{k} {e['held_out_model']:.2f} against {e['held_out_measured']:.2f}"
                      for k, e in g["per_kind"].items()) + "\n")
    for name, value in result["parameters"].items():
        interval = result["intervals"].get(name)
        md.append(f"- {name} = {value:.3g}" + (f" (interval {interval[0]:.3g} to "
                                               f"{interval[1]:.3g})" if interval else "") + "\n")
    vib = result.get("vibration")
    if vib:
        md.append(f"\n**Vibration: {vib['verdict']}**. {vib['reason']}\n\n")
        for kind, v in vib["kinds"].items():
            lines = ", ".join(f"{f['order']} on a_{f['axis']} ({_f(f['measured_db'])} dB "
                              f"recorded, {_f(f['simulated_db'])} dB model)"
                              for f in v["lines"]) or "none"
            rms = ", ".join(f"a_{a} {e['measured_m_s2']:.3f} recorded, {e['simulated_m_s2']:.3f} "
                            f"model" for a, e in v["rms"].items())
            md.append(f"- {kind} ({v['segments']} segments): wheel-order lines {lines}; RMS "
                      f"(m/s^2) {rms}\n")
    md.append("\n## Segments\n\n")
    md.append(table(["run", "segment (s)", "kind", "yaw measured", "predicted", "simulated",
                     "chi measured", "chi simulated"],
                    [[r["run"], f"{r['segment'][0]:.1f}-{r['segment'][1]:.1f}", r["kind"],
                      _f(r["yaw_rate_measured_deg_s"]), _f(r["yaw_rate_predicted_deg_s"]),
                      _f(r["yaw_rate_simulated_deg_s"]), _f(r["chi_measured"]),
                      _f(r["chi_simulated"])] for r in result["runs"]]))
    if result["skipped"]:
        md.append("\n## Skipped\n\n")
        md.append(table(["file", "reason"], [[s["file"], s["reason"]] for s in result["skipped"]]))
    md.append("\n## What the readers found\n\n")
    for name, notes in result["notes"].items():
        for note in notes:
            md.append(f"- {note}\n")
    return "".join(md)


def _f(x) -> str:
    return "-" if x is None else f"{x:.2f}"
