"""``skidsteer diagnose`` on real recordings: one robot, one or several terrains.

robot -> recordings of each terrain (data.terrains) -> segments and their measured
features (features.segments) -> is each terrain rigid (diagnosis.ground) -> the robot
and the rigid terrains identified apart (diagnosis.identify) -> one verdict
(diagnosis.verdict's rules) -> replays of every run on the base and the extended model
-> leave-one-terrain-out -> the extended robot written (diagnosis.extended_robot).

Alternate runs of each terrain (in name order: the first, third, ...) train; the
others are held out.  A terrain that is not one of the robot's floors is an unknown
rigid terrain until its logs say it is deformable: its friction is fitted like a
known floor's.  Deformable terrains move no robot parameter.
"""

from __future__ import annotations

import time
from typing import Sequence

import numpy as np
from tqdm import tqdm

from skidsteer.data.terrains import read_terrain, terrain_paths
from skidsteer.diagnosis import ground, identify, lines, motion
from skidsteer.diagnosis.verdict import Z_CONSISTENT, Z_EXPLAINED, verdict
from skidsteer.experiments.replay import replay
from skidsteer.features.segments import (Segment, lateral_acceleration, run_segments,
                                         run_yaw_features, segment_vibration, settled_window)
from skidsteer.robot import Setup, load_model, load_robot, load_spec, roles
from skidsteer.simulation.backends import LocalBackend
from skidsteer.simulation.drive import DriveGeometry

HALVES = ("fit", "held_out")


# ------------------------------------------------------------------ rows

def segment_rows(runs, track_m: float) -> list[dict]:
    """One row per segment of the runs with wheel speeds: kind, logged command, the
    measured yaw rates and chi, the centripetal ratio's inputs (mean v Omega and a_y),
    the motor current, and the half (alternate runs)."""
    rows = []
    usable = [r for r in runs if r.wheels is not None]
    for index, run in enumerate(usable):
        for s in run_segments(run):
            yaw = run_yaw_features(s, run, track_m)
            a_y = lateral_acceleration(s, run)
            measured = yaw["yaw_rate_deg_s"]
            rows.append({
                "run": run.path.name, "half": HALVES[index % 2], "kind": s.kind,
                "segment_s": [s.start_s, s.end_s], "left_mps": s.left_mps,
                "right_mps": s.right_mps, "yaw_rate_measured_deg_s": measured,
                "yaw_rate_predicted_deg_s": yaw["yaw_rate_predicted_deg_s"],
                "chi_measured": yaw["chi"],
                "centripetal_x": _centripetal_x(s, run), "a_y_m_s2": a_y,
                "current_a": _segment_current(run, s)})
    return rows


def _centripetal_x(segment, run) -> float | None:
    """The mean over the segment's settled window of v_logged(t) Omega(t) (m/s^2), the
    product sample by sample: where an operator slows as the turn tightens, the product
    of the means is not the mean of the product that a_y measures."""
    window = settled_window(segment, run.time_s)
    if not window.any():
        return None
    left, right = run.wheels.at(run.time_s[window])
    return float(np.mean((left + right) / 2 * run.gyro[window, 2]))


def _segment_current(run, segment) -> float | None:
    """The mean motor current (both sides, A) over the segment's settled window, the
    logged samples held between messages."""
    window = settled_window(segment, run.time_s)
    current = run.wheels.current_at(run.time_s[window])
    return None if current is None or not window.any() else float(np.mean(current))


def add_simulated(rows: list[dict], runs, simulated, track_m: float, key: str,
                  radius_m: float) -> None:
    """Adds each row's simulated yaw rate and chi (key: "base" or "extended") from the
    replays of its run, and a straight row's simulated vibration ("vibration_KEY")."""
    by_name = {run.path.name: sim for run, sim in zip(runs, simulated)}
    for r in rows:
        sim = by_name.get(r["run"])
        if sim is None:
            continue
        seg = _segment(r)
        yaw = run_yaw_features(seg, sim, track_m)
        r[f"yaw_rate_{key}_deg_s"] = yaw["yaw_rate_deg_s"]
        r[f"chi_{key}"] = yaw["chi"]
        r[f"a_y_{key}_m_s2"] = lateral_acceleration(seg, sim)
        r[f"centripetal_x_{key}"] = _centripetal_x(seg, sim)
        if r["kind"] == lines.KIND:
            r[f"vibration_{key}"] = segment_vibration(seg, sim, radius_m)


