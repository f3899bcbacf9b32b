"""Diagnose: which candidate cause explains what the simulation gets wrong, and how well.

1. The base model simulates every command group of the dataset from STARTS starts
   (evaluate.over_starts); its error is the median over them of the RMS z-score of the
   features against the trials' spread (comparison.Comparison).
2. The runs are split into training and held-out runs (split.split).
3. Each candidate cause (diagnosis.causes) is fitted on the training runs by its main
   parameter (search.fit_cause); the best (search.contenders) then have every
   parameter fitted (search.refine_fit; a random geometry's realisation is chosen again
   where the fit ends), and every fit's intervals are read against its own
   start-to-start scatter (search.with_start_scatter).
4. Each fit is scored on the held-out runs with a penalty per fitted parameter; the two
   best are also simulated together (search.fit_pair); the verdict follows the rules of
   verdict.py.  When the data leave two fits undecided, or the held-out runs cannot
   confirm the training runs' lead, the command to record next is proposed
   (next_command).

``diagnose_observed`` does all of it on measured runs already reduced to features;
reports.diagnosis reads a dataset into it and writes the outputs.
"""

from __future__ import annotations

import dataclasses
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, NamedTuple, Sequence

import numpy as np

from skidsteer.diagnosis import causes as cause_registry
from skidsteer.diagnosis.comparison import (Comparison, Observed, Simulated, model_factory,
                                            require_spread, simulate_groups)
from skidsteer.diagnosis.evaluate import (SEARCH_STARTS, STARTS, base_group_errors,
                                          median_error, over_starts)
from skidsteer.diagnosis.next_command import (CONFIRM, SEPARATE, BaseModel,
                                              confirmation_note, proposal_note,
                                              separating_commands, undecided_pair)
from skidsteer.diagnosis.search import (GRID_POINTS, PROFILE_MOVES, REFINE_CONTENDERS,
                                        REFINE_STEPS, REFINE_STEPS_PLANNED, Fit, contenders,
                                        fit_cause, fit_pair, refine_fit, with_start_scatter)
from skidsteer.diagnosis.split import holds_out_commands, split
from skidsteer.diagnosis.summary import summary_of
from skidsteer.diagnosis.verdict import (MIN_GAIN, REALISATIONS, Z_CONSISTENT, gain,
                                         unconfirmed_lead, verdict)
from skidsteer.simulation.sensor_chain import SensorChain


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
        """The verdict, the fitted parameters, the ranking and the gain as JSON-ready data
        (summary.summary_of)."""
        return summary_of(self)


def simulations_planned(names: list[str], observed: Observed,
                        search_starts: int = SEARCH_STARTS,
                        held_out: Sequence[str] | None = None) -> int:
    """How many command simulations diagnosing `observed` with these candidates is planned
    to take (a progress bar's total; a plan, not a bound: Brent is planned
    REFINE_STEPS_PLANNED steps and may take up to REFINE_MAX_STEPS, and refinements and
    profile moves are planned in full where a search often stops early): the base model
    on every command; per cause the grid, the Brent steps, for a random geometry the
    other realisations and a second grid, and every realisation again at three values
    around its fit (search.rechoose_realisation), for a cause with a design its points; for the
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
                   # rechoose_realisation, planned as if it were a contender (it runs for
                   # the contenders only) that finds no better realisation
                   + (3 * REALISATIONS - 1 if c.random_realisation else 0)
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
    two steps).  model_spread: the comparison's scale also holds the base model's
    start-to-start spread (Comparison.with_model_spread of its STARTS starts).  held_out:
    the commands to hold out (split's; default: split() chooses)."""
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


def base_error_over_starts(observed: Observed, *, timestep: float | None, chain: SensorChain,
                           backend, progress=None) -> tuple[Observed, Comparison, Simulated,
                                                            float]:
    """The base model alone on every command (compare): (observed with the base model's
    wheel rates, the comparison, the simulation from start 0 with its signals, and the
    error over all runs, the median over STARTS starts as diagnose reads it)."""
    groups, factory = observed.groups, model_factory(timestep=timestep)
    base = simulate_groups([(factory, groups)], observed.duration_s, chain, progress=progress,
                           backend=backend)[0]
    observed = observed.with_wheel_rates(base.wheel_rates_hz)  # as diagnose_observed does
    comparison = Comparison(observed)
    all_runs = np.arange(len(observed.run_group))
    error = median_error(comparison, over_starts(
        base, factory, groups, list(range(len(groups))), observed.duration_s, chain,
        backend, progress, None), all_runs)
    return observed, comparison, base, error


def base_verdict(base_error: float) -> str:
    """compare's verdict on the base model alone: "no-discrepancy" within Z_CONSISTENT,
    else "discrepancy"."""
    return "no-discrepancy" if base_error <= Z_CONSISTENT else "discrepancy"


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
    discrepancy (Diagnosis.next_commands and next_command_purpose; the reason says it).
    held_out: the commands whose runs test the fits (split's held_out: labels, or
    commands alone; default: split() chooses), such as a proposed command once
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
