"""Where a diagnosis's simulations go: `skidsteer diagnose` on one dataset, with every
batch of simulations counted against the stage of the search that asked for it.

A stage is the chain of diagnosis.fit functions between the batch and the diagnosis
(the grid, the Brent search, the realisations and design points, every parameter's
fit, the start-to-start scatter, the held-out starts, the base model, the pair).  The
wall time of a stage is that of its batches, so the stages add up to the diagnosis's
simulation time; the rest is the driving thread (features, scoring, the report).

    python scripts/bench/diagnosis_stages.py data/sample --out /tmp/stages
    python scripts/bench/diagnosis_stages.py DATASET --out DIR -- --model-spread

Arguments after `--` go to `skidsteer diagnose`.  Run it alone: the times are wall
times.  It reuses nothing: the cache is new, under --out (an --out that has one is
refused).
"""

from __future__ import annotations

import argparse
import collections
import sys
import time
import traceback
from pathlib import Path

from skidsteer import cli
from skidsteer.diagnosis import fit


def stage_of(stack: list[traceback.FrameSummary], depth: int = 3) -> str:
    """The innermost `depth` diagnosis.fit functions on the stack, innermost first."""
    names = [f.name for f in stack if Path(f.filename).name == "fit.py"
             and "diagnosis" in Path(f.filename).parts]
    return " < ".join(reversed(names[-depth:])) or "(outside diagnosis.fit)"


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv[:argv.index("--")] if "--" in argv else argv)

    if (args.out / "cache").exists():
        ap.error(f"{args.out / 'cache'} exists: its simulations would be reused, not counted "
                 "(remove it or give another --out)")
    runs: collections.Counter[str] = collections.Counter()
    wall: collections.Counter[str] = collections.Counter()
    simulate = fit.simulate_groups

    def counted(jobs, *a, **k):
        stage = stage_of(traceback.extract_stack()[:-1])
        started = time.perf_counter()
        out = simulate(jobs, *a, **k)
        wall[stage] += time.perf_counter() - started
        runs[stage] += sum(len(groups) for _, groups in jobs)
        return out

    fit.simulate_groups = counted
    started = time.perf_counter()
    try:
        code = cli.main(["diagnose", str(args.dataset), "--out", str(args.out),
                         "--cache", str(args.out / "cache"), "--no-progress", *extra])
    finally:
        fit.simulate_groups = simulate
    total = time.perf_counter() - started
    print(f"\n| stage (innermost first) | simulations | wall s | share of {total:.0f} s |")
    print("|---|---|---|---|")
    for stage in sorted(wall, key=wall.get, reverse=True):
        print(f"| {stage} | {runs[stage]} | {wall[stage]:.1f} | {wall[stage] / total:.0%} |")
    print(f"| all | {sum(runs.values())} | {sum(wall.values()):.1f} | "
          f"{sum(wall.values()) / total:.0%} |")
    return code


if __name__ == "__main__":
    sys.exit(main())
