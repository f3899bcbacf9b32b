"""The robot and its terrains identified apart, from how the robot turns on each.

Features, per terrain and per half of its runs (alternate runs train, the others are
held out): the median effective-track factor chi of the segments turning in place, of
the tight arcs and of the gentle ones (CLASSES), each scored in units of its scatter:
the robust standard error of the median, never finer than a third of MIN_RELATIVE of
the value (the model's own repeatability).  The centripetal ratio k (a_y = v Omega:
the true speed over the logged one) is measured too (measured_centripetal), and
compared between recording and replays rather than fitted.

The model side comes from a surrogate of each terrain's segments: their commands
grouped (class of turn, direction of turn and of travel), two commands per group at
its segments' quartiles of turn size, run at constant wheel speeds on the implicit
coupling at MOTION_TIMESTEP_S (the yaw rate converges there: within 0.01 % of the
explicit 0.1 ms, scripts/bench/bench_motion_step.py); a segment is scored with the
values interpolated at its own turn size.

A cause set (diagnosis.motion) frees robot parameters, shared by every terrain, and
terrain parameters, one set per terrain; ``fit`` finds them by bounded least squares
over the training half's features of all terrains at once, each parameter under a weak
Gaussian prior (PRIOR_SIGMA_UNIT of its prior's range around its base value), with
intervals from the fit's Jacobian (Laplace; clipped to the prior).
"""

from __future__ import annotations

import dataclasses
import itertools
from typing import Sequence

import mujoco
import numpy as np
from scipy import optimize

from skidsteer.diagnosis import motion
from skidsteer.diagnosis.motion import MOTION_CAUSES, ROBOT, TERRAIN, MotionCause
from skidsteer.features.segments import centripetal_ratio
from skidsteer.robot import Setup, load_model, load_spec, roles
from skidsteer.simulation.drive import DriveGeometry
from skidsteer.simulation.run import runs_from_rest

MOTION_TIMESTEP_S = 1e-3
MOTION_TIRE = {"coupling": "implicit"}
SETTLE_S = 1.0  # the robot at rest on its tires before a surrogate command
# each group's constant command; the last AVERAGE_S are averaged (the yaw rate settles
# within 1.5 s: chi of 3 s runs equals 8 s runs' to 4 digits, measured on the Husky)
SURROGATE_S = 3.0
AVERAGE_S = 1.5
MIN_TURN_DEG_S = 3.0  # slower turns say little about chi (gyro bias ~0.01 deg/s)
MIN_RELATIVE = 0.05  # a feature's tolerance is never finer than 5 % of it
NOISE_Z = 3.0  # the tolerance: NOISE_Z scatters (z = 3 at it)
# a segment turning at less than 1/STUCK_FACTOR of what isotropic Coulomb friction
# gives the robot's geometry (1 + (a/c)^2) did not turn: stuck or stalled
STUCK_FACTOR = 2.0
PRIOR_SIGMA_UNIT = 0.5  # a weak prior: half the prior's range is one sigma
DIFF_STEP = 0.02  # finite differences of 2 % of a prior's range: above the model's noise
# the search stops at 0.1 % of a prior's range or of the error's square (far below the
# features' resolution), after at most MAX_EVALUATIONS Jacobians
XTOL = FTOL = 1e-3
MAX_EVALUATIONS = 15
TURN_KINDS = ("turn_in_place", "arc")
# chi is scored per class of turn: in place, tight arcs and gentle arcs, split where the
# turning radius is TIGHT_ARC_RATIO half-tracks (|d / v| = 1 / 3): the slip a rolling
# wheel takes grows as the arc tightens, so the tire law's shape shows in how chi moves
# between them
TIGHT_ARC_RATIO = 1 / 3
CLASSES = ("turn_in_place", "arc_tight", "arc_gentle")
FEATURES = tuple(f"chi_{c}" for c in CLASSES)


def class_of(row: dict) -> str:
    """A turning segment's class (CLASSES)."""
    if row["kind"] != "arc":
        return row["kind"]
    v, d = (row["left_mps"] + row["right_mps"]) / 2, (row["right_mps"] - row["left_mps"]) / 2
    return "arc_tight" if v == 0 or abs(d / v) >= TIGHT_ARC_RATIO else "arc_gentle"


