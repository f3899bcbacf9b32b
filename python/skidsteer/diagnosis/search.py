"""Each candidate cause fitted on the training runs: its main parameter over a grid and by
Brent (fit_cause), then every parameter by a pattern search and a random geometry's
realisation chosen again where the fit ends (refine_fit), each fit's intervals read
against its own start-to-start scatter (with_start_scatter), and the two best together
(fit_pair).

The residual is on spectral features, not the raw signal: a time-series residual has
phase-wrapping local minima (PLATFORM-NOTES, sysid).  Causes with a random geometry (a
rough floor, eccentric wheels' phases) also choose their realisation on the training
runs: the measured robot has one, and it matters as much as the parameter.
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np
from scipy import optimize

from skidsteer.data.dataset import Group
from skidsteer.diagnosis import causes as cause_registry
from skidsteer.diagnosis.comparison import Comparison, Simulated, model_factory, simulate_groups
from skidsteer.diagnosis.evaluate import (SEARCH_STARTS, STARTS, Evaluations, over_starts,
                                          parameter_key)
from skidsteer.diagnosis.intervals import interval_bound, parameter_intervals
from skidsteer.diagnosis.verdict import REALISATIONS, n_parameters, penalised_score
from skidsteer.simulation.sensor_chain import SensorChain

GRID_POINTS = 5  # across the prior, at the centres of 5 equal slices (log or linear)
# Brent runs until it brackets the minimum to this, in prior coordinates (1 % of the
# prior's (log) range): finer than the narrowest valley measured
REFINE_TOL_UNIT = 0.01
# a guard, not a budget: Brent took 5-12 steps on made-up objectives at this tolerance
REFINE_MAX_STEPS = 25
# the steps a progress bar plans per Brent search; the bar's total is a plan, not a bound
REFINE_STEPS_PLANNED = 8
# every parameter's fit (refine_parameters): probe steps in prior coordinates, a coarse
# pass then a fine one (assumed: a quarter of the prior finds the basin, a tenth resolves it)
REFINE_STEPS = (0.25, 0.1)
# the final profile is taken again around a probe fitting better than its centre at most
# this many times, so the fit has a profile of its own (assumed: 3 bound the cost)
PROFILE_MOVES = 3
# the causes whose every parameter is fitted: the best REFINE_CONTENDERS by their main
# fit's score (assumed: the verdict weighs the best against the runner-up)
REFINE_CONTENDERS = 2
FIT_SEED = 0  # the first realisation (rough floor, wheel phases) a fit simulates


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
    removed: float = 0.0  # verdict.gain: the share of the held-out discrepancy it removes
    # a random geometry's training error at each realisation tried (at the grid's best
    # value): how much the draw matters beside the parameter
    realisation_errors: list[float] = dataclasses.field(default_factory=list)
    # the simulations the fit ran, kept to refine it (refine_fit) without running them again
    evaluator: object = dataclasses.field(default=None, repr=False, compare=False)
    # a cause with a design (Cause.design) whose best design point fits the training runs
    # better than the main fit, each scored with its fitted parameters' penalty: refined
    # whatever its rank (contenders)
    design_better: bool = False
    # the training error at the fit from each of STARTS starts (with_start_scatter; the
    # first search_starts are the search's own): the scatter its intervals are read against
    train_errors_over_starts: list[float] = dataclasses.field(default_factory=list)
    # per fitted parameter, the sides ("below", "above") where its interval runs to the
    # prior's bound with nothing evaluated beyond it (intervals.unprobed_sides)
    unprobed: dict[str, list[str]] = dataclasses.field(default_factory=dict)

    @property
    def fitted(self) -> list[str]:
        return list(self.intervals) or [self.main]


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
    evaluate = Evaluations(cause, comparison, groups, duration_s, train, timestep, chain,
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
        # pick, at the grid's best value, the realisation that fits the training runs
        # best, then search again with it (the score pays ln(REALISATIONS) for the choice)
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
        fit.design_better = bool(penalised_score(min(design), 1 + len(cause.held), len(train))
                                 < penalised_score(fit.train_error, 1, len(train)))
    return fit


def _clipped(cause, values: dict[str, float]) -> dict[str, float]:
    """A cause's parameter set with each parameter clipped to its prior."""
    return {name: float(np.clip(values[name], p.low, p.high))
            for name, p in cause.priors.items()}


