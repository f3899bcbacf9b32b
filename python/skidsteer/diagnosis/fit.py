"""Diagnose: which candidate cause explains what the simulation gets wrong, and how well.

1. The base model simulates every command group of the dataset
   (comparison.simulate_groups); its error is the RMS z-score of the features
   against the trials' spread (comparison.Comparison).
2. The groups are split: every third command (sorted by setup and command,
   starting with the second) is held out, unless the base model shows no
   discrepancy there and does on more commands (then the weakest of those is
   held out: split); the rest trains.  With fewer than three commands the last
   trial of each is held out, and no cause is named (they repeat trained commands).
3. Each candidate cause (diagnosis.causes) is fitted on the training runs:
   its main parameter over a grid across its prior (one batch), then a bounded
   Brent search between the best grid point's neighbours (scipy.optimize).  A
   residual on spectral features, not on the raw signal: a time-series residual
   has phase-wrapping local minima (PLATFORM-NOTES, sysid).
   Causes with a random geometry (a rough floor, the phases of eccentric
   wheels) also choose their realisation on the training runs: the measured
   robot has one, and it matters as much as the parameter.
4. The best REFINE_CONTENDERS causes, and any whose coarse design (Cause.design)
   fits the training runs better than its main fit, then have every parameter
   fitted (both frame stiffnesses and the damping, the roughness's RMS and
   correlation length, ...; fit_every_parameter: a bounded pattern search from
   the main fit or a coarse design's best point where a cause has one, and again
   from the fit's mirror image where a cause has one), each with an interval from
   the error's profile through the fit, read against the fit's own start-to-start
   scatter (with_start_scatter, interval_bound).
5. Each fit is scored on the held-out runs, plus an AIC-style penalty per fitted
   parameter (and ln(REALISATIONS) for a chosen realisation); the two best are
   also simulated together (fit_pair); the verdict follows VERDICT RULES below.
   The errors the verdict reads (the base model's, the held-out ones) are medians
   over STARTS starts of each command: one simulation is one draw of the model's
   run-to-run scatter, as one trial is of the robot's.

``diagnose_observed`` does all of it on measured runs already reduced to
features; reports.diagnosis reads a dataset into it and writes the outputs.
"""

from __future__ import annotations

import dataclasses
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, NamedTuple, Sequence

import numpy as np
from scipy import optimize

from skidsteer.data.dataset import Group
from skidsteer.diagnosis import causes as cause_registry
from skidsteer.diagnosis.comparison import (TRIALS_SCALE, Comparison, Observed, Simulated,
                                            model_factory, require_spread, simulate_groups)
from skidsteer.diagnosis.next_command import (CONFIRM, SEPARATE, BaseModel,
                                              confirmation_note, proposal_note,
                                              separating_commands, undecided_pair)
from skidsteer.simulation.sensor_chain import SensorChain

GRID_POINTS = 5  # across the prior, at the centres of 5 equal slices (log or linear)
# bounded Brent between the best grid point's neighbours, run until it brackets the
# minimum to REFINE_TOL_UNIT (in prior coordinates: 1 % of the prior's (log) range; for
# slip's 0.003-1 a factor 1.06, finer than the narrowest valley measured, 14 % wide on
# draw 1121).  A fixed budget of 4 steps stopped short of it: on draw 1166 the 4th step
# left the slip fit at 0.0088 on the valley's shoulder, 1.36x the truth (stop 39).
REFINE_TOL_UNIT = 0.01
# a guard, not a budget: on 900 made-up objectives over the grid's brackets (smooth,
# rippled, stepped with noise; scipy's bounded method at this tolerance) Brent took 5-12
# steps, median 6-8
REFINE_MAX_STEPS = 25
# the steps a progress bar plans per Brent search (the made-up objectives' median; the
# main job's one-parameter fits took 7-10); the bar's total is a plan, not a bound
REFINE_STEPS_PLANNED = 8
# every parameter's fit (refine_parameters): probe steps in prior coordinates, a coarse
# pass then a fine one (assumed: a quarter of the prior finds the basin a grid of 5 on
# the main parameter would, a tenth resolves it to about the recovery factors' width)
REFINE_STEPS = (0.25, 0.1)
# the profile (the last pass's probes, REFINE_STEPS[-1] either side of every parameter) is
# taken again around a probe that fits better than the point it was taken around, at most
# this many times: the fit is the best point evaluated, and only a profile around it
# bounds its intervals.  Before it the best point could be such a probe, with no probe
# of its own: its intervals ran to the prior's bounds for want of a probe, not for want
# of data (issue 21's draw 1205, fitted again: the floor's RMS 0.02-2 mm, one point on
# its profile; draw 1207's row shows all three frame parameters so).  Assumed: 3 moves
# (each 2 x parameters points) bound the cost; past them an interval may still be open
# for want of a probe, and the fit says so (Fit.unprobed)
PROFILE_MOVES = 3
# a value this close to a prior's bound (in prior coordinates) is at it (unprobed_sides):
# refine_parameters clips its probes to the bounds exactly, so any margin above rounding
# error does
UNIT_EDGE = 1e-9
# the causes whose every parameter is fitted: the best REFINE_CONTENDERS by their
# main-parameter fit's score (assumed: the verdict weighs the best against the
# runner-up; refining the rest would cost a fit each and could not change it unless a
# third cause jumped two places)
REFINE_CONTENDERS = 2
FIT_SEED = 0  # the first realisation (rough floor, wheel phases) a fit simulates
# causes with a random geometry: the realisations tried (seeds FIT_SEED...), the one
# fitting the training runs best is kept (assumed: 8 draws cover the phases of four
# wheels coarsely; each costs one simulation of every command)
REALISATIONS = 8
# VERDICT RULES.  The error is the RMS z-score of the features; a simulation as
# close to the measurements as one trial to another scores ~1 to ~1.4 (the
# simulation is one more trial).
Z_CONSISTENT = 2.0  # base error at or below: "no-discrepancy"
# a named cause whose held-out error comes down to within 3 sigma RMS "explains" the
# data; one that stays above it but removes most of the discrepancy (MIN_GAIN) is named
# as the most likely cause, "partly-explained" (an absolute limit alone would fail a
# cause removing 86 % of a large discrepancy: issue 21's rough tile)
Z_EXPLAINED = 3.0
MIN_GAIN = 0.5  # a named cause removes at least half of the held-out discrepancy (gain)
# ... and its score (held-out error squared plus PARAMETER_PENALTY per fitted parameter)
# beats the base model's, the held-out error squared with no parameter: the base model
# is a candidate too (AIC)
# ... and beat the runner-up's score by a quarter of the base model's excess over the
# best (assumed, set before any test ran: a runner-up that closes 3/4 of the gap is
# a rival explanation, not a worse one), or be consistent with the held-out runs
# (error within Z_CONSISTENT, the limit at which the base model itself would be)
# where no other candidate is: the held-out runs then tell the two apart whatever the
# base model's excess (added in issue 21 after draws 1030 and 1033 of its benchmark:
# frame 1.58 vs friction 2.48 and run-out 1.74 vs roughness 2.93 held-out, against
# base errors of 5.2-5.6, were not named; judged on draws it had not seen).  The others
# are the rival explanations: the fits the training runs tell from the base model
# (told_from_base, the test the named cause passes too).  A fit the training runs do not
# tell from the base model explains the held-out runs alone, with parameters the training
# runs leave free, and the named cause explains both halves better (issue 21's draw 1177:
# mu_s 0.49 on tile, friction_levels fitted at 0.49, held-out 3.18 -> 1.37, training
# 2.07 -> 1.43, was not named beside a mast fitted at the prior's stiffest, 3000 N m/rad,
# held-out 1.64 and training 2.14, worse than the base model's.  Added after seeing it;
# judged again on every stored row of the benchmark without simulating, it changes two,
# 1177 and 1175, both missed and now named right, and names nothing wrong; on the fresh
# draws 1178-1191 it moved no verdict)
SEPARATION = 0.25
# ... and the training runs tell it from the base model: the base model's training error
# (start 0, as a fit's) is outside the best fit's profile bound, E^2 > E_fit^2 (1 + 1/n)
# (profile_factor): the base model, the cause at its null, is not among the parameter
# values the training runs allow.  The intervals read a wider bound, widened by the fit's
# start-to-start scatter (interval_bound, added after this rule); the rule keeps the
# bound it was judged with on the benchmark, both sides of it read from one start.
# Without it a cause fitted next to its null value can be named on the held-out runs'
# scatter alone (issue 21's draw 1106: an unbalanced fan, base error 2.13, named
# slip_lambda_max at 0.087 for the base model's 0.1, 51 % removed; training errors 1.83
# against the base model's 1.88, inside the bound 1.98; added after seeing it, judged on
# the benchmark's draws after it)
# ... and the training runs rank it first too: no other fit's training score (its training
# error squared plus the same penalty per fitted parameter) is below the named one's.  The
# fits are chosen on the training runs and judged on the held-out ones; when the two halves
# of the data rank different causes first, the data do not tell them apart and naming the
# held-out half's choice is a guess; no threshold is added (the ranking's own score, on the
# other half).  Issue 21's fresh draws 1126 and 1131: a rough floor of 1.02 mm, 0.078 m
# named a run-out (held-out 1.55 against the floor fit's 3.40; training scores 4.16 against
# the floor's 3.38), and a run-out of 0.13 mm named a rough floor (held-out 1.51 against
# 2.11; training scores 3.36 against the run-out's 2.87).  In both the truth itself is not
# separated from the rival (ceiling): "unexplained" is the answer the data allow.  Added
# after seeing them (a first form after 1126, with the profile bound as margin and no
# penalty, did not catch 1131); of the 62 other named rows with kept rankings it changes
# none; judged on the benchmark's draws after 1131
PARAMETER_PENALTY = 2.0  # AIC: score = E^2 + 2 k / (training runs); choosing one of N
# realisations counts as ln N parameters (its description length in nats)
# The errors the verdict reads (the base model's, every fit's held-out error, the pair's)
# are the median over STARTS simulations of each command, from comparison.start_state
# 0..STARTS-1: the robot at rest, then repeat-trial starts drawn as a dataset's trials are
# (another yaw and wheel angle, and residual tire deflections: without these, issue 21's
# draw-1175 showed, the starts on a flat floor are copies and share one regime).
# One simulation is one draw of the model's run-to-run scatter, which on a stick-slip
# floor is not small: issue 21's draw-1071 (a 28 Hz sensor mount on carpet, held-out
# 20 deg/s; damping 0.034) scored 3.58 at 27.98 Hz and 1.52 at 27.99 from rest, and at 27.98 Hz
# 3.58, 1.59, 1.52, 2.01, 1.53 over five starts: a rare regime of the 6.5-9 Hz and
# 23-31 Hz steady bands, 14 trial spreads away (at the default 0.1 ms step, and at least
# partly the step's: the base model's 6.5-9 Hz a_x power spreads over 2.3 decades across
# 10 starts at 0.1 ms, 1.1 at 0.05 ms, 0.06 across 4 at 0.025 ms; issue 18's slow
# stick-slip lines are not converged at 0.1 ms).  The median keeps a simulation's scale
# ("one more trial", ~1 to 1.4 for a right model: Z_CONSISTENT holds) and is not moved
# by one start in two regimes (assumed: 5, the fewest for which two rare starts do not
# move it; measured on draw-1071 after seeing it, not tuned on the benchmark).  The
# search (the training errors) reads one start: STARTS times the simulations otherwise.
STARTS = 5
# The starts the search's training error is the median over (starts 0..SEARCH_STARTS-1;
# diagnose --search-starts).  1, the start from rest only, is the default: 5 plans 4.4x
# the simulations of issue 21's diagnoses (1807 against 415; 1765 s and 2006 s for draws
# 1121 and 1166, 1121 named right, as it is with 1, and 1166 not), and on 25 values of
# their slip fit's parameter the median over 5 starts is within 0.1 of the start from
# rest at 21 (1121) and 19 (1166): there the search was limited by its grid and its Brent
# steps (then 4), not by one start (README).  More starts guard a search against a point
# whose start from rest falls in a rare regime (issue 21's draw 1174: the truth scored
# 2.86 from rest, 1.41-1.73 from the 4 other starts).
SEARCH_STARTS = 1


