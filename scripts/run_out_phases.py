"""Is a wheel run-out's size told apart from its wheels' phases?  A probe of one
wheel_eccentricity draw of the generalisation benchmark.

Prints, for the draw's training runs (diagnose's training error, one start):

1. the wheels' phasor sums (heave, pitch, roll in an in-place turn, wheel-units, at
   most 4) of the truth's phases and of the fit's eight realisations; and the training
   error at phase sets parallel to the truth's sums but shorter, at the truth's run-out
   and at the run-out that keeps the product (a first-order picture: if the data read
   the run-out through these sums only, the product would fit like the truth);
2. the training error along the run-out for the truth's phases, the realisation that
   fits best at the row's fitted value, and the seeds given (--seeds);
3. with --more-seeds N: the training error of N other phase sets at the row's fitted
   run-out, and how it follows their phasor sums;
4. with --steps: the steady band powers of the command the run-out moves most, for the
   base model and the truth at several time steps (is the effect the step's?);
5. with --fit-phases: the run-out and three phase offsets (wheels 1-3 against wheel
   0's; in an in-place turn a shift of every phase is a shift in time) fitted by
   diagnose's pattern search from the realisation of 2.

    python scripts/run_out_phases.py --draw draw-1351 --out /tmp/run-out-phases \\
        --seeds 31 --more-seeds 64 --steps --fit-phases
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).parent / "bench"))
import bench_diagnose_generalisation as generalisation  # noqa: E402

from skidsteer.diagnosis import causes  # noqa: E402
from skidsteer.diagnosis.causes import Parameter  # noqa: E402
from skidsteer.diagnosis.causes.wheel_eccentricity import (ECCENTRICITY,  # noqa: E402
                                                            offset_wheels, wheel_phases)
from skidsteer.diagnosis.comparison import model_factory, simulate_groups  # noqa: E402
from skidsteer.diagnosis.diagnose import base_and_split  # noqa: E402
from skidsteer.diagnosis.evaluate import Evaluations  # noqa: E402
from skidsteer.diagnosis.search import refine_parameters  # noqa: E402
from skidsteer.diagnosis.verdict import REALISATIONS  # noqa: E402
from skidsteer.features.extract import comparison_feature_names  # noqa: E402
from skidsteer.reports.diagnosis import _observed  # noqa: E402
from skidsteer.robot import load_model, tire  # noqa: E402
from skidsteer.simulation.backends import LocalBackend  # noqa: E402
from skidsteer.simulation.sensor_chain import SensorChain  # noqa: E402

ROWS = Path(__file__).parents[1] / "docs" / "diagnose-generalisation.jsonl"
PARALLEL_DEG = 4.0  # how near the truth's direction a phase set counts as parallel
LENGTHS = (0.5, 0.75)  # the shorter phasor lengths probed, of the truth's
SWEEP = (0.55, 0.77, 0.88, 1.0, 1.1, 1.2, 1.35, 1.65)  # run-outs along 2, of the truth's
STEPS_S = (1e-4, 5e-5, 2.5e-5)  # the model's step and two finer
STEADY_FEATURES = 3  # the command's features printed in 4 (the base model's largest |z|)
PHASE_OFFSETS = tuple(
    Parameter(f"phase_offset_{k}_rad", -np.pi, np.pi, 0.0, log=False,
              source="a wheel's run-out phase against its realisation's, any angle")
    for k in (1, 2, 3))


class PhasedRunOut:
    """wheel_eccentricity with each wheel's phase its realisation's plus an offset
    (phase_offset_k_rad for wheels 1-3): what Evaluations reads of a cause."""

    def edit(self, params, seed: int = 0):
        offsets = np.array([0.0, *(params.get(p.name, 0.0) for p in PHASE_OFFSETS)])

        def edit(spec):
            offset_wheels(spec, params["eccentricity_m"],
                          lambda n: wheel_phases(seed, n) + offsets[:n])
        return edit


def wheel_signs() -> tuple[np.ndarray, np.ndarray]:
    """(front +1 / rear -1, left +1 / right -1) of each wheel, tire.find_wheels order."""
    m = load_model()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    wheels = tire.find_wheels(m, tire.instance_id(m))
    offset = np.array([d.xpos[m.jnt_bodyid[w.joint]] for w in wheels]) - d.subtree_com[1]
    return np.sign(offset[:, 0]), np.sign(offset[:, 1])


def phasor_sums(phases_rad: np.ndarray, front: np.ndarray, left: np.ndarray) -> np.ndarray:
    """(heave, pitch, roll) lengths of the wheels' run-out phasors in an in-place turn
    (the left wheels turn backwards: their phasors conjugate), in wheel-units."""
    z = np.exp(1j * phases_rad)
    z = np.where(left > 0, np.conj(z), z)
    return np.abs([z.sum(), (front * z).sum(), (left * z).sum()])


def parallel_seeds(truth: np.ndarray, front, left) -> dict[float, tuple[int, float]]:
    """Seeds whose phasor sums point within PARALLEL_DEG of the truth's, one per LENGTHS
    (length of the truth's): {length: (seed, its length)}."""
    found: dict[float, tuple[int, float]] = {}
    for seed in range(1_000_000):
        q = phasor_sums(wheel_phases(seed, len(front)), front, left)
        if q @ truth < np.cos(np.radians(PARALLEL_DEG)) * np.linalg.norm(q) * np.linalg.norm(truth):
            continue
        k = float(np.linalg.norm(q) / np.linalg.norm(truth))
        for length in LENGTHS:
            if abs(k - length) < 0.05 and length not in found:
                found[length] = (seed, k)
        if len(found) == len(LENGTHS):
            break
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draw", default="draw-1351")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--rows", type=Path, default=ROWS)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--seeds", type=int, nargs="*", default=[])
    parser.add_argument("--more-seeds", type=int, default=0)
    parser.add_argument("--steps", action="store_true")
    parser.add_argument("--fit-phases", action="store_true")
    args = parser.parse_args()
    rows = [json.loads(line) for line in args.rows.read_text().splitlines() if line.strip()]
    row = [r for r in rows if r["case"] == args.draw][-1]
    if row["effect"] != "wheel_eccentricity":
        raise SystemExit(f"{args.draw} hides {row['effect']}, not a wheel run-out")
    front, left = wheel_signs()
    truth_seed = int(np.random.default_rng(row["seed"]).integers(2**31))  # truth_edit's draw
    truth = phasor_sums(wheel_phases(truth_seed, len(front)), front, left)
    e_truth = row["truth"]["eccentricity_m"]
    e_fit = next(f for f in row["ranking"]
                 if f["cause"] == "wheel_eccentricity")["parameters"]["eccentricity_m"]
    print(f"{args.draw}: run-out {e_truth * 1e3:.3f} mm (the row's fit {e_fit * 1e3:.3f} mm), "
          f"phasor sums (heave, pitch, roll) {np.round(truth, 2)}")
    for r in range(REALISATIONS):
        print(f"  realisation {r}: {np.round(phasor_sums(wheel_phases(r, 4), front, left), 2)}")

    data = args.out / "datasets" / args.draw
    if not (data / "runs.csv").exists():
        generalisation.generate(generalisation.case_of(row), args.out, 3, 20.0, args.threads)
    observed = _observed(data, None)
    backend, chain = LocalBackend(args.threads), SensorChain()
    split = base_and_split(observed, timestep=None, chain=chain, backend=backend,
                           held_out=row["held_out_groups"])
    cause = causes.get("wheel_eccentricity")
    evaluate = Evaluations(cause, split.comparison, observed.groups, observed.duration_s,
                           split.train, None, chain, backend, None, None, 1)

    def error(e: float, seed: int) -> float:
        return evaluate([(cause.parameters(e), seed)])[0]

    print(f"\n1. base model: training error {row['base_train']:.2f}; the truth's phases at "
          f"{e_truth * 1e3:.3f} mm: {error(e_truth, truth_seed):.2f}")
    for _, (seed, k) in sorted(parallel_seeds(truth, front, left).items()):
        print(f"   parallel, {k:.2f}x as long (seed {seed}): {error(e_truth, seed):.2f} at "
              f"{e_truth * 1e3:.3f} mm, {error(e_truth / k, seed):.2f} at "
              f"{e_truth / k * 1e3:.3f} mm")

    errors = evaluate([(cause.parameters(e_fit), r) for r in range(REALISATIONS)])
    best = int(np.argmin(errors))
    values = [e_truth * f for f in SWEEP]
    print(f"\n2. training error along the run-out (mm: {' '.join(f'{v * 1e3:.2f}' for v in values)})")
    for label, seed in [("the truth's phases", truth_seed),
                        (f"realisation {best} (best at the row's fit)", best),
                        *((f"seed {s}", s) for s in args.seeds)]:
        sweep = evaluate([(cause.parameters(v), seed) for v in values])
        print(f"   {label:34s} " + " ".join(f"{x:.2f}" for x in sweep))

    if args.more_seeds:
        seeds = list(range(REALISATIONS, REALISATIONS + args.more_seeds))
        errs = np.array(evaluate([(cause.parameters(e_fit), s) for s in seeds]))
        sums = np.array([phasor_sums(wheel_phases(s, len(front)), front, left) for s in seeds])
        cos = sums @ truth / np.linalg.norm(sums, axis=1) / np.linalg.norm(truth)
        length = np.linalg.norm(sums, axis=1) / np.linalg.norm(truth)
        top = np.argsort(errs)[:4]
        print(f"\n3. {len(seeds)} more phase sets at the row's fit {e_fit * 1e3:.3f} mm: "
              f"training error median {np.median(errs):.2f}, best {errs.min():.2f}; "
              f"correlation with the cosine to the truth's sums {np.corrcoef(cos, errs)[0, 1]:+.2f}, "
              f"with their length {np.corrcoef(length, errs)[0, 1]:+.2f}")
        at_truth = evaluate([(cause.parameters(e_truth), seeds[i]) for i in top])
        for i, e in zip(top, at_truth):
            print(f"   seed {seeds[i]}: {errs[i]:.2f} (cosine {cos[i]:.2f}, length "
                  f"{length[i]:.2f}); at the truth's run-out {e:.2f}")

    if args.steps:
        steps(observed, split, cause, truth_seed, e_truth, best, e_fit)

    if args.fit_phases:
        fit_phases(row, split, observed, chain, backend, best, e_fit, front, left, truth,
                   e_truth)


