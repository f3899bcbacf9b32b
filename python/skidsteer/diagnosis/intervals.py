"""A fitted parameter's interval: the values whose training error is within a profile
bound of the fit's, read off the error's profile through the fit."""

from __future__ import annotations

import numpy as np

from skidsteer.diagnosis.evaluate import SEARCH_STARTS
from skidsteer.diagnosis.verdict import profile_factor

# a value this close to a prior's bound (in prior coordinates) is at it (unprobed_sides):
# the search clips its probes to the bounds exactly, so any margin above rounding does
UNIT_EDGE = 1e-9


def interval_bound(train_errors_over_starts, train_error: float, n_train: int,
                   search_starts: int = SEARCH_STARTS) -> float:
    """The bound on one evaluation's training error squared that a fit's intervals read:
    the profile bound (profile_factor) on the median over STARTS starts of the fit's
    training error squared, plus one standard deviation of it across the starts; never
    below the profile bound on the search's own value (train_error).

    A search evaluates each point once, and on a stick-slip floor one evaluation is one
    draw of the model's run-to-run scatter: a bound on the best value alone is the
    neighbourhood of one lucky draw.  The median takes the level the best point scores
    typically, the standard deviation the scatter of the one draw each other point had
    (assumed: one sigma, as Delta chi^2 = 1 is), divided by sqrt(search_starts) where each
    evaluation is a median over that many starts (the scatter of a mean of that many:
    approximate for a median)."""
    e2 = np.square(np.asarray(train_errors_over_starts, dtype=float))
    scatter = float(np.std(e2, ddof=1)) / np.sqrt(search_starts) if len(e2) > 1 else 0.0
    return max(float(train_error) ** 2 * profile_factor(n_train),
               float(np.median(e2)) * profile_factor(n_train) + scatter)


def interval(evaluations: list[tuple[float, float]], n_train: int, parameter,
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
            inside = [r for r in parabola_roots(c[[k, i, j]], e2[[k, i, j]] - bound)
                      if min(c[i], c[j]) <= r <= max(c[i], c[j])]
            if inside:
                crossing = min(inside, key=lambda r: abs(r - crossing))
        return float(inv(crossing))

    return edge(lo_i, lo_i - 1, lo_i + 1), edge(hi_i, hi_i + 1, hi_i - 1)


def unprobed_sides(evaluations: list[tuple[float, float]], parameter,
                   interval: tuple[float, float]) -> list[str]:
    """The sides of `interval` ("below", "above") that run to the prior's bound for want
    of a probe: interval() opens a side when no evaluated value beyond its last value
    inside the bound crosses it, and this is the case where the outermost value
    evaluated on that side lies inside the prior (the search stopped short of it),
    not at its bound (where an open side is the data's).  Most such sides belong to fits
    of the main parameter alone, whose grid points are slice middles (nothing evaluated
    between the outermost one and the prior's bound unless Brent went there); a refined
    fit has one where refine_parameters' profile moves ran out (search.PROFILE_MOVES)."""
    units = [parameter.to_unit(v) for v, _ in evaluations]
    sides = []
    if interval[0] <= parameter.low and min(units) > UNIT_EDGE:
        sides.append("below")
    if interval[1] >= parameter.high and max(units) < 1 - UNIT_EDGE:
        sides.append("above")
    return sides


def unprobed_note(sides: list[str] | None) -> str:
    """An interval's sides that end at the prior's bound for want of a probe
    (unprobed_sides), as a report's note: the search did not go there, the data may
    well bound it."""
    return f"; not probed {' or '.join(sides)}" if sides else ""


def parabola_roots(x: np.ndarray, y: np.ndarray) -> list[float]:
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


def parameter_intervals(evaluate, priors: dict, params: dict[str, float], realisation: int,
                        bound: float | None = None) -> tuple[dict, dict, dict]:
    """(profiles, intervals, unprobed sides) of the parameters `priors` names (name ->
    Parameter) through `params`, from an evaluate.Evaluations: each profile's interval
    (against `bound` where given) and its sides open for want of a probe (unprobed_sides,
    only those that have one)."""
    profiles = {name: evaluate.profile(name, params, realisation) for name in priors}
    intervals = {name: interval(profiles[name], len(evaluate.train), prior, bound)
                 for name, prior in priors.items()}
    sides = {name: unprobed_sides(profiles[name], priors[name], intervals[name])
             for name in priors}
    return profiles, intervals, {name: s for name, s in sides.items() if s}