@dataclasses.dataclass
class Fit:
    cause: str
    parameters: dict[str, float]
    main: str
    interval: tuple[float, float]
    train_error: float
    held_out_error: float
    score: float
    simulated: Simulated
    evaluations: list[tuple[float, float]]  # (main value, training error)
    realisation: int | None = None  # the random geometry's seed, for causes that have one
    factory: Callable | None = None  # Setup -> the fitted model (to simulate it again)
    # every fitted parameter's interval (the main one's is `interval`); a parameter not
    # in it was held at its prior's value
    intervals: dict[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    removed: float = 0.0  # gain(): the share of the held-out discrepancy it removes
    # a random geometry's training error at each realisation tried (at the grid's best
    # value): how much the draw matters beside the parameter
    realisation_errors: list[float] = dataclasses.field(default_factory=list)
    # the simulations the fit ran, kept to refine it (refine_fit) without running them again
    evaluator: object = dataclasses.field(default=None, repr=False, compare=False)
    # a cause with a design (Cause.design) whose best design point fits the training runs
    # better than the main fit, each scored with its fitted parameters' penalty: refined
    # whatever its rank (diagnose_observed)
    design_better: bool = False
    # the training error at the fit from each of STARTS starts (with_start_scatter; the
    # first search_starts are the search's own): the scatter its intervals are read against
    train_errors_over_starts: list[float] = dataclasses.field(default_factory=list)
    # per fitted parameter, the sides ("below", "above") where its interval runs to the
    # prior's bound with nothing evaluated beyond it (unprobed_sides): the search did not
    # look there, so the data may or may not bound it
    unprobed: dict[str, list[str]] = dataclasses.field(default_factory=dict)

    @property
    def fitted(self) -> list[str]:
        return list(self.intervals) or [self.main]


def split(observed: Observed, group_errors: np.ndarray | None = None,
          held_out: Sequence[str] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(training runs, held-out runs): every third group, starting with the second, is
    held out; with fewer than 3 groups, the last trial of each group is.

    group_errors: the base model's error on each group (base_group_errors).  When every
    group the rule holds out is within Z_CONSISTENT (the held-out runs would show no
    discrepancy of their own and could confirm no cause) and more groups than it holds
    out are above it, the groups above it with the smallest errors are held out
    instead, as many: the held-out runs then show the discrepancy, and the groups
    showing it most still train.  Issue 21's benchmark: 14 of its 179 datasets had a
    quiet held-out command; in 5 of them two commands show the effect (per-command
    errors measured with the base model before this rule was written).

    held_out: the commands to hold out instead (held_out_groups: labels, or a command
    alone where one setup has it), as the user chose them; neither rule applies."""
    runs = np.arange(len(observed.run_group))
    if held_out is not None:
        held = np.isin(observed.run_group, held_out_groups(observed, held_out))
    elif holds_out_commands(observed):
        held_groups = np.arange(1, len(observed.groups), 3)
        if group_errors is not None:
            errors = np.asarray(group_errors)
            showing = np.flatnonzero(errors > Z_CONSISTENT)
            if np.all(errors[held_groups] <= Z_CONSISTENT) and len(showing) > len(held_groups):
                weakest = np.argsort(errors[showing], kind="stable")
                held_groups = showing[weakest[:len(held_groups)]]
        held = np.isin(observed.run_group, held_groups)
    else:
        held = np.zeros(len(runs), bool)
        for gi in range(len(observed.groups)):
            members = runs[observed.run_group == gi]
            if len(members) > 1:
                held[members[-1]] = True
    if not held.any() or held.all():
        raise ValueError("the dataset needs at least two runs of one command, or three "
                         "commands, to hold some out")
    return runs[~held], runs[held]


def held_out_groups(observed: Observed, commands: Sequence[str]) -> np.ndarray:
    """The indices of the groups `commands` name, each by its label ("v0-w60 tile
    extended", as diagnosis.json's dataset.groups list them) or by its command alone
    ("v0-w60") where only one setup has it.  A command the dataset lacks, one that names
    several groups, or holding out every command is an error naming it."""
    labels = [g.label for g in observed.groups]
    chosen = []
    for command in commands:
        matches = [i for i, g in enumerate(observed.groups)
                   if command.strip() in (g.label, g.command)]
        if not matches:
            raise ValueError(f"hold-out {command!r}: the dataset has no such command "
                             f"(its commands: {', '.join(labels)})")
        if len(matches) > 1:
            raise ValueError(f"hold-out {command!r} names {len(matches)} commands ("
                             f"{', '.join(labels[i] for i in matches)}): give the full label")
        chosen.append(matches[0])
    if len(set(chosen)) == len(labels):
        raise ValueError(f"hold-out {', '.join(commands)}: that is every command of the "
                         "dataset, and none would be left to fit on")
    return np.array(sorted(set(chosen)), int)


def holds_out_commands(observed: Observed, held_out: Sequence[str] | None = None) -> bool:
    """Whether split holds out whole commands (the user's held_out, or three or more
    commands), or else the last trial of each, which repeats a trained command and can
    confirm no cause (verdict)."""
    return held_out is not None or len(observed.groups) >= 3


def base_group_errors(comparison: Comparison, sims: list[Simulated]) -> np.ndarray:
    """The base model's error on each command group (median over the starts' sims), the
    centripetal offset taken from the other groups, as a held-out group's is (from its
    own runs when it is the only group)."""
    group_of = comparison.observed.run_group
    runs = np.arange(len(group_of))
    return np.array([median_error(comparison, sims, runs[group_of == g],
                                  runs[group_of != g] if np.any(group_of != g) else None)
                     for g in range(len(comparison.observed.groups))])


def profile_factor(n_train: int) -> float:
    """The profile bound on a training error squared, as a factor on the best fit's:
    E^2 <= E_min^2 (1 + 1/n), a Delta chi^2 = 1 bound with the residual variance scaled
    to the best fit and each training run counted as one observation (features of a run
    are correlated).  The intervals (_interval) and told_from_base read it."""
    return 1 + 1 / max(n_train, 1)


def interval_bound(train_errors_over_starts, train_error: float, n_train: int,
                   search_starts: int = SEARCH_STARTS) -> float:
    """The bound on one evaluation's training error squared that a fit's intervals read:
    the profile bound (profile_factor) on the median over STARTS starts of the fit's
    training error squared, plus one standard deviation of it across the starts; never
    below the profile bound on the search's own value (train_error).

    A search evaluates each point once (from rest, SEARCH_STARTS 1), and on a stick-slip
    floor one evaluation is one draw of the model's run-to-run scatter: issue 21's draw
    1204 (mu_s 0.425 on carpet) fitted 0.4947 at a training error of 2.18, and the same
    point scored 2.18, 2.21, 2.10, 3.15 and 3.08 from the five starts.  The bound on the
    best value alone, E^2 <= 2.18^2 (1 + 1/6), gave 0.491-0.513, the neighbourhood of
    one lucky draw; against the point's own scatter it is 0.457-0.527.  That still
    excludes the truth: the search's lowest point, 0.457, scored 2.93, just outside, and
    the truth sits in a valley narrower than the grid's spacing (1.56-1.63 from every
    start at 0.425, 2.46-2.89 at 0.45; scripts/bench/profile_fit.py), a miss of the
    search no bound mends.  The median takes the level the best point scores typically
    (not its luckiest draw), the standard deviation the scatter of the one draw each
    other point had (assumed: one sigma, as Delta chi^2 = 1 is; set before any benchmark
    row was judged by it), divided by sqrt(search_starts) where each evaluation is a
    median over that many starts (the scatter of a mean of that many: approximate for a
    median)."""
    e2 = np.square(np.asarray(train_errors_over_starts, dtype=float))
    scatter = float(np.std(e2, ddof=1)) / np.sqrt(search_starts) if len(e2) > 1 else 0.0
    return max(float(train_error) ** 2 * profile_factor(n_train),
               float(np.median(e2)) * profile_factor(n_train) + scatter)


def _interval(evaluations: list[tuple[float, float]], n_train: int, parameter,
              bound: float | None = None):
    """Values whose training error is within the profile bound (profile_factor), or
    within `bound` on the error squared (interval_bound) where given.

    Each edge is where the parabola through the last point inside the bound, the first
    outside and the point beyond the first (in the prior's coordinate, log or linear)
    crosses the bound: E^2 is quadratic near a minimum, and a straight line between two
    points a tenth of the prior apart puts the edge too close where the error rises
    steeply.  Linear where no third point or no crossing on that stretch.  A side where no
    evaluated value crosses the bound is open: it ends at the prior's bound (the data
    do not bound it there, or no value beyond was evaluated: unprobed_sides tells
    which)."""
    log = parameter.log
    ev = sorted(evaluations)
    coord = np.log if log else (lambda a: a)
    inv = np.exp if log else (lambda a: a)
    c = coord(np.array([v for v, _ in ev], dtype=float))
    e2 = np.array([e for _, e in ev]) ** 2
    if bound is None:
        bound = e2.min() * profile_factor(n_train)
    ok = np.flatnonzero(e2 <= bound)
    lo_i, hi_i = ok.min(), ok.max()

    def edge(i, j, k):  # the crossing between points i (in) and j (out); k: i's other side
        if j < 0 or j >= len(c):
            return float(parameter.low if j < 0 else parameter.high)
        t = (bound - e2[i]) / (e2[j] - e2[i]) if e2[j] != e2[i] else 0.0
        crossing = c[i] + t * (c[j] - c[i])
        if 0 <= k < len(c):
            inside = [r for r in _parabola_roots(c[[k, i, j]], e2[[k, i, j]] - bound)
                      if min(c[i], c[j]) <= r <= max(c[i], c[j])]
            if inside:
                crossing = min(inside, key=lambda r: abs(r - crossing))
        return float(inv(crossing))

    return edge(lo_i, lo_i - 1, lo_i + 1), edge(hi_i, hi_i + 1, hi_i - 1)


def unprobed_sides(evaluations: list[tuple[float, float]], parameter,
                   interval: tuple[float, float]) -> list[str]:
    """The sides of `interval` ("below", "above") that run to the prior's bound for want
    of a probe: _interval opens a side when no evaluated value beyond its last value
    inside the bound crosses it, and this is the case where the outermost value
    evaluated on that side lies inside the prior (the search stopped short of it),
    not at its bound (where an open side is the data's).  Most such sides belong to fits
    of the main parameter alone, whose grid points are slice middles (nothing evaluated
    between the outermost one and the prior's bound unless Brent went there); a refined
    fit has one where refine_parameters' profile moves ran out (PROFILE_MOVES)."""
    units = [parameter.to_unit(v) for v, _ in evaluations]
    sides = []
    if interval[0] <= parameter.low and min(units) > UNIT_EDGE:
        sides.append("below")
    if interval[1] >= parameter.high and max(units) < 1 - UNIT_EDGE:
        sides.append("above")
    return sides


def _parabola_roots(x: np.ndarray, y: np.ndarray) -> list[float]:
    """Real roots of the parabola through three points (Newton's divided differences);
    none when two points share an abscissa or the numbers overflow."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        f01 = (y[1] - y[0]) / (x[1] - x[0])
        f012 = ((y[2] - y[1]) / (x[2] - x[1]) - f01) / (x[2] - x[0])
        coefficients = [f012, f01 - f012 * (x[0] + x[1]), y[0] - f01 * x[0] + f012 * x[0] * x[1]]
    if not np.all(np.isfinite(coefficients)):
        return []
    if coefficients[0] == 0:
        return [] if coefficients[1] == 0 else [float(-coefficients[2] / coefficients[1])]
    return [float(r.real) for r in np.roots(coefficients) if abs(r.imag) < 1e-12]


def _parameter_key(params: dict[str, float]) -> tuple:
    return tuple(sorted((k, float(v)) for k, v in params.items()))


def _placed(part: Simulated, which: list[int], into: Simulated | int) -> Simulated:
    """part, a simulation of the groups `which` (in that order), laid into a simulation of
    every group: `into`'s copy, or with n_groups = into, empty rows (NaN features)."""
    if isinstance(into, int):
        into = Simulated([None] * into, [None] * into, [np.nan] * into,
                         np.full((into, part.features.shape[1]), np.nan), [()] * into)
    out = Simulated(list(into.time_s), list(into.accel), list(into.mean_yaw_rate_deg_s),
                    into.features.copy(), list(into.wheel_rates_hz))
    for row, i in enumerate(which):
        out.time_s[i], out.accel[i] = part.time_s[row], part.accel[row]
        out.mean_yaw_rate_deg_s[i] = part.mean_yaw_rate_deg_s[row]
        out.features[i], out.wheel_rates_hz[i] = part.features[row], part.wheel_rates_hz[row]
    return out


class _Evaluations:
    """Training errors of one cause's models, simulated in batches and kept: a point is
    (its parameters, its realisation).

    A point simulates the commands its training error reads (the groups holding
    training runs) only; the held-out commands are simulated for the points a fit
    ends at (complete), a third of a search's simulations saved when every third
    command is held out.  Each command is simulated on its own from the settled
    state, so the numbers are those of simulating every command at every point."""

    def __init__(self, cause, comparison, groups, duration_s, train, timestep, chain, backend,
                 progress, stored, search_starts: int = SEARCH_STARTS):
        self.cause, self.comparison, self.groups, self.train = cause, comparison, groups, train
        self.duration_s, self.timestep, self.chain = duration_s, timestep, chain
        self.backend, self.progress, self.stored = backend, progress, stored
        self.search_starts = search_starts
        self.done: dict[tuple, tuple[float, Simulated]] = {}
        # a point's training error from each of the search's starts (0..search_starts-1)
        self.start_errors: dict[tuple, list[float]] = {}
        self.trained = _groups_of(comparison, train)
        self.completed: set[tuple] = set()  # the points simulated on every command
        self.held_errors: dict[tuple, float] = {}  # a point's held-out error (held_out_error)

    def factory(self, params: dict[str, float], realisation: int):
        return model_factory(self.cause.edit(params, realisation), self.timestep)

    def _simulate(self, keys: list[tuple], which: list[int], starts: int = 1
                  ) -> list[list[Simulated]]:
        """Each point's groups `which` from starts 0..starts-1 (one batch)."""
        factories = [self.factory(dict(k), r) for k, r in keys]
        jobs = [(f, [self.groups[i] for i in which]) for f in factories for _ in range(starts)]
        parts = simulate_groups(jobs, self.duration_s, self.chain, backend=self.backend,
                                progress=self.progress, cache=self.stored, signals=False,
                                starts=[s for _ in factories for s in range(starts)])
        return [parts[i * starts:(i + 1) * starts] for i in range(len(keys))]

    def __call__(self, points: list[tuple[dict[str, float], int]]) -> list[float]:
        """The points' training errors: the median over the search's starts (the
        simulation kept is the one from start 0)."""
        keys = [(_parameter_key(p), int(r)) for p, r in points]
        todo = list(dict.fromkeys(k for k in keys if k not in self.done))
        if todo:
            for key, parts in zip(todo, self._simulate(todo, self.trained, self.search_starts)):
                sims = [_placed(part, self.trained, len(self.groups)) for part in parts]
                self.start_errors[key] = [float(self.comparison.error(s.features, self.train))
                                          for s in sims]
                self.done[key] = (float(np.median(self.start_errors[key])), sims[0])
        return [self.done[k][0] for k in keys]

    def complete(self, params: dict[str, float], realisation: int) -> Simulated:
        """The point's simulation with every command (the held-out ones added)."""
        key = (_parameter_key(params), int(realisation))
        self([(params, realisation)])
        error, sim = self.done[key]
        if key not in self.completed:
            missing = [i for i in range(len(self.groups)) if i not in self.trained]
            if missing:
                sim = _placed(self._simulate([key], missing)[0][0], missing, sim)
                self.done[key] = (error, sim)
            self.completed.add(key)
        return sim

    def held_out_error(self, params: dict[str, float], realisation: int,
                       held: np.ndarray) -> float:
        """The point's error on the held-out runs, the median over STARTS starts."""
        key = (_parameter_key(params), int(realisation))
        if key not in self.held_errors:
            self.held_errors[key] = self.held_out_over_starts(
                self.complete(params, realisation), self.factory(params, realisation), held)
        return self.held_errors[key]

    def held_out_over_starts(self, sim: Simulated, factory, held: np.ndarray) -> float:
        """The held-out error of factory's model, sim its simulation from start 0: the
        median over STARTS starts (over_starts), the bias taken on the training runs."""
        sims = over_starts(sim, factory, self.groups, _groups_of(self.comparison, held),
                           self.duration_s, self.chain, self.backend, self.progress,
                           self.stored)
        return median_error(self.comparison, sims, held, self.train)

    def best(self, realisation: int) -> tuple[dict[str, float], float, Simulated]:
        key = min((k for k in self.done if k[1] == realisation), key=lambda k: self.done[k][0])
        return dict(key[0]), *self.done[key]

    def profile(self, name: str, at: dict[str, float], realisation: int
                ) -> list[tuple[float, float]]:
        """(value of `name`, training error) of the points that differ from `at` in `name`
        only: a slice of the error surface through the fit."""
        others = {k: v for k, v in _parameter_key(at) if k != name}
        return sorted((dict(key)[name], err) for (key, r), (err, _) in self.done.items()
                      if r == realisation
                      and {k: v for k, v in key if k != name} == others)


def fit_cause(cause, comparison: Comparison, groups: list[Group], duration_s: float,
              train: np.ndarray, held: np.ndarray, timestep: float | None,
              chain: SensorChain, backend, progress, stored=None,
              search_starts: int = SEARCH_STARTS) -> Fit:
    """The cause's main parameter fitted on the training runs (a grid, then Brent), its
    other parameters at their priors' values (refine_fit then fits every parameter).

    stored: a SimulationCache; simulations found in it are not run again, so the
    fit reads their features only (Fit.simulated may lack time series).  Raises
    NotApplicable, before simulating, when a command drives beyond the cause's reach."""
    cause.check_reach([(g.v_mps, g.omega_deg_s) for g in groups], duration_s)
    main = cause.main
    evaluate = _Evaluations(cause, comparison, groups, duration_s, train, timestep, chain,
                            backend, progress, stored, search_starts)

    def at_main(value, realisation):
        return (cause.parameters(float(value)), realisation)

    def grid_search(realisation):
        grid = main.from_unit((np.arange(GRID_POINTS) + 0.5) / GRID_POINTS)
        best = int(np.argmin(evaluate([at_main(v, realisation) for v in grid])))
        lo = main.to_unit(grid[best - 1]) if best > 0 else 0.0
        hi = main.to_unit(grid[best + 1]) if best < GRID_POINTS - 1 else 1.0
        return grid[best], (lo, hi)

    realisation = FIT_SEED
    value, bracket = grid_search(realisation)
    errors = []
    if cause.random_realisation:
        # The measured robot has one realisation (its floor, its wheels' phases), and it
        # shapes the spectra as much as the main parameter does: pick, at the grid's
        # best value, the draw that fits the training runs best, then search again with
        # it.  The held-out runs judge whether the choice generalises; the score pays
        # ln(REALISATIONS) parameters for it.
        errors = evaluate([at_main(value, r) for r in range(FIT_SEED, FIT_SEED + REALISATIONS)])
        chosen = FIT_SEED + int(np.argmin(errors))
        if chosen != realisation:
            realisation = chosen
            value, bracket = grid_search(realisation)
    optimize.minimize_scalar(lambda u: evaluate([at_main(main.from_unit(u), realisation)])[0],
                             bounds=bracket, method="bounded",
                             options={"xatol": REFINE_TOL_UNIT, "maxiter": REFINE_MAX_STEPS})
    fit = _result(cause, evaluate, [main], realisation, held)
    fit.realisation_errors = [float(e) for e in errors]
    if cause.design is not None:
        # the design's points too (after the result: they are not on the main parameter's
        # line), so that a cause the one-dimensional fit misses is still refined
        design = evaluate([(values, realisation) for values in _design_points(cause)])
        fit.design_better = bool(_score(min(design), 1 + len(cause.held), len(train))
                                 < _score(fit.train_error, 1, len(train)))
    return fit


def _groups_of(comparison: Comparison, runs: np.ndarray) -> list[int]:
    """The groups (indices) the runs belong to."""
    return sorted({int(g) for g in comparison.observed.run_group[runs]})


def over_starts(sim: Simulated, factory, groups: list[Group], which: list[int],
                duration_s: float, chain: SensorChain, backend, progress, cache,
                first: int = 1) -> list[Simulated]:
    """sim (every group from start 0) and, for each start first..STARTS-1, sim with the
    groups `which` simulated again from that start (comparison.start_state)."""
    jobs = [(factory, [groups[i] for i in which])] * (STARTS - first)
    parts = simulate_groups(jobs, duration_s, chain, backend=backend, progress=progress,
                            cache=cache, signals=False, starts=range(first, STARTS))
    return [sim, *(_placed(part, which, sim) for part in parts)]


def median_error(comparison: Comparison, sims: list[Simulated], runs: np.ndarray,
                 bias_runs: np.ndarray | None = None) -> float:
    """Comparison.error on `runs`, the median over the simulations of several starts."""
    return float(np.median([comparison.error(s.features, runs, bias_runs) for s in sims]))


def _score(error: float, n_params: float, n_train: int) -> float:
    """An error squared plus PARAMETER_PENALTY per fitted parameter (AIC)."""
    return error ** 2 + PARAMETER_PENALTY * n_params / n_train


def _clipped(cause, values: dict[str, float]) -> dict[str, float]:
    """A cause's parameter set with each parameter clipped to its prior."""
    return {name: float(np.clip(values[name], p.low, p.high))
            for name, p in cause.priors.items()}


def _design_points(cause) -> list[dict[str, float]]:
    """Cause.design's points, clipped to the priors."""
    return [_clipped(cause, values) for values in cause.design()]


def refine_fit(fit: Fit, held: np.ndarray) -> Fit:
    """The fit again with every parameter of its cause fitted (refine_parameters), from
    where the main parameter's fit ended; the same fit when the cause has no other."""
    cause = cause_registry.get(fit.cause)
    if not cause.held or len(fit.fitted) > 1:
        return fit
    realisation = fit.realisation if fit.realisation is not None else FIT_SEED
    parameters = [cause.main, *cause.held]
    fit_every_parameter(fit.evaluator, cause, fit.parameters, realisation)
    return dataclasses.replace(_result(cause, fit.evaluator, parameters, realisation, held),
                               realisation_errors=fit.realisation_errors,
                               design_better=fit.design_better)


def with_start_scatter(fit: Fit) -> Fit:
    """The fit with its training error from each of STARTS starts (those the search ran
    read from it, the others' training commands simulated at the fit) and every interval
    read against
    interval_bound: the bound a single evaluation of the search is within, given the
    scatter the fit's own simulations show.  A fit without its evaluations is returned
    as it is."""
    evaluate = fit.evaluator
    if evaluate is None:
        return fit
    comparison, train = evaluate.comparison, evaluate.train
    realisation = fit.realisation if fit.realisation is not None else FIT_SEED
    # the search's own starts are read, not simulated again (--search-starts above 1)
    known = evaluate.start_errors.get((_parameter_key(fit.parameters), realisation), [])[:STARTS]
    first = max(len(known), 1)
    sims = over_starts(fit.simulated, fit.factory, evaluate.groups, evaluate.trained,
                       evaluate.duration_s, evaluate.chain, evaluate.backend,
                       evaluate.progress, evaluate.stored, first=first)
    errors = (known or [float(comparison.error(sims[0].features, train))]) + [
        float(comparison.error(s.features, train)) for s in sims[1:]]
    bound = interval_bound(errors, fit.train_error, len(train), evaluate.search_starts)
    priors = cause_registry.get(fit.cause).priors
    _, intervals, unprobed = _intervals(evaluate, {name: priors[name] for name in fit.fitted},
                                        fit.parameters, realisation, bound)
    return dataclasses.replace(fit, interval=intervals[fit.main], intervals=intervals,
                               train_errors_over_starts=errors, unprobed=unprobed)


def _result(cause, evaluate: "_Evaluations", fitted: list, realisation: int,
            held: np.ndarray) -> Fit:
    """The Fit at the best point evaluated: its errors, the score with one penalty per
    fitted parameter, and every fitted parameter's interval."""
    train = evaluate.train
    params, train_error, _ = evaluate.best(realisation)
    sim = evaluate.complete(params, realisation)
    held_error = evaluate.held_out_error(params, realisation, held)
    profiles, intervals, unprobed = _intervals(evaluate, {p.name: p for p in fitted}, params,
                                               realisation)
    n_params = n_parameters(cause.name, len(fitted))
    return Fit(cause.name, params, cause.main.name, intervals[cause.main.name], train_error,
               held_error, _score(held_error, n_params, len(train)), sim,
               profiles[cause.main.name], realisation if cause.random_realisation else None,
               evaluate.factory(params, realisation), intervals, evaluator=evaluate,
               unprobed=unprobed)


def _intervals(evaluate: "_Evaluations", priors: dict, params: dict[str, float],
               realisation: int, bound: float | None = None) -> tuple[dict, dict, dict]:
    """(profiles, intervals, unprobed sides) of the parameters `priors` names (name ->
    Parameter) through `params`: each profile's interval (_interval, against `bound`
    where given) and its sides open for want of a probe (unprobed_sides, only those
    that have one)."""
    profiles = {name: evaluate.profile(name, params, realisation) for name in priors}
    intervals = {name: _interval(profiles[name], len(evaluate.train), prior, bound)
                 for name, prior in priors.items()}
    sides = {name: unprobed_sides(profiles[name], priors[name], intervals[name])
             for name in priors}
    return profiles, intervals, {name: s for name, s in sides.items() if s}


def fit_every_parameter(evaluate, cause, start: dict[str, float], realisation: int) -> None:
    """refine_parameters from `start` (the main parameter's fit) or, for a cause with a
    design (Cause.design: coarse start points over parameters the main fit does not
    vary), from the design's best point where it fits the training runs better; for a
    cause with a mirror (Cause.mirror: parameters that describe the other branch of an
    ambiguity the search cannot cross, e.g. a frame's roll and pitch stiffnesses
    exchanged), the mirror image of that fit too, searched from when it fits the
    training runs better.
    A search along the axes stays in the basin it starts in: issue 21's anisotropic
    frame (roll 400 N m/rad, pitch 0.5x) stopped at roll 161, pitch 2x, whose mirror
    (322, 0.5x) lies in the truth's basin (training error 1.65 at 250, 0.5x and 1.60
    at 400, 0.5x against 2.03 at 161, 2x; measured on its training runs)."""
    parameters = [cause.main, *cause.held]
    if cause.design is not None:
        points = _design_points(cause)
        errors = evaluate([(values, realisation) for values in points])
        if min(errors) < evaluate([(start, realisation)])[0]:
            start = points[int(np.argmin(errors))]
    refine_parameters(evaluate, parameters, start, realisation)
    if cause.mirror is None:
        return
    best, error, _ = evaluate.best(realisation)
    image = _clipped(cause, cause.mirror(best))
    if evaluate([(image, realisation)])[0] < error:
        refine_parameters(evaluate, parameters, image, realisation)


def refine_parameters(evaluate: _Evaluations, parameters, start: dict[str, float],
                      realisation: int) -> None:
    """Every parameter fitted from `start` by a bounded pattern search in prior
    coordinates: each pass probes every parameter REFINE_STEPS[i] either side (one
    batch), moves to the best probe and tries the sum of every improving move; a last
    pass at the smallest step around the final point gives each parameter's profile
    (its interval), taken again around any probe of it that fits better
    (PROFILE_MOVES).  A derivative-free search: the features of a stick-slip
    simulation are not smooth enough in a parameter for finite differences at the
    small steps a Gauss-Newton step needs (PLATFORM-NOTES, sysid)."""
    x = {p.name: p.to_unit(start[p.name]) for p in parameters}
    x0, by_name = dict(x), {p.name: p for p in parameters}

    def point(u):  # a coordinate left where it started keeps start's exact value
        return ({k: start[k] if v == x0[k] else float(by_name[k].from_unit(v))
                 for k, v in u.items()}
                | {k: v for k, v in start.items() if k not in by_name}, realisation)

    current = evaluate([point(x)])[0]
    for step in REFINE_STEPS:
        probes = []
        for name in x:
            for sign in (-1.0, 1.0):
                u = float(np.clip(x[name] + sign * step, 0.0, 1.0))
                if u != x[name]:
                    probes.append((name, u))
        errors = evaluate([point(x | {name: u}) for name, u in probes])
        improving = {}
        for (name, u), err in zip(probes, errors):
            if err < current and err < improving.get(name, (None, np.inf))[1]:
                improving[name] = (u, err)
        if not improving:
            continue
        best_name = min(improving, key=lambda n: improving[n][1])
        candidates = [(x | {best_name: improving[best_name][0]}, improving[best_name][1])]
        if len(improving) > 1:
            combined = x | {n: u for n, (u, _) in improving.items()}
            candidates.append((combined, evaluate([point(combined)])[0]))
        x, current = min(candidates, key=lambda c: c[1])
    # the profile through the final point at the smallest step (most of it is done), taken
    # again around a probe that fits better (PROFILE_MOVES)
    step = REFINE_STEPS[-1]
    for _ in range(1 + PROFILE_MOVES):
        probes = [x | {name: u} for name in x for sign in (-1.0, 1.0)
                  if (u := float(np.clip(x[name] + sign * step, 0.0, 1.0))) != x[name]]
        errors = evaluate([point(u) for u in probes])
        if not probes or min(errors) >= current:
            break
        x, current = probes[int(np.argmin(errors))], float(min(errors))


def gain(base_held: float, extended_held: float, noise: float) -> float:
    """The fraction of the base model's held-out discrepancy that an extension removes.

    The discrepancy is the mean square z-score in excess of what a simulation at
    the trials' mean scores against single trials (Comparison.noise_error): a
    perfect extension scores 1 (up to chance), the base model 0.  The plain ratio
    of RMS errors would not do: it cannot reach 50 % for a perfect extension when
    the base error is below twice the noise, however clear the effect.  Capped at
    1 (an extension that scores below the trials' noise does so by chance).
    """
    excess = base_held ** 2 - noise ** 2
    if excess <= 0:
        return 0.0
    return float(min(1.0, (base_held ** 2 - extended_held ** 2) / excess))


def separated(base_held: float, best: Fit, others: list[Fit]) -> bool:
    """Whether the best fit is told apart from the others (SEPARATION): it beats the
    runner-up's score by a quarter of the base model's excess over it, or it is
    consistent with the held-out runs (within Z_CONSISTENT) and none of the others is."""
    base_score = base_held ** 2
    if others[0].score - best.score >= SEPARATION * (base_score - best.score):
        return True
    return (best.held_out_error <= Z_CONSISTENT
            and all(f.held_out_error > Z_CONSISTENT for f in others))


def told_from_base(base_train: float, best: Fit, n_train: int) -> bool:
    """Whether the training runs tell the best fit from the base model: the base model's
    training error lies outside the fit's profile bound (profile_factor, on the fit's
    own training error: not the intervals' wider interval_bound)."""
    return base_train ** 2 > best.train_error ** 2 * profile_factor(n_train)


def rivals(others: list[Fit], base_train: float, n_train: int) -> list[Fit]:
    """The other fits that are rival explanations (SEPARATION): those the training runs
    tell from the base model, in the given order."""
    return [f for f in others if told_from_base(base_train, f, n_train)]


def n_parameters(cause: str, n_fitted: int) -> float:
    """The parameters a fit of `cause` pays for (_score): its n_fitted fitted ones, and
    ln(REALISATIONS) for a chosen realisation (a cause with a random geometry; a name not
    in the registry, a test's stand-in, has none)."""
    registered = cause_registry.CAUSES.get(cause)
    random = registered is not None and registered.random_realisation
    return n_fitted + (np.log(REALISATIONS) if random else 0.0)


def training_score(fit, n_train: int) -> float:
    """The fit's training error scored as its held-out error is (_score)."""
    return _score(fit.train_error, n_parameters(fit.cause, len(fit.fitted)), n_train)


def training_lead(fits: list, base_train: float, n_train: int):
    """The fit the training runs rank first (the lowest training_score) when they tell it
    from the base model (told_from_base), else None: what the training runs point to,
    whatever the held-out runs say."""
    if not fits:
        return None
    lead = min(fits, key=lambda f: training_score(f, n_train))
    return lead if told_from_base(base_train, lead, n_train) else None


def unconfirmed_lead(fits: list, named, base_error: float, base_held: float,
                     base_train: float, n_train: int):
    """The fit a new command could confirm, or None: no cause is named, the records show a
    discrepancy (base_error above Z_CONSISTENT) but the held-out runs show none of their
    own (base_held within it), so nothing held out can confirm the training runs' lead
    (training_lead).  Issue 21: such "held-out quiet" draws are 7 of the 16 clear causes
    since draw 1080 that even the hidden truth would not be named on
    (docs/diagnose-ceiling.md); on the 11 such cause draws with stored rankings the
    training lead is the hidden cause in 10 (the held-out best in 8)."""
    if named is not None or base_error <= Z_CONSISTENT or base_held > Z_CONSISTENT:
        return None
    return training_lead(fits, base_train, n_train)


def preferred_in_training(best, others: list, n_train: int):
    """The other fit the training runs rank first (the lowest training_score, below the
    best's), or None when they rank the best first too."""
    rival = min(others, key=lambda f: training_score(f, n_train), default=None)
    if rival is not None and training_score(rival, n_train) < training_score(best, n_train):
        return rival
    return None


def verdict(base_error: float, base_held: float, fits: list[Fit], noise: float, *,
            base_train: float, n_train: int, held_out_new_commands: bool = True,
            scale: str = TRIALS_SCALE) -> tuple[str, Fit | None, str]:
    """(verdict, named fit or None, reason); noise: Comparison.noise_error(); base_train:
    the base model's training error from start 0 (as Fit.train_error), n_train the
    training runs; held_out_new_commands: the held-out runs are of commands no training
    run has (split's way with three commands or more); scale: what the errors are read
    against, as the reason says it.

    no-discrepancy: the base model is within Z_CONSISTENT.  Otherwise, when the held-out
    runs show a discrepancy of their own (base_held above Z_CONSISTENT) and are of
    commands the fits were not trained on (held_out_new_commands), the best fit is
    the most likely cause when it removes at least MIN_GAIN of the held-out discrepancy,
    its score beats the base model's (the held-out error squared: no parameter), the
    training runs tell it from the base model (told_from_base), it is told apart from
    the others the training runs tell from the base model (rivals, separated) and the
    training runs do not prefer another (preferred_in_training: its training score is
    the lowest too); it is then named, "explained" when its held-out error is within
    Z_EXPLAINED and "partly-explained" when it is not (it removes most of a large
    discrepancy and leaves a part no candidate covers: the summary says which features
    and how far).  Anything else is "unexplained".
    """
    if base_error <= Z_CONSISTENT:
        return "no-discrepancy", None, (
            f"the base model's error {base_error:.2f} is within {Z_CONSISTENT} (RMS z against "
            f"{scale})")
    if not fits:
        return "unexplained", None, "no candidate cause applies to this model"
    best = fits[0]
    if base_held <= Z_CONSISTENT:
        # the held-out runs show no discrepancy of their own (the base model is within the
        # no-discrepancy limit on them): nothing on them can confirm a cause, whatever its
        # gain there.  Issue 21's draw 1171 (a rough floor of 0.67 mm on carpet, held-out
        # base 1.89) named a run-out, 54 % removed, beside the floor's 1.49; of the
        # benchmark's 14 such draws ("held-out quiet", reported apart since before it) 6
        # had a cause named, 5 right and 1 wrong.  Added after seeing it.
        lead = training_lead(fits, base_train, n_train)
        points = ("the training runs tell no candidate from the base model" if lead is None
                  else f"the training runs point to {lead.cause} (training error "
                       f"{base_train:.2f} -> {lead.train_error:.2f})")
        return "unexplained", None, (
            f"the held-out runs show no discrepancy of their own (the base model's error "
            f"{base_held:.2f} there is within {Z_CONSISTENT}), so they cannot confirm a cause; "
            f"{points}")
    removed = gain(base_held, best.held_out_error, noise)
    if not held_out_new_commands:
        # a held-out trial of a command the fits trained on shares that command's
        # simulation: a parameter that moves the simulation towards the command's trained
        # trials (the model's stick-slip scatter is a draw, as a trial's is) moves it
        # towards their repeat too, cause or none.  Issue 21, stop 44: datasets the base
        # model itself simulated, of one command (2 or 3 trials, 3 draws), named
        # friction_levels at 68-78 % removed; a cause is confirmed on a command it was not
        # fitted on.  Added after seeing them.
        return "unexplained", None, (
            f"the held-out runs repeat the commands the fits were trained on (split needs "
            f"three commands to hold one out), so they cannot confirm a cause: the best "
            f"candidate, {best.cause}, brings their error from {base_held:.2f} to "
            f"{best.held_out_error:.2f} ({removed:.0%} of the discrepancy); record a third "
            "command to confirm it")
    if removed < MIN_GAIN:
        return "unexplained", None, (
            f"the best candidate, {best.cause}, removes only {removed:.0%} of the held-out "
            f"discrepancy (error {base_held:.2f} -> {best.held_out_error:.2f}; trial noise "
            f"{noise:.2f})")
    if best.score >= base_held ** 2:
        # the base model is a candidate too, with no parameter: an extension whose score
        # (its held-out error and the penalty for what it fitted) does not beat the base
        # model's held-out error is not supported by the held-out runs (issue 21's draw
        # 1068: base 1.53, run-out 1.25 held-out and score 2.60 against 2.34, named a
        # rough floor wrong through SEPARATION, whose threshold is negative there)
        return "unexplained", None, (
            f"the best candidate, {best.cause}, does not beat the base model on the held-out "
            f"runs once its fitted parameters are paid for (score {best.score:.2f} against "
            f"{base_held ** 2:.2f}; error {base_held:.2f} -> {best.held_out_error:.2f})")
    if not told_from_base(base_train, best, n_train):
        return "unexplained", None, (
            f"the training runs do not tell the best candidate, {best.cause}, from the base "
            f"model (training error {base_train:.2f} -> {best.train_error:.2f}, within the "
            f"fit's profile bound {best.train_error * np.sqrt(profile_factor(n_train)):.2f}); "
            f"the held-out gain ({base_held:.2f} -> {best.held_out_error:.2f}) alone does not "
            "establish it")
    contending = rivals(fits[1:], base_train, n_train)
    if contending and not separated(base_held, best, contending):
        return "unexplained", None, (
            f"{best.cause} and {contending[0].cause} explain the data about equally well "
            f"(held-out {best.held_out_error:.2f} vs {contending[0].held_out_error:.2f})")
    rival = preferred_in_training(best, fits[1:], n_train)
    if rival is not None:
        return "unexplained", None, (
            f"the held-out runs prefer {best.cause} (error {best.held_out_error:.2f} against "
            f"{rival.held_out_error:.2f}) but the training runs prefer {rival.cause} (training "
            f"error {rival.train_error:.2f} against {best.train_error:.2f}, score "
            f"{training_score(rival, n_train):.2f} against {training_score(best, n_train):.2f}"
            f"): the two halves of the data disagree about the cause")
    runner_up = (f"the runner-up {fits[1].cause} reaches {fits[1].held_out_error:.2f}"
                 if len(fits) > 1 else "no other candidate applies")
    if len(fits) > 1 and not told_from_base(base_train, fits[1], n_train):
        runner_up += (f", but the training runs do not tell it from the base model (training "
                      f"error {base_train:.2f} -> {fits[1].train_error:.2f})")
    if best.held_out_error > Z_EXPLAINED:
        return "partly-explained", best, (
            f"{best.cause} is the most likely cause: it removes {removed:.0%} of the held-out "
            f"discrepancy (error {base_held:.2f} -> {best.held_out_error:.2f}; trial noise "
            f"{noise:.2f}) but leaves more than {Z_EXPLAINED}; {runner_up}")
    return "explained", best, (
        f"{best.cause} brings the held-out error from {base_held:.2f} to "
        f"{best.held_out_error:.2f} (trial noise {noise:.2f}: {removed:.0%} of the "
        f"discrepancy removed); {runner_up}")


def fit_pair(first: Fit, second: Fit, held: np.ndarray) -> dict | None:
    """Two fitted causes together, each at its fitted parameters and realisation (one
    simulation per command): whether the pair does better than either alone.  None when
    the two cannot be applied to one model."""
    a, b = cause_registry.get(first.cause), cause_registry.get(second.cause)
    evaluate = first.evaluator
    edit_a = a.edit(first.parameters, first.realisation or FIT_SEED)
    edit_b = b.edit(second.parameters, second.realisation or FIT_SEED)

    def both(spec):
        edit_a(spec)
        edit_b(spec)

    factory = model_factory(both, evaluate.timestep)
    try:
        sim = simulate_groups([(factory, evaluate.groups)], evaluate.duration_s, evaluate.chain,
                              backend=evaluate.backend, progress=evaluate.progress,
                              cache=evaluate.stored, signals=False)[0]
    except (ValueError, RuntimeError):
        return None
    comparison, train = evaluate.comparison, evaluate.train
    held_error = evaluate.held_out_over_starts(sim, factory, held)
    n_params = sum(n_parameters(f.cause, len(f.fitted)) for f in (first, second))
    score = _score(held_error, n_params, len(train))
    return {"causes": [first.cause, second.cause],
            "parameters": {first.cause: first.parameters, second.cause: second.parameters},
            "train_error": comparison.error(sim.features, train),
            "held_out_error": held_error, "score": score,
            "better_than_best": bool(score < first.score)}


def simulations_planned(names: list[str], observed: Observed,
                        search_starts: int = SEARCH_STARTS,
                        held_out: Sequence[str] | None = None) -> int:
    """How many command simulations diagnosing `observed` with these candidates is planned
    to take (a progress bar's total; a plan, not a bound: Brent is planned
    REFINE_STEPS_PLANNED steps and may take up to REFINE_MAX_STEPS, and refinements and
    profile moves are planned in full where a search often stops early): the base model
    on every command; per cause the grid, the Brent steps, for a random geometry the
    other realisations and a second grid, for a cause with a design its points; for the
    causes contenders() can refine (every cause with a design, and the REFINE_CONTENDERS
    costliest to refine of the others with more than one parameter)
    refine_parameters' passes and profile (twice with
    a mirror), each on the training commands; the held-out commands at each
    fit's end (main and refined); the pair (of two causes or more) on every command;
    and STARTS - 1 more starts of the base model's every command and of each end's and
    the pair's held-out ones, and STARTS - search_starts more of each cause's final fit's
    training commands (the starts the search did not run: with_start_scatter); the
    search's (on the training commands) once per search start."""
    def refining(cause):  # refine_parameters: the passes, the final profile
        n = 1 + len(cause.held)
        search = len(REFINE_STEPS) * (2 * n + 1) + 2 * n * (1 + PROFILE_MOVES)
        return 0 if n == 1 else search + (1 + search if cause.mirror else 0)

    candidates = [cause_registry.get(name) for name in names]
    designed = {c.name for c in candidates if c.design is not None}
    others = sorted((c for c in candidates if c.name not in designed and refining(c) > 0),
                    key=refining, reverse=True)  # refine_fit leaves a one-parameter fit
    refined = designed | {c.name for c in others[:REFINE_CONTENDERS]}
    searched = sum(GRID_POINTS + REFINE_STEPS_PLANNED
                   + (REALISATIONS - 1 + GRID_POINTS if c.random_realisation else 0)
                   + (len(c.design()) if c.design is not None else 0)
                   + (refining(c) if c.name in refined else 0) for c in candidates)
    # split() moves held-out groups, never changes their count; the user's stay
    train, held = split(observed, held_out=held_out)
    n_groups = len(observed.groups)
    n_trained = len(set(observed.run_group[train].tolist()))
    n_held = len(set(observed.run_group[held].tolist()))
    ends = len(names) + len(refined)
    pair = 1 if len(names) > 1 else 0  # fit_pair needs two causes
    return ((1 + pair) * n_groups + n_trained * searched * search_starts
            + (n_groups - n_trained) * ends
            + (STARTS - 1) * (n_groups + n_held * (ends + pair))
            + max(STARTS - search_starts, 0) * n_trained * len(names))


@dataclasses.dataclass
class Diagnosis:
    """What diagnose_observed found: the base model's errors, every candidate's fit (best
    first), the ones that do not apply, and the verdict."""

    observed: Observed
    comparison: Comparison
    train: np.ndarray
    held: np.ndarray
    base: Simulated
    base_error: float  # all runs
    base_held: float  # held-out runs
    base_train: float  # training runs, over the search's starts (as Fit.train_error)
    noise: float  # Comparison.noise_error()
    fits: list[Fit]
    not_applicable: list[dict]
    verdict: str
    named: Fit | None
    reason: str
    pair: dict | None = None  # fit_pair of the two best, when there are two
    group_errors: np.ndarray | None = None  # base_group_errors: the base model's, per group
    # next_command.separating_commands, best first: of the two fits the data leave
    # undecided (undecided_pair), or of the training runs' lead and the base model when the
    # held-out runs cannot confirm it (unconfirmed_lead); empty otherwise
    next_commands: list[dict] = dataclasses.field(default_factory=list)
    # the commands the user held out (split's held_out), None where split() chose them
    held_out_given: list[str] | None = None
    # what next_commands are for: next_command.SEPARATE or CONFIRM (None: no proposal)
    next_command_purpose: str | None = None

    @property
    def reference(self) -> Fit | None:
        """The fit a report shows beside the base model: the named one, else the best."""
        return self.named or (self.fits[0] if self.fits else None)

    def summary(self) -> dict:
        """The verdict, the fitted parameters, the ranking and the gain as JSON-ready data."""
        named, reference, groups = self.named, self.reference, self.observed.groups
        best = self.fits[0] if self.fits else None
        return {
            "verdict": self.verdict,
            "cause": named.cause if named else None,
            "reason": self.reason,
            "parameters": named.parameters if named else {},
            "intervals": ({k: list(v) for k, v in named.intervals.items()} if named else {}),
            # the intervals' sides open for want of a probe (unprobed_sides)
            "unprobed": dict(named.unprobed) if named else {},
            # the best candidate whatever the verdict: what it removes and what it leaves
            "most_likely": None if best is None else {
                "cause": best.cause, "named": named is not None,
                "removed": best.removed, "held_out_error": best.held_out_error,
                "parameters": best.parameters,
                "intervals": {k: list(v) for k, v in best.intervals.items()},
                "unprobed": dict(best.unprobed),
                "left": self.comparison.discrepancies(best.simulated.features)},
            "best_pair": self.pair,
            # what to record to tell the two undecided fits apart, or to confirm the
            # training runs' lead (next_command; next_command_purpose says which)
            "next_commands": self.next_commands,
            "next_command_purpose": self.next_command_purpose,
            "ranking": [{"cause": f.cause, "held_out_error": f.held_out_error,
                         "train_error": f.train_error, "score": f.score, "removed": f.removed,
                         "parameters": f.parameters, "fitted": f.fitted,
                         "interval": {k: list(v) for k, v in f.intervals.items()},
                         # what the intervals are read against (interval_bound)
                         "train_errors_over_starts": f.train_errors_over_starts,
                         # interval sides open for want of a probe (unprobed_sides)
                         "unprobed": f.unprobed,
                         "realisation": f.realisation,
                         "realisation_errors": f.realisation_errors,
                         # the training error along the main parameter through the fit:
                         # the grid's and Brent's points, [value, error], by value
                         "profile": [[float(v), float(e)] for v, e in f.evaluations]}
                        for f in self.fits],
            "gain": {
                "metric": "held-out RMS z-score of the spectral features (start-up and steady "
                          "band powers per axis, centripetal mean) against "
                          f"{self.comparison.scale_label}, "
                          f"the median over {STARTS} simulated starts; "
                          "relative_reduction is the fraction of its square in excess of the "
                          "trial noise (noise_error^2) that the extended model removes",
                "baseline_error": self.base_held,
                "extended_error": reference.held_out_error if reference else self.base_held,
                "noise_error": self.noise,
                "relative_reduction": (gain(self.base_held, reference.held_out_error,
                                            self.noise) if reference else 0.0),
                "rms_reduction": (1 - reference.held_out_error / self.base_held
                                  if reference else 0.0),
                "extended_cause": reference.cause if reference else None,
            },
            "baseline_error_all_runs": self.base_error,
            "baseline_error_training": self.base_train,
            "training_runs": int(len(self.train)),
            "discrepancies": self.comparison.discrepancies(self.base.features),
            "remaining_discrepancies": (self.comparison.discrepancies(named.simulated.features)
                                        if named else None),
            "skipped_runs": self.observed.skipped,
            "not_applicable": self.not_applicable,
            "dataset": {"runs": len(self.observed.run_files),
                        "groups": [g.label for g in groups],
                        "held_out_groups": sorted({groups[i].label
                                                   for i in self.observed.run_group[self.held]}),
                        "held_out_given": self.held_out_given,
                        # what split() chose the held-out groups by
                        "base_error_by_group": (None if self.group_errors is None else
                                                {g.label: float(e) for g, e in
                                                 zip(groups, self.group_errors)}),
                        "duration_s": self.observed.duration_s},
        }


def contenders(fits: list[Fit]) -> list[int]:
    """The fits (indices into `fits`, sorted by score) whose every parameter is fitted:
    the REFINE_CONTENDERS best by their main parameter's fit, and those whose design fits
    the training runs better than that (issue 21's draws 1012 and 1039: frames 38x and
    19x stiffer in pitch than in roll were never among the two best)."""
    return [i for i, f in enumerate(fits) if i < REFINE_CONTENDERS or f.design_better]


class BaseAndSplit(NamedTuple):
    """base_and_split's result."""
    observed: Observed  # with the base model's wheel rates
    comparison: Comparison
    base: Simulated  # every command from start 0
    base_starts: list[Simulated]  # over_starts: every command from each of STARTS starts
    group_errors: np.ndarray  # base_group_errors
    train: np.ndarray
    held: np.ndarray


def base_and_split(observed: Observed, *, timestep: float | None, chain: SensorChain,
                   backend, progress=None, cache=None, signals: bool = False,
                   model_spread: bool = False,
                   held_out: Sequence[str] | None = None) -> BaseAndSplit:
    """The base model simulated on every command from every start, the comparison it
    reads the records with, and the split of training and held-out runs (diagnose's first
    two steps; scripts/bench/profile_fit.py reads them too).  model_spread: the
    comparison's scale also holds the base model's start-to-start spread
    (Comparison.with_model_spread of its STARTS starts).  held_out: the commands to hold
    out (split's; default: split() chooses)."""
    groups = observed.groups
    base_model = model_factory(timestep=timestep)
    base = simulate_groups([(base_model, groups)], observed.duration_s,
                           chain, backend=backend, progress=progress, cache=cache,
                           signals=signals)[0]
    # the records carry no wheel speeds: their wheel orders are read at the base model's
    # actual wheel rates (the command less the servos' droop), where the simulations'
    # are read at their own
    observed = observed.with_wheel_rates(base.wheel_rates_hz)
    comparison = Comparison(observed)
    base_starts = over_starts(base, base_model, groups, list(range(len(groups))),
                              observed.duration_s, chain, backend, progress, cache)
    if model_spread:
        comparison = comparison.with_model_spread(base_starts)
    group_errors = base_group_errors(comparison, base_starts)
    train, held = split(observed, group_errors, held_out)
    return BaseAndSplit(observed, comparison, base, base_starts, group_errors, train, held)


def diagnose_observed(observed: Observed, candidates: list[str] | None = None, *,
                      timestep: float | None = None, chain: SensorChain = SensorChain(),
                      backend, progress: Callable[[int], None] | None = None, cache=None,
                      signals: bool = True, search_starts: int = SEARCH_STARTS,
                      model_spread: bool = False, next_command: bool = True,
                      held_out: Sequence[str] | None = None) -> Diagnosis:
    """Simulates the base model on every command of the measured runs, and, if it
    disagrees with them, fits every candidate cause on the training runs and decides.

    backend: where the simulations run (simulation.backends).  On a backend wider than
    one fit's batch (a Ray cluster) the candidates are fitted concurrently; the numbers
    are the same either way.  cache: a simulation.cache.SimulationCache (finished
    simulations are kept and reused).  signals: simulate the base model and the fit a
    report shows for their time series (not only their features).  search_starts: the
    starts a fit's training error is the median over (SEARCH_STARTS).  model_spread:
    every error is read against the trials' spread and the base model's own
    start-to-start spread together (Comparison.with_model_spread; default: the trials'
    alone).  next_command: when two fits each remove most of the held-out discrepancy and
    none is named (next_command.undecided_pair), simulate both on the swivels the dataset
    lacks and propose the one that tells them apart; when the held-out runs show no
    discrepancy of their own (unconfirmed_lead), simulate the training runs' lead and the
    base model there and propose the swivel where the lead predicts the largest
    discrepancy (Diagnosis.next_commands and next_command_purpose; the reason says it).  held_out: the commands whose runs test the fits (split's held_out: labels,
    or commands alone; default: split() chooses), such as a proposed command once
    recorded: the fits trained without it then predict it.
    """
    if not 1 <= search_starts <= STARTS:
        raise ValueError(f"search_starts={search_starts}: must be 1 to {STARTS}")
    require_spread(observed)
    groups = observed.groups
    all_runs = np.arange(len(observed.run_group))
    names = candidates or sorted(cause_registry.CAUSES)
    observed, comparison, base, base_starts, group_errors, train, held = base_and_split(
        observed, timestep=timestep, chain=chain, backend=backend, progress=progress,
        cache=cache, signals=signals, model_spread=model_spread, held_out=held_out)
    base_error = median_error(comparison, base_starts, all_runs)
    base_held = median_error(comparison, base_starts, held, train)
    # as a fit's train_error: the median over the search's starts
    base_train = median_error(comparison, base_starts[:search_starts], train)
    fits, not_applicable = [], []
    if base_error > Z_CONSISTENT:
        def fit(name):
            try:
                return fit_cause(cause_registry.get(name), comparison, groups,
                                 observed.duration_s, train, held, timestep, chain, backend,
                                 progress, cache, search_starts)
            except cause_registry.NotApplicable as err:
                return {"cause": name, "reason": str(err)}

        one_fit_batch = len(groups) * max(GRID_POINTS, REALISATIONS)
        workers = len(names) if backend.concurrency > one_fit_batch else 1
        with ThreadPoolExecutor(max_workers=workers) as pool:
            for outcome in pool.map(fit, names):  # in the candidates' order
                (fits if isinstance(outcome, Fit) else not_applicable).append(outcome)
            # every parameter of the contenders
            fits.sort(key=lambda f: f.score)
            chosen = contenders(fits)
            for i, refined in zip(chosen, pool.map(lambda i: refine_fit(fits[i], held),
                                                   chosen)):
                fits[i] = refined
            # every fit's intervals against its own start-to-start scatter
            fits = list(pool.map(with_start_scatter, fits))
    fits.sort(key=lambda f: f.score)
    noise = comparison.noise_error()
    for f in fits:
        f.removed = gain(base_held, f.held_out_error, noise)
    pair = fit_pair(fits[0], fits[1], held) if len(fits) > 1 else None
    result, named, reason = verdict(base_error, base_held, fits, noise, base_train=base_train,
                                    n_train=len(train),
                                    held_out_new_commands=holds_out_commands(observed,
                                                                             held_out),
                                    scale=comparison.scale_label)
    if pair is not None and pair["better_than_best"] and result != "explained":
        reason += (f"; the pair {' + '.join(pair['causes'])} does better (held-out "
                   f"{pair['held_out_error']:.2f}): two effects may be at work")
    undecided = undecided_pair(fits, named, base_held, Z_CONSISTENT, MIN_GAIN)
    lead = unconfirmed_lead(fits, named, base_error, base_held, base_train, len(train))
    proposals, purpose = [], None
    if next_command and undecided is not None:
        proposals = separating_commands(*undecided, comparison, groups, observed.duration_s,
                                        chain, backend, cache, progress)
        reason += proposal_note(proposals, *undecided, Z_CONSISTENT)
        purpose = SEPARATE
    elif next_command and lead is not None:
        # the lead against the base model: where the lead's fit predicts a discrepancy the
        # held-out runs of that command would show
        base_model = BaseModel(model_factory(timestep=timestep))
        proposals = separating_commands(lead, base_model, comparison, groups,
                                        observed.duration_s, chain, backend, cache, progress)
        reason += confirmation_note(proposals, lead, Z_CONSISTENT)
        purpose = CONFIRM
    found = Diagnosis(observed, comparison, train, held, base, base_error, base_held, base_train,
                      noise, fits, not_applicable, result, named, reason, pair, group_errors,
                      proposals, None if held_out is None else list(held_out), purpose)
    reference = found.reference
    if signals and reference is not None and reference.simulated.accel[0] is None:
        # read from the cache: simulate the fit a report plots again, for its signals
        again = simulate_groups([(reference.factory, groups)], observed.duration_s, chain,
                                backend=backend, cache=cache)[0]
        if not np.array_equal(again.features, reference.simulated.features, equal_nan=True):
            raise RuntimeError(f"{reference.cause}'s simulation differs from the one stored "
                               f"in {cache.root}: delete that directory and rerun")
        reference.simulated = again
    return found