def of_class(rows: list[dict], cls: str, half: str | None, stuck_chi: float) -> list[dict]:
    kind = "arc" if cls.startswith("arc") else cls
    return [r for r in turning(rows, kind, half, stuck_chi) if class_of(r) == cls]


# ------------------------------------------------------------------ measured features

def turning(rows: list[dict], kind: str, half: str | None = None,
            stuck_chi: float = np.inf) -> list[dict]:
    """Rows of a kind whose predicted yaw rate reaches MIN_TURN_DEG_S and whose chi is
    measured and below stuck_chi, of one half (None: both)."""
    return [r for r in rows if r["kind"] == kind and (half is None or r["half"] == half)
            and r["yaw_rate_predicted_deg_s"] is not None
            and abs(r["yaw_rate_predicted_deg_s"]) >= MIN_TURN_DEG_S
            and r["chi_measured"] is not None and r["chi_measured"] < stuck_chi]


def arcs_for_centripetal(rows: list[dict], half: str | None, stuck_chi: float) -> list[dict]:
    return [r for r in turning(rows, "arc", half, stuck_chi)
            if r.get("a_y_m_s2") is not None and r.get("centripetal_x") is not None]


def straight_for_centripetal(rows: list[dict], half: str | None) -> list[dict]:
    """Straight segments: x about 0, they pin each run's a_y bias."""
    return [r for r in rows if r["kind"] == "straight" and (half is None or r["half"] == half)
            and r.get("a_y_m_s2") is not None and r.get("centripetal_x") is not None]


def median_summary(values) -> dict:
    """Median, robust standard error of the median (1.253 x 1.4826 MAD / sqrt n), n."""
    v = np.asarray([x for x in values if x is not None and np.isfinite(x)], float)
    if len(v) == 0:
        return {"value": None, "stderr": None, "n": 0}
    mad = 1.4826 * float(np.median(np.abs(v - np.median(v))))
    return {"value": float(np.median(v)), "stderr": 1.253 * mad / np.sqrt(len(v)),
            "n": int(len(v))}


def sigma(summary: dict) -> float:
    """A feature's scatter: its standard error, never below MIN_RELATIVE / NOISE_Z of it."""
    return max(summary["stderr"] or 0.0, MIN_RELATIVE * abs(summary["value"]) / NOISE_Z)


def measured_features(rows: list[dict], half: str | None, stuck_chi: float) -> dict:
    """The measured features of a terrain's half (None: every run): chi per class with at
    least one segment (a single segment's scatter is sigma's floor)."""
    out = {}
    for cls in CLASSES:
        s = median_summary([r["chi_measured"] for r in of_class(rows, cls, half, stuck_chi)])
        if s["n"] >= 1:
            out[f"chi_{cls}"] = s
    return out


def measured_centripetal(rows: list[dict], half: str | None, stuck_chi: float,
                         key: str = "") -> dict:
    """The centripetal ratio of a terrain's half from its arcs and straight segments, each
    run with its own a_y bias (features.segments.centripetal_ratio); key "" for the
    recording, "_base" or "_extended" for a replay's.  Not a fit feature: a surrogate's
    steady arcs read it 0.2 higher than replays of the operator's varying commands on
    the same model, so it is compared replay against recording."""
    arcs = [r for r in arcs_for_centripetal(rows, half, stuck_chi)
            if r.get(f"a_y{key}_m_s2") is not None]
    used = arcs + [r for r in straight_for_centripetal(rows, half)
                   if r.get(f"a_y{key}_m_s2") is not None]
    c = centripetal_ratio([r[f"centripetal_x{key}"] for r in used],
                          [r[f"a_y{key}_m_s2"] for r in used], [r["run"] for r in used])
    return c if len(arcs) >= 3 else {"k": None, "stderr": None, "n": len(used)}


def stuck_chi(m: mujoco.MjModel) -> float:
    """STUCK_FACTOR times isotropic Coulomb friction's chi for the model's geometry."""
    position = roles.roles_of(m).wheel_position_m
    a, c = np.mean(np.abs(position[:, 0])), np.mean(np.abs(position[:, 1]))
    return STUCK_FACTOR * (1 + (a / c) ** 2)


# ------------------------------------------------------------------ the surrogate

