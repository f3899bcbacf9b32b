"""Benchmark: diagnose on real recordings, one terrain and all of them at once.

Times `skidsteer diagnose` of the BorealTC recordings of a Husky A200: FLOORING alone,
then the four terrains together (with leave one terrain out and the vibration lines),
on this machine with 2 threads, one after the other.  Targets: one terrain in under 3
minutes, all four together in under 10.

    python scripts/bench/bench_real_data.py [--data ../shared/data/borealtc] [--json out.json]
"""

import argparse
import tempfile
import time
from pathlib import Path

from skidsteer.reports.real_data import diagnose_recordings
from _machine import loadavg, machine, save_results

TARGETS_S = {"one terrain": 180.0, "all terrains": 600.0}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default="../shared/data/borealtc")
    parser.add_argument("--json", help="write the results to this file")
    args = parser.parse_args()
    load_before = loadavg()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, paths in (("one terrain", [Path(args.data) / "FLOORING"]),
                             ("all terrains", [Path(args.data)])):
            t0 = time.perf_counter()
            result = diagnose_recordings(paths, Path(tmp) / label.replace(" ", "_"),
                                         progress=False)
            wall = time.perf_counter() - t0
            rows.append({"what": label, "terrains": list(result["terrains"]), "wall_s": wall,
                         "target_s": TARGETS_S[label], "simulations": result["simulations"],
                         "motion": result["motion"]["verdict"],
                         "cause": result["motion"]["cause"]})
    print("| diagnose | terrains | wall (s) | target (s) | surrogate simulations | verdict |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['what']} | {', '.join(r['terrains'])} | {r['wall_s']:.0f} | "
              f"{r['target_s']:.0f} ({'met' if r['wall_s'] <= r['target_s'] else 'missed'}) | "
              f"{r['simulations']} | {r['motion']} {r['cause'] or ''} |")
    print(machine(), "load before", load_before, "after", loadavg())
    if args.json:
        save_results(args.json, "bench_real_data", rows=rows, load_before=load_before,
                     load_after=loadavg())


if __name__ == "__main__":
    main()