def _segment(row: dict) -> Segment:
    return Segment(row["run"], row["segment_s"][0], row["segment_s"][1], row["kind"],
                   row["left_mps"], row["right_mps"])


def add_vibration(rows: list[dict], runs, radius_m: float) -> None:
    """Adds each straight row's recorded vibration (features.segments)."""
    by_name = {run.path.name: run for run in runs}
    for r in rows:
        if r["kind"] == lines.KIND and r["run"] in by_name:
            r["vibration"] = segment_vibration(_segment(r), by_name[r["run"]], radius_m)


# ------------------------------------------------------------------ terrains

def terrain_setup(robot, model: str, name: str) -> tuple[Setup, str | None]:
    """The setup a terrain runs on: the robot's floor of that name (any case), else its
    default floor; and the floor's name (None: not one of the robot's floors)."""
    floor = next((f for f in robot.floors if f.lower() == name.lower()), None)
    return (Setup(robot=str(model), build=robot.default_build,
                  floor=floor or robot.default_floor), floor)


def replay_all(model, runs, nthread: int, bar=None) -> list:
    backend = LocalBackend(nthread)
    out = []
    try:
        for sim in backend.map(replay, [(model, r) for r in runs]):
            out.append(sim)
            if bar is not None:
                bar.update(1)
    finally:
        backend.close()
    return out