@dataclasses.dataclass(frozen=True)
class Group:
    kind: str
    left_mps: float  # logged wheel speeds of the surrogate's command
    right_mps: float
    size: float = 0.0  # its turn's size: |d / v| of an arc, |d| of a turn in place


def turn_size(row: dict) -> float:
    """How sharply a segment turns: |d / v| for an arc, |d| in place (d, v: the half
    difference and the mean of the sides' logged speeds)."""
    v, d = (row["left_mps"] + row["right_mps"]) / 2, (row["right_mps"] - row["left_mps"]) / 2
    return abs(d) if row["kind"] != "arc" or v == 0 else abs(d / v)


def plan_groups(rows: list[dict], stuck: float) -> tuple[list[Group], dict[int, tuple]]:
    """The surrogate's commands: a terrain's turning segments (both halves: commands, not
    outcomes) grouped by class, direction of turn and of travel; per group two commands
    at the 25th and 75th percentiles of its segments' turn size (turn_size) at their
    median forward speed (one where they do not differ), between which a segment's
    model values are interpolated (chi moves with an arc's tightness).  Returns the
    commands and, per row index in rows, the indices of its group's commands."""
    groups, group_of = [], {}
    index = {id(r): i for i, r in enumerate(rows)}
    for cls in CLASSES:
        keys = {}
        for r in of_class(rows, cls, None, stuck):
            v, d = (r["left_mps"] + r["right_mps"]) / 2, (r["right_mps"] - r["left_mps"]) / 2
            keys.setdefault((np.sign(d), np.sign(v) if cls != "turn_in_place" else 0),
                            []).append(r)
        kind = "arc" if cls.startswith("arc") else cls
        for (sign_d, _), chosen in sorted(keys.items()):
            sizes = np.array([turn_size(r) for r in chosen])
            v = float(np.median([(r["left_mps"] + r["right_mps"]) / 2 for r in chosen]))
            levels = np.unique(np.round(np.percentile(sizes, [25, 75]), 6))
            members = []
            for size in levels:
                d = sign_d * (size * abs(v) if kind == "arc" else size)
                groups.append(Group(kind, v - d, v + d, float(size)))
                members.append(len(groups) - 1)
            for r in chosen:
                group_of[index[id(r)]] = tuple(members)
    return groups, group_of


def motion_model(setup: Setup, values: dict, settings: dict, edit=None) -> mujoco.MjModel:
    """The model for the motion features: the setup with the motion parameters and
    settings applied (and any further edit of the spec), on the implicit coupling at
    MOTION_TIMESTEP_S."""
    def edited(spec):
        motion.apply(spec, values)
        if edit is not None:
            edit(spec)
    return load_model(setup, timestep=MOTION_TIMESTEP_S, tire={**MOTION_TIRE, **settings},
                      edit=edited)


def simulate_groups(m: mujoco.MjModel, groups: Sequence[Group], nthread: int = 2
                    ) -> np.ndarray:
    """(groups, 2): each group's mean yaw rate (rad/s) and lateral specific force (m/s^2,
    relative to the robot's driving straight at the groups' median forward speed, as
    the recordings' is to their straight driving) over the last AVERAGE_S of
    SURROGATE_S."""
    geometry = DriveGeometry.from_model(m)
    scale = roles.model_numeric(m, "drive.logged_speed_scale", 1.0) / geometry.wheel_radius
    nstep = int(round(SURROGATE_S / m.opt.timestep))
    # the last control row drives straight: its a_y is the IMU's bias
    straight = float(np.median([(g.left_mps + g.right_mps) / 2 for g in groups]))
    commands = [(g.left_mps, g.right_mps) for g in groups] + [(straight, straight)]
    controls = np.zeros((len(commands), nstep, m.nu))
    for g, (left, right) in enumerate(commands):
        controls[g, :, list(geometry.left_actuators)] = scale * left
        controls[g, :, list(geometry.right_actuators)] = scale * right
    runs = runs_from_rest(m, controls, SETTLE_S, nthread)
    tail = int(round(AVERAGE_S / m.opt.timestep))
    bias = runs[-1].accel[-tail:, 1].mean()
    return np.array([[run.gyro[-tail:, 2].mean(), run.accel[-tail:, 1].mean() - bias]
                     for run in runs[:-1]])


