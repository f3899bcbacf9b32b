"""Benchmark: `diagnose` on 3 omegas x 3 trials of 20 s (issue 4's performance target).

Generates the dataset (the sample recipe's effect, 20 s records, LabVIEW xlsx),
then times diagnose on it, on this machine, with 2 threads.  Prints a Markdown
row for the README's benchmark table.

    python scripts/bench/bench_diagnose.py [--threads 2] [--json out.json]
"""

import argparse
import json
import tempfile
import time
from pathlib import Path

import skidsteer  # noqa: F401  (registers the plugin)
from skidsteer.diagnosis.synth import SAMPLE_RECIPE, make_dataset
from skidsteer.reports.diagnosis import diagnose
from skidsteer.robot import Setup
from _machine import loadavg, machine, save_results

TARGET_S = 600.0  # issue 4: within 10 minutes on the project's 2-core machine


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--json", help="write the results to this file")
    args = parser.parse_args()
    load_before = loadavg()
    recipe = {**SAMPLE_RECIPE, "duration_s": 20.0, "file_format": "xlsx"}
    recipe["setup"] = Setup(build=recipe.pop("build"), floor=recipe.pop("floor"))
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "data"
        t0 = time.perf_counter()
        make_dataset(data, **recipe)
        generate_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        result = diagnose(data, Path(tmp) / "out", nthread=args.threads, progress=True)
        diagnose_s = time.perf_counter() - t0
    summary = {"runs": 9, "record_s": 20.0, "threads": args.threads,
               "generate_s": round(generate_s, 1), "diagnose_s": round(diagnose_s, 1),
               "fraction_of_target": round(diagnose_s / TARGET_S, 3),
               "verdict": result["verdict"], "cause": result["cause"],
               "parameters": result["parameters"],
               "relative_reduction": round(result["gain"]["relative_reduction"], 3),
               "loadavg_before": load_before, "loadavg_after": loadavg()}
    print(json.dumps(summary, indent=2))
    print(f"| diagnose, 3 omegas x 3 trials x 20 s, {args.threads} threads | "
          f"{diagnose_s:.0f} s ({diagnose_s / TARGET_S:.2f} x the 10 min target) | {machine()} |")
    if args.json:
        save_results(args.json, "diagnose", target_s=TARGET_S, **summary)


if __name__ == "__main__":
    main()