def steps(observed, split, cause, truth_seed: int, e_truth: float, best: int,
          e_fit: float) -> None:
    """4: the command the base model misses most, its steady band powers at STEPS_S."""
    z = np.abs(split.comparison.z_scores(split.base.features, split.train))
    group_of_run = observed.run_group[split.train]
    worst = int(group_of_run[np.argmax(np.nanmean(z ** 2, axis=1))])
    names = comparison_feature_names()
    steady = [i for i in np.argsort(-np.nan_to_num(
        np.nanmean(z[group_of_run == worst], axis=0))) if names[i].startswith("steady")]
    shown = steady[:STEADY_FEATURES]
    group = observed.groups[worst]
    print(f"\n4. {group.label}: steady band powers (log10, (m/s^2)^2) and the mean yaw rate")
    models = [("base model", None), ("truth, 0.77x", (0.77 * e_truth, truth_seed)),
              ("truth", (e_truth, truth_seed)), (f"realisation {best}, the fit", (e_fit, best))]
    for step in STEPS_S:
        jobs = [(model_factory(None if p is None else cause.edit(cause.parameters(p[0]), p[1]),
                               step), [group]) for _, p in models]
        for (label, _), sim in zip(models, simulate_groups(jobs, observed.duration_s,
                                                           nthread=1, signals=False)):
            powers = " ".join(f"{names[i]} {np.log10(max(sim.features[0, i], 1e-12)):.2f}"
                              for i in shown)
            print(f"   step {step:g} s, {label:26s} yaw {sim.mean_yaw_rate_deg_s[0]:.2f} deg/s; "
                  f"{powers}")


def fit_phases(row, split, observed, chain, backend, realisation: int, e_fit: float, front,
               left, truth, e_truth) -> None:
    """5: the run-out and three phase offsets fitted by diagnose's pattern search."""
    evaluate = Evaluations(PhasedRunOut(), split.comparison, observed.groups,
                           observed.duration_s, split.train, None, chain, backend, None, None,
                           1)
    start = {"eccentricity_m": e_fit, **{p.name: 0.0 for p in PHASE_OFFSETS}}
    refine_parameters(evaluate, [ECCENTRICITY, *PHASE_OFFSETS], start, realisation)
    params, error, _ = evaluate.best(realisation)
    offsets = np.array([0.0, *(params[p.name] for p in PHASE_OFFSETS)])
    sums = phasor_sums(wheel_phases(realisation, len(front)) + offsets, front, left)
    print(f"\n5. phases fitted from realisation {realisation} ({len(evaluate.done)} "
          f"evaluations): run-out {params['eccentricity_m'] * 1e3:.3f} mm "
          f"({params['eccentricity_m'] / e_truth:.2f}x the truth's), training error "
          f"{error:.2f}; phasor sums {np.round(sums, 2)} (the truth's {np.round(truth, 2)})")


if __name__ == "__main__":
    main()
