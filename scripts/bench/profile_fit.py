"""One cause's errors along its main parameter, on one dataset: what diagnose's search reads.

For each value: the training error from the start at rest (the search's, SEARCH_STARTS 1),
the same from each of the STARTS starts and their median, and the held-out error the
verdict reads (the median over the starts).  The split of training and held-out runs is
diagnose's.  Use it when a fit lands off a known truth, or to see how well the training
commands pin a parameter down: a flat stretch of training error over which the held-out
error changes is a value the training runs cannot choose and the held-out command can.

    python scripts/bench/profile_fit.py DATASET --cause slip_lambda_max \
        --values 0.004 0.0055 0.0066 0.009
    # a draw of the generalisation benchmark, generated first into OUT/datasets/draw-SEED
    python scripts/bench/profile_fit.py --draw 1191 --first-seed 1177 --out /tmp/pgen \
        --cause slip_lambda_max --values 0.0062 0.0066 0.007 0.009

Each value costs (training commands + held-out commands) x STARTS simulations.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from skidsteer.diagnosis import causes
from skidsteer.diagnosis import fit as F
from skidsteer.reports.diagnosis import _observed
from skidsteer.simulation.backends import LocalBackend
from skidsteer.simulation.cache import SimulationCache
from skidsteer.simulation.sensor_chain import SensorChain


def profile(dataset: Path, cause_name: str, values: list[float], *, realisation: int = 0,
            held_values: dict[str, float] | None = None, threads: int = 2,
            cache_dir: Path | None = None, timestep: float | None = None) -> dict:
    """The base model's errors and, per value of the cause's main parameter, the training
    errors from each start and the held-out error (diagnose's split and medians); the
    cause's other parameters at held_values, or their priors' values; the models (base
    and cause) at timestep (None: the model's own), the records as they are."""
    backend, chain = LocalBackend(threads), SensorChain()
    cache = SimulationCache(cache_dir) if cache_dir else None
    observed, comparison, _, base_starts, _, train, held = F.base_and_split(
        _observed(dataset, None), timestep=timestep, chain=chain, backend=backend, cache=cache)
    groups, duration = observed.groups, observed.duration_s
    cause = causes.get(cause_name)
    evaluate = F._Evaluations(cause, comparison, groups, duration, train, timestep, chain,
                              backend, None, cache, search_starts=F.STARTS)
    rows = []
    for value in values:
        params = cause.parameters(float(value), dict(held_values or {}))
        key = (F._parameter_key(params), realisation)
        parts = evaluate._simulate([key], evaluate.trained, F.STARTS)[0]
        sims = [F._placed(part, evaluate.trained, len(groups)) for part in parts]
        per_start = [float(comparison.error(s.features, train)) for s in sims]
        evaluate.done[key] = (float(np.median(per_start)), sims[0])
        rows.append({"value": float(value), "train_per_start": per_start,
                     "train_from_rest": per_start[0],
                     "train_median": float(np.median(per_start)),
                     "held_out_median": evaluate.held_out_error(params, realisation, held)})
    return {"dataset": str(dataset), "cause": cause_name, "parameter": cause.main.name,
            "realisation": realisation, "timestep": timestep,
            "held_values": {k: v for k, v in cause.parameters(None, held_values).items()
                            if k != cause.main.name},
            "train_runs": train.tolist(),
            "held_out_runs": held.tolist(),
            "base": {"train_from_rest": F.median_error(comparison, base_starts[:1], train),
                     "train_median": F.median_error(comparison, base_starts, train),
                     "held_out_median": F.median_error(comparison, base_starts, held, train)},
            "profile_bound_factor": F.profile_factor(len(train)), "rows": rows}


def table(result: dict) -> str:
    base = result["base"]
    held = result["held_values"]
    step = result.get("timestep")
    lines = [f"{result['cause']} on {result['dataset']} (realisation {result['realisation']}"
             + (f", models at {step:g} s" if step else "")
             + "".join(f", {k} {v:.4g}" for k, v in held.items()) + "; training runs "
             f"{result['train_runs']}, held out {result['held_out_runs']}); base model: "
             f"training {base['train_from_rest']:.2f} from rest, {base['train_median']:.2f} "
             f"median, held-out {base['held_out_median']:.2f}",
             f"| {result['parameter']} | training, from rest | training, median "
             f"| each start | held-out |", "|---|---|---|---|---|"]
    for r in result["rows"]:
        lines.append(f"| {r['value']:.4g} | {r['train_from_rest']:.2f} | "
                     f"{r['train_median']:.2f} | "
                     f"{' '.join(f'{e:.2f}' for e in r['train_per_start'])} | "
                     f"{r['held_out_median']:.2f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset", nargs="?", type=Path, help="a dataset folder")
    ap.add_argument("--draw", type=int, help="instead, the generalisation benchmark's draw "
                    "of this seed (generated into OUT/datasets/draw-SEED)")
    ap.add_argument("--first-seed", type=int, help="the --first-seed of the benchmark run "
                    "the draw belongs to (the effect cycles from it)")
    ap.add_argument("--out", type=Path, help="where a draw is generated")
    ap.add_argument("--cause", required=True, choices=sorted(causes.CAUSES))
    ap.add_argument("--values", type=float, nargs="+", required=True,
                    help="values of the cause's main parameter, in its unit")
    ap.add_argument("--at", nargs="*", default=[], metavar="NAME=VALUE",
                    help="the cause's other parameters (default: their priors' values)")
    ap.add_argument("--realisation", type=int, default=F.FIT_SEED,
                    help="the realisation of a cause with a random geometry (a benchmark "
                         "draw's own: numpy.random.default_rng(SEED).integers(2**31))")
    ap.add_argument("--timestep", type=float, help="simulate the models (base and cause) at "
                    "this step, s (default: the model's own); the records stay as they are")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--cache", type=Path, help="keep the simulations here (default with "
                    "--out: OUT/profile-simulations; otherwise none)")
    ap.add_argument("--json", type=Path, help="also write the result here")
    args = ap.parse_args(argv)
    if args.draw is not None:
        if args.first_seed is None or args.out is None:
            ap.error("--draw needs --first-seed and --out")
        from bench_diagnose_generalisation import generate, plan
        case = next(c for c in plan(args.draw - args.first_seed + 1, args.first_seed)
                    if c["case"] == f"draw-{args.draw}")
        truth = generate(case, args.out, 3, 20.0, args.threads)
        print(f"draw-{args.draw}: {case['effect']} {truth['parameters']} on {case['floor']}, "
              f"commands {case['omegas']} deg/s", flush=True)
        args.dataset = args.out / "datasets" / case["case"]
    elif args.dataset is None:
        ap.error("give a dataset folder or --draw")
    cache = args.cache or (args.out / "profile-simulations" if args.out else None)
    held_values = {}
    for item in args.at:
        name, sep, value = item.partition("=")
        if not sep or name not in {p.name for p in causes.get(args.cause).held}:
            ap.error(f"--at {item}: not NAME=VALUE with NAME one of {args.cause}'s other "
                     f"parameters ({', '.join(p.name for p in causes.get(args.cause).held)})")
        held_values[name] = float(value)
    result = profile(args.dataset, args.cause, args.values, realisation=args.realisation,
                     held_values=held_values, threads=args.threads, cache_dir=cache,
                     timestep=args.timestep)
    print(table(result))
    if args.json:
        args.json.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