def segment_model(row: dict, members: tuple, groups: Sequence[Group], values: np.ndarray,
                  track_m: float) -> tuple[float, float]:
    """A segment's model chi and centripetal ratio, interpolated in turn size between its
    group's two commands (held beyond them)."""
    chi, k = [], []
    for g in members:
        yaw, a_y = values[g]
        group = groups[g]
        chi.append((group.right_mps - group.left_mps) / track_m / yaw if abs(yaw) > 1e-9
                   else np.inf)
        x = (group.left_mps + group.right_mps) / 2 * yaw
        k.append(a_y / x if abs(x) > 1e-12 else np.nan)
    if len(members) == 1:
        return chi[0], k[0]
    sizes = [groups[g].size for g in members]
    size = turn_size(row)
    return float(np.interp(size, sizes, chi)), float(np.interp(size, sizes, k))


def model_features(rows: list[dict], group_of: dict[int, tuple], groups: Sequence[Group],
                   values: np.ndarray, half: str | None, stuck: float, track_m: float) -> dict:
    """The model's features of a half from the groups' simulated (yaw rate, a_y)."""
    out = {}
    index = {id(r): i for i, r in enumerate(rows)}
    for cls in CLASSES:
        chi = [segment_model(r, group_of[index[id(r)]], groups, values, track_m)[0]
               for r in of_class(rows, cls, half, stuck)]
        if chi:
            out[f"chi_{cls}"] = float(np.median(chi))
    return out


# ------------------------------------------------------------------ terrains and scores

@dataclasses.dataclass
class TerrainCase:
    """One terrain as the fit sees it: its setup (robot and floor), its segment rows
    (each with "half"), the surrogate's groups, and its measured features per half."""

    name: str
    setup: Setup
    rows: list[dict]
    stuck_chi: float
    track_m: float
    groups: list[Group] = dataclasses.field(default_factory=list)
    group_of: dict[int, int] = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        self.groups, self.group_of = plan_groups(self.rows, self.stuck_chi)
        self.measured = {half: measured_features(self.rows, half, self.stuck_chi)
                         for half in ("fit", "held_out", None)}

    def z_scores(self, values: np.ndarray, half: str | None) -> dict[str, float]:
        model = model_features(self.rows, self.group_of, self.groups, values, half,
                               self.stuck_chi, self.track_m)
        return {name: (model[name] - f["value"]) / sigma(f)
                for name, f in self.measured[half].items() if name in model}


class Evaluator:
    """The surrogate's simulations, memoised by (terrain, parameter values, settings)."""

    def __init__(self, nthread: int = 2):
        self.nthread = nthread
        self.cache: dict[tuple, np.ndarray] = {}
        self.simulations = 0

    def values(self, case: TerrainCase, params: dict, settings: dict) -> np.ndarray:
        key = (case.name, tuple(sorted((k, round(float(v), 12)) for k, v in params.items())),
               tuple(sorted(settings.items())))
        if key not in self.cache:
            if case.groups:
                m = motion_model(case.setup, params, settings)
                self.cache[key] = simulate_groups(m, case.groups, self.nthread)
                self.simulations += len(case.groups)
            else:
                self.cache[key] = np.zeros((0, 2))
        return self.cache[key]


def rms(z: Sequence[float]) -> float:
    z = np.asarray(list(z), float)
    return float(np.sqrt(np.mean(z ** 2))) if len(z) else 0.0


# ------------------------------------------------------------------ fits

@dataclasses.dataclass
class MotionFit:
    """A cause set fitted on the training half of every terrain; what verdict() reads:
    cause, train_error, held_out_error, score, fitted."""

    causes: tuple[str, ...]
    settings: dict
    robot: dict[str, float]  # fitted robot parameters
    terrain: dict[str, dict[str, float]]  # per terrain, its fitted parameters
    intervals: dict[str, tuple[float, float]]  # "name" or "name@terrain"
    train_error: float
    held_out_error: float
    score: float
    z: dict[str, dict[str, dict[str, float]]]  # half -> terrain -> feature -> z
    removed: float = 0.0
    implausible: str | None = None  # why a fitted value is impossible for the robot

    @property
    def cause(self) -> str:
        return " + ".join(self.causes) if self.causes else "base model"

    @property
    def fitted(self) -> list[str]:
        return list(self.intervals)

    def parameters_for(self, terrain: str) -> dict[str, float]:
        return {**self.robot, **self.terrain.get(terrain, {})}