def diagnose_terrains(paths: Sequence, model: str = "husky_a200", progress: bool = True,
                      nthread: int = 2, candidates: Sequence[str] | None = None,
                      leave_one_out: bool = True, with_lines: bool = True) -> dict:
    """Diagnoses the recordings of one robot on the terrains at `paths` (see the module);
    returns the result (diagnosis.json's content, and under "_named" the named fit, for
    the identified robot) without writing anything.  with_lines: also the vibration's
    wheel-order lines (diagnosis.lines)."""
    started = time.perf_counter()
    robot = load_robot(model)
    unknown = sorted(set(candidates or ()) - set(motion.MOTION_CAUSES))
    if unknown:
        raise ValueError(f"unknown motion cause(s) {unknown}: the candidates are "
                         f"{sorted(motion.MOTION_CAUSES)}")
    cases, terrains, evidence, notes, skipped = [], [], {}, {}, []
    track = None
    for path in terrain_paths(paths):
        name = path.name if path.is_dir() else path.parent.name
        setup, floor = terrain_setup(robot, model, name)
        m = identify.motion_model(setup, {}, {})
        geometry = DriveGeometry.from_model(m)
        track, radius = 2 * geometry.half_track, geometry.wheel_radius
        terrain = read_terrain(path, track)
        rows = segment_rows(terrain.data.runs, track)
        terrains.append((terrain, setup, floor, rows, identify.stuck_chi(m)))
        skipped += list(terrain.data.skipped) + [
            {"file": str(r.path), "reason": f"{r.path.name}: no wheel speeds, nothing to "
             "replay"} for r in terrain.data.runs if r.wheels is None]
        notes.update({r.path.name: list(r.notes) for r in terrain.data.runs})
    # the rigid reference of rolling current: the robot's floors among the terrains, or
    # what the identified robot carries
    declared = [ground.rolling_current(rows) for _, _, floor, rows, _ in terrains
                if floor is not None]
    declared = [c for c in declared if c is not None]
    rigid_current = (float(np.median(declared)) if declared
                     else robot.identified.get("rolling_current_a"))
    for terrain, setup, floor, rows, stuck in terrains:
        evidence[terrain.name] = ground.judge(rows, stuck, rigid_current)
        if not evidence[terrain.name]["deformable"]:
            cases.append(identify.TerrainCase(terrain.name, setup, rows, stuck, track))
    base = {c.name: motion.base_values(load_spec(c.setup)) for c in cases}
    identified = bool(robot.identified.get("parameters"))
    allowed = [n for n in (candidates or motion.MOTION_CAUSES)
               if not (identified and motion.MOTION_CAUSES[n].owner == motion.ROBOT)]
    evaluate = identify.Evaluator(nthread)
    result = {"model": str(model), "terrains": {}, "skipped": skipped, "notes": notes,
              "robot_identified_before": robot.identified or None,
              "rigid_rolling_current_a": rigid_current}
    fits, verdict_text = [], ("unexplained", None, "no rigid terrain to fit a motion cause on")
    base_fit = None
    if cases:
        base_fit = identify.base_fit(cases, evaluate, base)
        if base_error(base_fit) > Z_CONSISTENT:  # else no cause is needed: none is fitted
            bar = tqdm(desc="fits", unit="fit", disable=not progress)
            fits = identify.select(cases, evaluate, base, allowed,
                                   progress=lambda f: bar.update(1),
                                   implausible=lambda f: implausible(f, cases))
            bar.close()
        verdict_text = judge_fits(base_fit, fits, cases)
    result["motion"] = motion_summary(base_fit, fits, verdict_text, cases, evaluate)
    named = verdict_text[1]
    unknown = {t.name: identify_terrain(c, named, evaluate, base)
               for t, _, floor, _, _ in terrains if floor is None
               for c in cases if c.name == t.name}
    # replays: every run on the base model, the rigid terrains' on the extended one too
    total = sum(len([r for r in t.data.runs if r.wheels is not None])
                * (2 if named and t.name in base else 1) for t, *_ in terrains)
    bar = tqdm(total=total, desc="replay", unit="run", disable=not progress)
    for terrain, setup, floor, rows, stuck in terrains:
        runs = [r for r in terrain.data.runs if r.wheels is not None]
        add_vibration(rows, runs, radius)
        add_simulated(rows, runs, replay_all(identify.motion_model(setup, {}, {}), runs,
                                             nthread, bar), track, "base", radius)
        if named and terrain.name in base:
            m = identify.motion_model(setup, named.parameters_for(terrain.name), named.settings)
            add_simulated(rows, runs, replay_all(m, runs, nthread, bar), track, "extended",
                          radius)
        result["terrains"][terrain.name] = {
            "path": str(terrain.path), "floor": floor, "setup_floor": setup.floor,
            "runs": len(runs), "rows": rows, "ground": evidence[terrain.name],
            "chi": chi_table(rows, stuck), "identified": unknown.get(terrain.name),
            "centripetal_ratio": {
                half or "all": {key or "measured": identify.measured_centripetal(
                    rows, half, stuck, key and f"_{key}") for key in ("", "base", "extended")}
                for half in (*HALVES, None)}}
    bar.close()
    if with_lines:
        rigid = [(t.name, setup, rows) for t, setup, _, rows, _ in terrains
                 if t.name in base]
        fs = next(r.sample_rate_hz for t, *_ in terrains for r in t.data.runs)
        values = {c.name: named.parameters_for(c.name) if named else {} for c in cases}
        result["lines"] = lines.diagnose(rigid, fs, radius, nthread, values,
                                         named.settings if named else {})
    for *_, rows, _ in terrains:
        for r in rows:
            for key in ("vibration", "vibration_base", "vibration_extended"):
                v = r.pop(key, None)
                if key == "vibration" and v is not None and v["rms_m_s2"] is not None:
                    r["accel_rms_m_s2"] = v["rms_m_s2"]
    if leave_one_out and named and len(cases) >= 2:
        result["leave_one_terrain_out"] = leave_one_terrain_out(named, cases, evaluate, base)
    result["models"] = {  # what simulated each row's yaw_rate_KEY_deg_s and chi_KEY
        "base": {"robot": str(model), "timestep_s": identify.MOTION_TIMESTEP_S,
                 "tire": dict(identify.MOTION_TIRE), "parameters": {}},
        "extended": None if named is None else {
            "robot": str(model), "timestep_s": identify.MOTION_TIMESTEP_S,
            "tire": {**identify.MOTION_TIRE, **named.settings},
            "parameters": {"robot": named.robot, "terrain": named.terrain}}}
    result["simulations"] = evaluate.simulations
    result["wall_time_s"] = round(time.perf_counter() - started, 1)
    result["_named"] = named
    return result