def _design_points(cause) -> list[dict[str, float]]:
    """Cause.design's points, clipped to the priors."""
    return [_clipped(cause, values) for values in cause.design()]


def refine_fit(fit: Fit, held: np.ndarray) -> Fit:
    """The fit again with every parameter of its cause fitted (refine_parameters), from
    where the main parameter's fit ended, and a random geometry's realisation chosen
    again there (rechoose_realisation); the same fit when neither applies."""
    cause = cause_registry.get(fit.cause)
    if cause.held and len(fit.fitted) == 1:
        realisation = fit.realisation if fit.realisation is not None else FIT_SEED
        parameters = [cause.main, *cause.held]
        fit_every_parameter(fit.evaluator, cause, fit.parameters, realisation)
        fit = dataclasses.replace(_result(cause, fit.evaluator, parameters, realisation, held),
                                  realisation_errors=fit.realisation_errors,
                                  design_better=fit.design_better)
    return rechoose_realisation(fit, held) if cause.random_realisation else fit


def rechoose_realisation(fit: Fit, held: np.ndarray) -> Fit:
    """A random geometry's fit with its realisation chosen again where the fit ended:
    each realisation at the fit's main value and one fine step (REFINE_STEPS[-1]) either
    side, its other parameters at the fit's; where another realisation fits the training
    runs better, the search again there (Brent on the main parameter, or every parameter
    for a cause that has others) and the better of the two fits.

    fit_cause chooses at the coarse grid's best value, and a realisation that fits there
    need not fit at the value the search then reaches: a floor with larger bumps on the
    wheels' path matches the data at a lower RMS height, wheels at other phases tip a
    turn into shaking at another run-out, and the search keeps that value."""
    cause = cause_registry.get(fit.cause)
    evaluate, main = fit.evaluator, cause.main
    if evaluate is None or fit.realisation is None:
        return fit
    step = REFINE_STEPS[-1]
    unit = main.to_unit(fit.parameters[main.name])
    values = [float(main.from_unit(np.clip(unit + d, 0.0, 1.0))) for d in (-step, 0.0, step)]
    realisations = range(FIT_SEED, FIT_SEED + REALISATIONS)
    points = [(fit.parameters | {main.name: v}, r) for r in realisations for v in values]
    errors = evaluate(points)
    start, realisation = points[int(np.argmin(errors))]
    if realisation == fit.realisation or min(errors) >= fit.train_error:
        return fit
    fitted = [cause.priors[name] for name in fit.fitted]
    if len(fitted) > 1:
        refine_parameters(evaluate, fitted, start, realisation)
    else:
        at = main.to_unit(start[main.name])
        optimize.minimize_scalar(
            lambda u: evaluate([(start | {main.name: float(main.from_unit(u))}, realisation)])[0],
            bounds=(max(0.0, at - step), min(1.0, at + step)), method="bounded",
            options={"xatol": REFINE_TOL_UNIT, "maxiter": REFINE_MAX_STEPS})
    again = _result(cause, evaluate, fitted, realisation, held)
    if again.train_error >= fit.train_error:
        return fit
    return dataclasses.replace(again, realisation_errors=fit.realisation_errors,
                               design_better=fit.design_better)