def settings_of(causes: Sequence[MotionCause]) -> dict:
    out = {}
    for c in causes:
        out.update(c.settings)
    return out


def free_parameters(causes: Sequence[MotionCause], terrains: Sequence[str]
                    ) -> list[tuple[motion.MotionParameter, str | None]]:
    """(parameter, terrain or None for the robot's) for every value the fit frees."""
    out, seen = [], set()
    for c in causes:
        for p in c.parameters:
            for t in ([None] if p.owner == ROBOT else terrains):
                if (p.name, t) not in seen:
                    seen.add((p.name, t))
                    out.append((p, t))
    return out


def fit(causes: Sequence[MotionCause], cases: Sequence[TerrainCase], evaluate: Evaluator,
        base: dict[str, dict[str, float]], fixed: dict[str, dict[str, float]] | None = None,
        train: str = "fit", held: str = "held_out", settings: dict | None = None,
        warm: dict[str, float] | None = None) -> MotionFit:
    """Fits the causes' parameters on the `train` half of every case, judged on `held`.
    base: per terrain, the model's own values (motion.base_values); fixed: per terrain,
    values set and not fitted (a robot identified elsewhere); settings: made besides the
    causes' own (a law a robot identified elsewhere has); warm: values to start the
    search from ("name" or "name@terrain"; the rest start at their base values)."""
    fixed = fixed or {}
    settings = {**(settings or {}), **settings_of(causes)}
    free = free_parameters(causes, [c.name for c in cases])

    def params_at(u: np.ndarray) -> dict[str, dict[str, float]]:
        out = {c.name: dict(fixed.get(c.name, {})) for c in cases}
        for (p, terrain), ui in zip(free, u):
            value = float(p.prior.from_unit(ui))
            for c in cases:
                if terrain is None or terrain == c.name:
                    out[c.name][p.name] = value
        return out

    def z_of(u: np.ndarray, half: str) -> dict[str, dict[str, float]]:
        params = params_at(u)
        return {c.name: c.z_scores(evaluate.values(c, params[c.name], settings), half)
                for c in cases}

    u0 = np.array([np.clip(p.prior.to_unit(base[terrain or cases[0].name][p.name]), 0, 1)
                   for p, terrain in free])

    def residuals(u: np.ndarray) -> np.ndarray:
        z = z_of(u, train)
        prior = (u - u0) / PRIOR_SIGMA_UNIT
        return np.concatenate([[v for t in z.values() for v in t.values()], prior])

    intervals = {}
    u = u0
    if len(free):
        start = np.array([np.clip(p.prior.to_unit((warm or {}).get(
            p.name if terrain is None else f"{p.name}@{terrain}", p.prior.from_unit(u))), 0, 1)
            for (p, terrain), u in zip(free, u0)])
        solution = optimize.least_squares(residuals, start, bounds=(0.0, 1.0),
                                          diff_step=DIFF_STEP, x_scale=1.0, xtol=XTOL,
                                          ftol=FTOL, max_nfev=MAX_EVALUATIONS * (len(free) + 1))
        u = solution.x
        intervals = _intervals(solution, free)
    z = {half: z_of(u, half) for half in (train, held)}
    params = params_at(u)
    robot = {p.name: params[cases[0].name][p.name] for p, t in free if t is None}
    terrain = {c.name: {p.name: params[c.name][p.name] for p, t in free if t == c.name}
               for c in cases}
    n_train = max(1, sum(len(v) for v in z[train].values()))
    train_error = rms(v for t in z[train].values() for v in t.values())
    held_error = rms(v for t in z[held].values() for v in t.values())
    return MotionFit(tuple(c.name for c in causes), settings, robot, terrain, intervals,
                     train_error, held_error, score(held_error, len(free), n_train),
                     {"fit" if h == train else "held_out": v for h, v in z.items()})


PARAMETER_PENALTY = 2.0  # AIC, as the accelerometer diagnosis scores its fits


def score(error: float, n_params: int, n_train: int) -> float:
    return error ** 2 + PARAMETER_PENALTY * n_params / n_train


