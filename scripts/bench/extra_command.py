"""A generalisation draw diagnosed again with one more command: does a training command
next to the held-out one pin down what the training runs left open?

The draw's truth and the runs of its own commands are the benchmark's (the truth is
drawn from the seed before any command is used, and each trial's seed depends on
(seed, command, trial) only); the extra command adds 3 trials.  With four commands
split() holds out the second, so an extra command above the draw's middle one keeps
the held-out command and trains on its neighbour.  Issue 21's draws 1191 (a
saturation slip whose held-out response turns between 0.0066 and 0.0070 while the
training runs score 0.0062-0.0105 alike) and 1170 (mu_s fitted where the training
runs score lower than at the truth) are what it was written for.

    python scripts/bench/extra_command.py 1191 50 --first-seed 1177 --out /tmp/extra

Prints the diagnosis's verdict, the named or best fit and the benchmark's outcome as
one JSON line, appended to OUT/rows.jsonl.  Costs a diagnosis of 4 commands (about
1.4x one of 3).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_diagnose_generalisation as generalisation  # noqa: E402

from skidsteer.reports.diagnosis import diagnose  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("seed", type=int, help="the draw's seed (draw-SEED)")
    ap.add_argument("extra_deg_s", type=float, help="the added command's swivel rate, deg/s")
    ap.add_argument("--first-seed", type=int, required=True,
                    help="the --first-seed of the benchmark run the draw belongs to (the "
                         "effect cycles from it)")
    ap.add_argument("--datasets", type=int, default=40, help="that run's --datasets")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args(argv)
    cases = [c for c in generalisation.plan(args.datasets, args.first_seed)
             if c.get("seed") == args.seed]
    if not cases:
        ap.error(f"no draw {args.seed} in a plan of {args.datasets} from {args.first_seed}")
    case = cases[0]
    if args.extra_deg_s in case["omegas"]:
        ap.error(f"draw {args.seed} already has {args.extra_deg_s:g} deg/s: {case['omegas']}")
    case = {**case, "case": f"draw-{args.seed}-plus{args.extra_deg_s:g}",
            "omegas": tuple(sorted(case["omegas"] + (args.extra_deg_s,)))}
    started = time.time()
    truth = generalisation.generate(case, args.out, 3, 20.0, args.threads)
    result = diagnose(args.out / "datasets" / case["case"], None, nthread=args.threads,
                      progress=False, cache_dir=args.out / "simulations")
    row = {"case": case["case"], "effect": case["effect"], "omegas": case["omegas"],
           "truth": truth["parameters"],
           "held_out_groups": result["dataset"]["held_out_groups"],
           "verdict": result["verdict"], "cause": result["cause"], "reason": result["reason"],
           "held_out": [result["gain"]["baseline_error"], result["gain"]["extended_error"]],
           "ranking": [{k: f[k] for k in ("cause", "held_out_error", "train_error",
                                           "parameters", "interval", "unprobed")}
                       for f in result["ranking"]],
           "outcome": generalisation.outcome(case["effect"], result["verdict"], result["cause"],
                                             result["baseline_error_all_runs"]),
           "seconds": round(time.time() - started, 1)}
    print(json.dumps(row))
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "rows.jsonl", "a") as f:
        f.write(json.dumps(row) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