def chi_table(rows: list[dict], stuck: float) -> dict:
    """Per kind and half: the measured, base and extended median chi of the turning
    segments (replays)."""
    out = {}
    for kind in identify.TURN_KINDS:
        for half in (*HALVES, None):
            segs = identify.turning(rows, kind, half, stuck)
            if not segs:
                continue
            entry = {"n": len(segs)}
            for key in ("measured", "base", "extended"):
                s = identify.median_summary([r.get(f"chi_{key}") for r in segs])
                if s["n"]:
                    entry[key] = s["value"]
                    if key == "measured":
                        entry["stderr"] = s["stderr"]
            out[f"{kind}/{half or 'all'}"] = entry
    return out


# ------------------------------------------------------------------ the verdict

def judge_fits(base_fit, fits, cases) -> tuple[str, object, str]:
    """verdict_rules.verdict on the fits' RMS z errors.  An implausible fit (a fitted
    value the robot cannot have) is not named; a fit that adds causes to the selected
    one is not its rival (it explains the same with more), so the rivals are the fits
    that do not contain it."""
    n_train = max(1, sum(len(c.measured["fit"]) for c in cases))
    noise = identify.rms(min(1.0, (f["stderr"] or 0) / identify.sigma(f))
                         for c in cases for f in c.measured[None].values())
    base_all = base_error(base_fit)
    plausible = sorted((f for f in fits if not f.implausible), key=lambda f: f.score)
    for f in plausible:
        f.removed = gain(base_fit.held_out_error, f.held_out_error, noise)
    if plausible:
        best = plausible[0]
        plausible = [best] + [f for f in plausible[1:]
                              if not set(best.causes) <= set(f.causes)]
    name, named, reason = verdict(base_all, base_fit.held_out_error, plausible, noise,
                                  base_train=base_fit.train_error, n_train=n_train,
                                  scale="the segments' scatter")
    # two fits that each explain the held-out runs and that the rules cannot tell apart
    tied = (named is None and len(plausible) >= 2
            and all(f.held_out_error <= Z_EXPLAINED for f in plausible[:2]))
    proposal = next_recording(plausible[:2], cases) if tied else None
    return name, named, reason + (f"; {proposal}" if proposal else "")


def next_recording(contenders, cases) -> str | None:
    """What recording would tell two contending fits apart, where the rule is known: a
    logged-speed scale is implausible once it puts the rims past the robot's top speed,
    so wheels logged faster than top speed / scale rule it out."""
    scaled = [f for f in contenders if f.robot.get("logged_speed_scale")]
    if len(contenders) < 2 or len(scaled) != 1:
        return None
    scale = scaled[0].robot["logged_speed_scale"]
    top, fastest = speed_limits(cases)
    if not np.isfinite(top) or scale <= 1:
        return None
    return (f"runs with the wheels logged above {top / scale:.2f} m/s (these reach "
            f"{fastest:.2f}) would tell them apart: there {scaled[0].cause}'s logged-speed "
            f"scale {scale:.2f} puts the rims past the robot's top speed, {top:.2f} m/s")


def base_error(base_fit) -> float:
    """The base model's RMS z over every feature of both halves."""
    return identify.rms(v for half in base_fit.z.values() for t in half.values()
                        for v in t.values())


def gain(base_held: float, held: float, noise: float) -> float:
    excess = base_held ** 2 - noise ** 2
    return 0.0 if excess <= 0 else float(min(1.0, (base_held ** 2 - held ** 2) / excess))


def speed_limits(cases) -> tuple[float, float]:
    """The robot's top speed (skidsteer.drive.top_speed_mps; inf without) and the fastest
    wheel speed the recordings log, m/s."""
    top = roles.model_numeric(load_model(cases[0].setup), "drive.top_speed_mps", np.inf)
    fastest = max(max(abs(r["left_mps"]), abs(r["right_mps"])) for c in cases for r in c.rows)
    return top, fastest