def _intervals(solution, free) -> dict[str, tuple[float, float]]:
    """Each free parameter's interval: +-2 sigma of the Laplace approximation at the
    solution (J^T J of residuals in scatter units, prior included), clipped to its
    prior's bounds; a parameter the data leave unconstrained spans about its prior."""
    jac = solution.jac
    try:
        cov = np.linalg.pinv(jac.T @ jac)
    except np.linalg.LinAlgError:
        cov = np.full((len(free), len(free)), np.inf)
    out = {}
    for i, (p, terrain) in enumerate(free):
        spread = 2 * np.sqrt(max(cov[i, i], 0.0))
        low = p.prior.from_unit(max(0.0, solution.x[i] - spread))
        high = p.prior.from_unit(min(1.0, solution.x[i] + spread))
        out[p.name if terrain is None else f"{p.name}@{terrain}"] = (float(low), float(high))
    return out


def base_fit(cases: Sequence[TerrainCase], evaluate: Evaluator, base) -> MotionFit:
    """The base model scored as a fit of nothing."""
    return fit((), cases, evaluate, base)


MAX_ROBOT_CAUSES = 2  # robot causes fitted together, every combination up to this size
MAX_TERRAIN_CAUSES = 2


def select(cases: Sequence[TerrainCase], evaluate: Evaluator, base,
           candidates: Sequence[str] | None = None, progress=None,
           implausible=None) -> list[MotionFit]:
    """The robot's causes first: every combination of up to MAX_ROBOT_CAUSES of them is
    fitted (a greedy path misses a pair whose members do little alone, such as a law
    and the parameter it needs); the one with the lowest training score (training
    error squared plus PARAMETER_PENALTY per fitted value over the training features)
    is kept; then the terrains' causes are added on top by forward selection, each kept
    only when it lowers the training score.  The robot comes first because one value
    shared by every terrain explains what they have in common at a fraction of the cost
    of one value per terrain.  A fit `implausible` (fit -> reason or None) rejects is
    not kept.  Returns every fit made, by held-out score (the verdict's order)."""
    names = [n for n in (candidates or MOTION_CAUSES) if _applies(MOTION_CAUSES[n], cases)]
    fits: dict[tuple[str, ...], MotionFit] = {}
    n_train = max(1, sum(len(c.measured["fit"]) for c in cases))

    def run(combo: tuple[str, ...]) -> MotionFit:
        key = tuple(sorted(combo))
        if key not in fits:
            # start from what the fits of its parts found
            warm = {}
            for part in fits.values():
                if set(part.causes) < set(combo):
                    warm.update({k: v for k, v in part.robot.items()})
                    warm.update({f"{k}@{t}": v for t, vs in part.terrain.items()
                                 for k, v in vs.items()})
            fits[key] = fit([MOTION_CAUSES[n] for n in combo], cases, evaluate, base,
                            warm=warm)
            if implausible is not None:
                fits[key].implausible = implausible(fits[key])
            if progress:
                progress(fits[key])
        return fits[key]

    robot = [n for n in names if MOTION_CAUSES[n].owner == ROBOT]
    current = run(())
    trials = [run(combo) for size in range(1, MAX_ROBOT_CAUSES + 1)
              for combo in itertools.combinations(robot, size)]
    kept = [f for f in trials if not f.implausible]
    if kept:
        best = min(kept, key=lambda f: training_score(f, n_train))
        if training_score(best, n_train) < training_score(current, n_train):
            current = best
    pool = [n for n in names if MOTION_CAUSES[n].owner == TERRAIN]
    for _ in range(MAX_TERRAIN_CAUSES):
        trials = [run(current.causes + (n,)) for n in pool if n not in current.causes]
        trials = [f for f in trials if not f.implausible]
        if not trials:
            break
        best = min(trials, key=lambda f: training_score(f, n_train))
        if training_score(best, n_train) >= training_score(current, n_train):
            break
        current = best
    return sorted((f for f in fits.values() if f.causes), key=lambda f: f.score)


def training_score(f: MotionFit, n_train: int) -> float:
    return score(f.train_error, len(f.intervals), n_train)


def _applies(cause: MotionCause, cases: Sequence[TerrainCase]) -> bool:
    try:
        spec = load_spec(cases[0].setup)
        motion.apply(spec, {p.name: p.prior.value for p in cause.parameters})
        return True
    except (motion.NotApplicable, ValueError):
        return False

