"""How a run-out's wheel phases shape what diagnose sees (issue 21's missed run-outs).

wheel_eccentricity offsets each wheel's tire by the eccentricity at a phase per wheel
(its realisation); a fit tries REALISATIONS random draws of the four phases.  A swivel
turns the left wheels back and the right ones forward, and a repeat trial starts with
the left wheels turned by -theta and the right by +theta (simulation.run.trial_start),
so what a dataset can know of the phases is three numbers: the front-rear phase
difference on each side and the four phases' sum.  For each case this script simulates
the truth (the generalisation benchmark's draw, replayed as the ceiling benchmark does)
with its phases turned as a trial start turns them (the three numbers kept), and with
each of the three changed, and prints the training and held-out errors (from rest, the
base model's split) beside `--realisations` random draws at the truth's eccentricity,
which is what a fit chooses among.  With `--grid N` it prints instead the errors of
N^3 sets of the front-left, front-right and rear-right wheels' phase shifts (the three
numbers) from realisation 0: how loosely the training runs tell realisations apart and
how rugged the error is over them (why a fit of the three was reverted: docs/diagnose.md).

    python scripts/runout_phases.py --out DIR draw-1167 draw-1149
    python scripts/runout_phases.py --out DIR --grid 3 draw-1167 draw-1149

DIR: the generalisation benchmark's --out (its datasets are regenerated there when
missing; simulations are cached in DIR/simulations).
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent / "bench"))
from bench_diagnose_ceiling import Measured  # noqa: E402
from bench_diagnose_generalisation import case_of, newest_rows  # noqa: E402

from skidsteer.diagnosis import causes  # noqa: E402
from skidsteer.diagnosis.causes.wheel_eccentricity import (offset_wheels,  # noqa: E402
                                                          wheel_phases)
from skidsteer.diagnosis.comparison import model_factory  # noqa: E402
from skidsteer.diagnosis.synth import truth_edit  # noqa: E402
from skidsteer.robot import roles_of  # noqa: E402

ROWS = Path(__file__).resolve().parents[1] / "docs" / "diagnose-generalisation.jsonl"


def phased(phases: np.ndarray, eccentricity_m: float):
    """wheel_eccentricity's edit with the wheels' phases given (tire.find_wheels order)."""
    return lambda spec: offset_wheels(spec, eccentricity_m, lambda n_wheels: phases)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="+", help="generalisation benchmark cases (run-outs)")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--realisations", type=int, default=24)
    ap.add_argument("--grid", type=int, default=0, metavar="N",
                    help="instead: the N^3 sets of the front-left, front-right and rear-right "
                         "wheels' phase shifts (N levels over a turn each; the three numbers "
                         "a dataset can tell) from realisation 0 at the truth's eccentricity: "
                         "the best six and the spread of their errors")
    args = ap.parse_args(argv)
    rows = newest_rows(ROWS)
    cause = causes.get("wheel_eccentricity")
    for name in args.cases:
        case = case_of(rows[name])
        if case["effect"] != cause.name:
            raise SystemExit(f"{name}: its hidden effect is {case['effect']}, not a run-out")
        measured = Measured(case, args.out, 3, 20.0, 2)
        edit, values = truth_edit(case["effect"], case["params"],
                                  np.random.default_rng(case["seed"]), "clear", "prior")
        # the truth's realisation: truth_edit's first draw, the phases apply makes of it
        realisation = int(np.random.default_rng(case["seed"]).integers(2**31))
        phases = wheel_phases(realisation, 4)
        e = values["eccentricity_m"]
        m = model_factory()(measured.groups[0].setup)
        parts = roles_of(m)  # wheels in tire.find_wheels order
        side = np.array(parts.wheel_side, dtype=float)  # +1 left
        front = parts.wheel_position_m[:, 0] > 0
        left_front = np.where((side > 0) & front, np.pi, 0.0)
        variants = {"the truth": edit}
        for theta in (0.7, 2.1, 4.0):
            variants[f"turned {theta} rad (a trial start)"] = phased(phases - side * theta, e)
        variants["sum + pi/2 (right wheels + pi/2)"] = phased(
            phases + np.where(side < 0, np.pi / 2, 0.0), e)
        variants["left front-rear difference + pi"] = phased(phases + left_front, e)
        variants["mirrored (all phases negated)"] = phased(-phases, e)
        print(f"{name}: {e * 1e3:.3f} mm, {case['floor']}, {case['omegas']} deg/s")
        if args.grid:
            shifted = [np.flatnonzero((side > 0) & front)[0],
                       np.flatnonzero((side < 0) & front)[0],
                       np.flatnonzero((side < 0) & ~front)[0]]
            print_grid(measured, wheel_phases(0, len(side)), shifted, e, args.grid)
            continue

        def show(label, factory):
            print(f"  {label:38s} " + shown(*errors(measured, factory)), flush=True)

        show("the base model", model_factory())
        for label, variant in variants.items():
            show(label, model_factory(variant))
        for r in range(args.realisations):
            show(f"realisation {r}", model_factory(cause.edit(values, r)))
    return 0


def errors(measured: Measured, factory) -> tuple[float, float]:
    """The model's training and held-out errors (from rest, the base model's split)."""
    sim = measured.simulated(factory)
    comparison, train, held = measured.comparison, measured.train, measured.held
    return comparison.error(sim.features, train), comparison.error(sim.features, held, train)


def shown(train_error: float, held_error: float) -> str:
    return f"training {train_error:6.2f}  held-out {held_error:6.2f}"


def print_grid(measured: Measured, phases: np.ndarray, shifted: list[int], e: float,
               levels: int) -> None:
    """The training and held-out errors of the levels^3 sets of phase shifts of the wheels
    `shifted` (indices into phases) at eccentricity e: how far the training runs tell
    realisations apart, and how rugged the error is over them."""
    steps = np.arange(levels) / levels * 2 * np.pi
    steps = np.where(steps > np.pi, steps - 2 * np.pi, steps)
    found = []
    for point in itertools.product(steps, repeat=len(shifted)):
        turned = phases.copy()
        turned[shifted] += point
        found.append((*errors(measured, model_factory(phased(turned, e))), point))
    found.sort()
    print(f"  {len(found)} phase-shift sets (front-left, front-right, rear-right) "
          f"from realisation 0:")
    for train_error, held_error, point in found[:6]:
        print(f"  shifts {np.round(point, 2)} rad  " + shown(train_error, held_error))
    training = [err[0] for err in found]
    print(f"  training errors: median {np.median(training):.2f}, worst {max(training):.2f}",
          flush=True)


if __name__ == "__main__":
    sys.exit(main())
