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
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from skidsteer.data.files import write_json, write_text
from skidsteer.data.imu import ImuDataset, ImuRun, read_bag, read_imu_folder
from skidsteer.diagnosis.motion import MOTION_CAUSES
from skidsteer.features.segments import Segment, segments, yaw_features
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
    rows = []
    for index, (run, sim) in enumerate(zip(usable, simulated)):
        for seg in run_segments(run):
            measured = run_yaw_features(seg, run, track)
            model_side = run_yaw_features(seg, sim, track)
            rows.append({"run": run.path.name, "segment": [seg.start_s, seg.end_s],
                         "kind": seg.kind, "left_mps": seg.left_mps, "right_mps": seg.right_mps,
                         "yaw_rate_measured_deg_s": measured["yaw_rate_deg_s"],
                         "yaw_rate_predicted_deg_s": measured["yaw_rate_predicted_deg_s"],
                         "yaw_rate_simulated_deg_s": model_side["yaw_rate_deg_s"],
                         "chi_measured": measured["chi"], "chi_simulated": model_side["chi"],
                         "half": "fit" if index % 2 == 0 else "held_out"})
    result = _verdict(rows, floor is not None, floor_note, setup, timestep)
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
