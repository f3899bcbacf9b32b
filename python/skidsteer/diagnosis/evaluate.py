"""A model's errors on the measured runs: simulated in batches, over several starts, kept.

``Evaluations`` holds the training errors of one cause's models (a search's memory);
``over_starts`` and ``median_error`` give the error the verdict reads, the median over
STARTS simulated starts of each command (one simulation is one draw of the model's
run-to-run scatter, as one trial is of the robot's).
"""

from __future__ import annotations

import numpy as np

from skidsteer.data.dataset import Group
from skidsteer.diagnosis.comparison import Comparison, Simulated, model_factory, simulate_groups
from skidsteer.simulation.sensor_chain import SensorChain

# the starts the verdict's errors are the median over (comparison.start_state 0..STARTS-1:
# rest, then repeat-trial starts); assumed: 5, the fewest for which two starts in a rare
# regime do not move the median
STARTS = 5
# the starts a search's training error is the median over (diagnose --search-starts); 1,
# the start from rest: more guard a search against a rare start at as many times its cost
SEARCH_STARTS = 1


def parameter_key(params: dict[str, float]) -> tuple:
    """A parameter set as a hashable key (sorted names, float values)."""
    return tuple(sorted((k, float(v)) for k, v in params.items()))


def placed(part: Simulated, which: list[int], into: Simulated | int) -> Simulated:
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


def groups_of(comparison: Comparison, runs: np.ndarray) -> list[int]:
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
    return [sim, *(placed(part, which, sim) for part in parts)]


def median_error(comparison: Comparison, sims: list[Simulated], runs: np.ndarray,
                 bias_runs: np.ndarray | None = None) -> float:
    """Comparison.error on `runs`, the median over the simulations of several starts."""
    return float(np.median([comparison.error(s.features, runs, bias_runs) for s in sims]))


def base_group_errors(comparison: Comparison, sims: list[Simulated]) -> np.ndarray:
    """The base model's error on each command group (median over the starts' sims), the
    centripetal offset taken from the other groups, as a held-out group's is (from its
    own runs when it is the only group)."""
    group_of = comparison.observed.run_group
    runs = np.arange(len(group_of))
    return np.array([median_error(comparison, sims, runs[group_of == g],
                                  runs[group_of != g] if np.any(group_of != g) else None)
                     for g in range(len(comparison.observed.groups))])


class Evaluations:
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
        self.trained = groups_of(comparison, train)
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
        keys = [(parameter_key(p), int(r)) for p, r in points]
        todo = list(dict.fromkeys(k for k in keys if k not in self.done))
        if todo:
            for key, parts in zip(todo, self._simulate(todo, self.trained, self.search_starts)):
                sims = [placed(part, self.trained, len(self.groups)) for part in parts]
                self.start_errors[key] = [float(self.comparison.error(s.features, self.train))
                                          for s in sims]
                self.done[key] = (float(np.median(self.start_errors[key])), sims[0])
        return [self.done[k][0] for k in keys]

    def complete(self, params: dict[str, float], realisation: int) -> Simulated:
        """The point's simulation with every command (the held-out ones added)."""
        key = (parameter_key(params), int(realisation))
        self([(params, realisation)])
        error, sim = self.done[key]
        if key not in self.completed:
            missing = [i for i in range(len(self.groups)) if i not in self.trained]
            if missing:
                sim = placed(self._simulate([key], missing)[0][0], missing, sim)
                self.done[key] = (error, sim)
            self.completed.add(key)
        return sim

    def held_out_error(self, params: dict[str, float], realisation: int,
                       held: np.ndarray) -> float:
        """The point's error on the held-out runs, the median over STARTS starts."""
        key = (parameter_key(params), int(realisation))
        if key not in self.held_errors:
            self.held_errors[key] = self.held_out_over_starts(
                self.complete(params, realisation), self.factory(params, realisation), held)
        return self.held_errors[key]

    def held_out_over_starts(self, sim: Simulated, factory, held: np.ndarray) -> float:
        """The held-out error of factory's model, sim its simulation from start 0: the
        median over STARTS starts (over_starts), the bias taken on the training runs."""
        sims = over_starts(sim, factory, self.groups, groups_of(self.comparison, held),
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
        others = {k: v for k, v in parameter_key(at) if k != name}
        return sorted((dict(key)[name], err) for (key, r), (err, _) in self.done.items()
                      if r == realisation
                      and {k: v for k, v in key if k != name} == others)