def with_start_scatter(fit: Fit) -> Fit:
    """The fit with its training error from each of STARTS starts (those the search ran
    read from it, the others' training commands simulated at the fit) and every interval
    read against interval_bound: the bound a single evaluation of the search is within,
    given the scatter the fit's own simulations show.  A fit without its evaluations is
    returned as it is."""
    evaluate = fit.evaluator
    if evaluate is None:
        return fit
    comparison, train = evaluate.comparison, evaluate.train
    realisation = fit.realisation if fit.realisation is not None else FIT_SEED
    # the search's own starts are read, not simulated again (--search-starts above 1)
    known = evaluate.start_errors.get((parameter_key(fit.parameters), realisation), [])[:STARTS]
    first = max(len(known), 1)
    sims = over_starts(fit.simulated, fit.factory, evaluate.groups, evaluate.trained,
                       evaluate.duration_s, evaluate.chain, evaluate.backend,
                       evaluate.progress, evaluate.stored, first=first)
    errors = (known or [float(comparison.error(sims[0].features, train))]) + [
        float(comparison.error(s.features, train)) for s in sims[1:]]
    bound = interval_bound(errors, fit.train_error, len(train), evaluate.search_starts)
    priors = cause_registry.get(fit.cause).priors
    _, intervals, unprobed = parameter_intervals(
        evaluate, {name: priors[name] for name in fit.fitted}, fit.parameters, realisation,
        bound)
    if fit.realisation is not None:
        intervals[fit.main] = over_realisations(evaluate, fit, bound, intervals[fit.main])
    return dataclasses.replace(fit, interval=intervals[fit.main], intervals=intervals,
                               train_errors_over_starts=errors, unprobed=unprobed)


def over_realisations(evaluate: Evaluations, fit: Fit, bound: float,
                      interval: tuple[float, float]) -> tuple[float, float]:
    """A random geometry's main interval widened to every value of it that another
    realisation, at the fit's other parameters, fits within `bound` (on the training
    error squared) among the points evaluated: the data tell the value only as well as
    they tell the realisation (a floor bumpier on the wheels' path matches the data at a
    smaller height; run-outs at other phases shake a turn at another size)."""
    realisations = {r for _, r in evaluate.done} - {fit.realisation}
    values = [value for r in sorted(realisations)
              for value, error in evaluate.profile(fit.main, fit.parameters, r)
              if error ** 2 <= bound]
    return min([interval[0], *values]), max([interval[1], *values])


def _result(cause, evaluate: Evaluations, fitted: list, realisation: int,
            held: np.ndarray) -> Fit:
    """The Fit at the best point evaluated: its errors, the score with one penalty per
    fitted parameter, and every fitted parameter's interval."""
    train = evaluate.train
    params, train_error, _ = evaluate.best(realisation)
    sim = evaluate.complete(params, realisation)
    held_error = evaluate.held_out_error(params, realisation, held)
    profiles, intervals, unprobed = parameter_intervals(evaluate, {p.name: p for p in fitted},
                                                        params, realisation)
    n_params = n_parameters(cause.name, len(fitted))
    return Fit(cause.name, params, cause.main.name, intervals[cause.main.name], train_error,
               held_error, penalised_score(held_error, n_params, len(train)), sim,
               profiles[cause.main.name], realisation if cause.random_realisation else None,
               evaluate.factory(params, realisation), intervals, evaluator=evaluate,
               unprobed=unprobed)


def fit_every_parameter(evaluate, cause, start: dict[str, float], realisation: int) -> None:
    """refine_parameters from `start` (the main parameter's fit) or, for a cause with a
    design (Cause.design: coarse start points over parameters the main fit does not
    vary), from the design's best point where it fits the training runs better; for a
    cause with a mirror (Cause.mirror: parameters that describe the other branch of an
    ambiguity the search cannot cross, e.g. a frame's roll and pitch stiffnesses
    exchanged), the mirror image of that fit too, searched from when it fits the
    training runs better: a search along the axes stays in the basin it starts in."""
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


def refine_parameters(evaluate: Evaluations, parameters, start: dict[str, float],
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


def contenders(fits: list[Fit]) -> list[int]:
    """The fits (indices into `fits`, sorted by score) whose every parameter is fitted:
    the REFINE_CONTENDERS best by their main parameter's fit, and those whose design fits
    the training runs better than that (a cause the one-dimensional fit misses)."""
    return [i for i, f in enumerate(fits) if i < REFINE_CONTENDERS or f.design_better]


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
    score = penalised_score(held_error, n_params, len(train))
    return {"causes": [first.cause, second.cause],
            "parameters": {first.cause: first.parameters, second.cause: second.parameters},
            "train_error": comparison.error(sim.features, train),
            "held_out_error": held_error, "score": score,
            "better_than_best": bool(score < first.score)}