def implausible(fit, cases) -> str | None:
    """Why a fit's values are impossible for the robot, or None: a logged-speed scale
    that puts the rims beyond the robot's top speed (skidsteer.drive.top_speed_mps)."""
    scale = fit.robot.get("logged_speed_scale")
    if scale is None:
        return None
    top, fastest = speed_limits(cases)
    if scale * fastest > top:
        return (f"its logged-speed scale {scale:.2f} puts the rims at {scale * fastest:.2f} "
                f"m/s on the fastest logged command ({fastest:.2f} m/s), beyond the robot's "
                f"top speed {top:.2f} m/s")
    return None


def motion_summary(base_fit, fits, verdict_text, cases, evaluate) -> dict:
    verdict_name, named, reason = verdict_text
    return {
        "verdict": verdict_name, "cause": named.cause if named else None, "reason": reason,
        "features": {c.name: {h or "all": c.measured[h] for h in (*HALVES, None)}
                     for c in cases},
        "base": None if base_fit is None else _fit_json(base_fit),
        "fits": [_fit_json(f) for f in fits],
        "named": None if named is None else _fit_json(named)}


def _fit_json(f) -> dict:
    return {"cause": f.cause, "settings": f.settings, "robot": f.robot, "terrain": f.terrain,
            "intervals": {k: list(v) for k, v in f.intervals.items()},
            "train_error": f.train_error, "held_out_error": f.held_out_error,
            "score": f.score, "removed": f.removed, "z": f.z,
            "implausible": getattr(f, "implausible", None)}


def identify_terrain(case, named, evaluate, base) -> dict:
    """An unknown rigid terrain's friction (TERRAIN_CAUSES) fitted on its training half
    with the robot as diagnosed (named's robot values and law, or the model's own), and
    how its held-out half compares with and without it."""
    robot = dict(named.robot) if named else {}
    settings = dict(named.settings) if named else {}
    causes = [motion.MOTION_CAUSES[n] for n in TERRAIN_CAUSES]
    fitted = identify.fit(causes, [case], evaluate, base, fixed={case.name: robot},
                          settings=settings)
    values = fitted.terrain[case.name]
    return {"parameters": values,
            "intervals": {k.split("@")[0]: list(v) for k, v in fitted.intervals.items()},
            "train_error": fitted.train_error, "held_out_error": fitted.held_out_error,
            "held_out_z": fitted.z["held_out"][case.name],
            "robot": robot, "settings": settings}


TERRAIN_CAUSES = ("friction_levels", "lateral_friction")


# ------------------------------------------------------------------ leave one terrain out

def leave_one_terrain_out(named, cases, evaluate, base) -> list[dict]:
    """For each rigid terrain: the named causes' robot parameters fitted on the other
    terrains alone; the left-out terrain predicted with its terrain parameters at their
    base values (no fit), and with them fitted on its training half (judged on its
    held-out half)."""
    causes = [motion.MOTION_CAUSES[n] for n in named.causes]
    robot_causes = [c for c in causes if c.owner == motion.ROBOT]
    terrain_causes = [c for c in causes if c.owner == motion.TERRAIN] or [
        motion.MOTION_CAUSES["lateral_friction"]]
    out = []
    for left in cases:
        others = [c for c in cases if c is not left]
        robot = identify.fit(robot_causes + [c for c in causes if c not in robot_causes],
                             others, evaluate, base)
        fixed = {left.name: dict(robot.robot)}
        settings = identify.settings_of(causes)
        values = evaluate.values(left, {**base[left.name], **robot.robot}, settings)
        no_fit = {h or "all": identify.model_features(
            left.rows, left.group_of, left.groups, values, h, left.stuck_chi, left.track_m)
            for h in (*HALVES, None)}
        fitted = identify.fit(terrain_causes, [left], evaluate, base, fixed=fixed,
                              settings=settings)
        with_fit = identify.model_features(
            left.rows, left.group_of, left.groups,
            evaluate.values(left, {**base[left.name], **robot.robot,
                                   **fitted.terrain[left.name]}, settings),
            "held_out", left.stuck_chi, left.track_m)
        out.append({"terrain": left.name, "robot_from": [c.name for c in others],
                    "robot": robot.robot, "terrain_fitted": fitted.terrain[left.name],
                    "measured": {h or "all": {k: v["value"] for k, v in left.measured[h].items()}
                                 for h in (*HALVES, None)},
                    "no_fit": no_fit, "fitted_held_out": with_fit})
    return out
