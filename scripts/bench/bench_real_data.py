"""Benchmark: diagnose on real recordings, one terrain and all of them at once.

Times `skidsteer diagnose` of the BorealTC recordings of a Husky A200: FLOORING alone,
then the four terrains together (with leave one terrain out and the vibration lines),
on this machine with 2 threads, one after the other.  Targets: one terrain in under 3
minutes, all four together in under 10.  With --null, also the null: the hard floors'
runs replayed on the base model itself at its own step (their own wheel commands),
written as recordings and diagnosed: nothing may be named.

    python scripts/bench/bench_real_data.py [--data ../shared/data/borealtc] [--null]
        [--json out.json]
"""

import argparse
import tempfile
import time
from pathlib import Path

from skidsteer.data.imu import write_borealtc_run
from skidsteer.data.terrains import read_terrain
from skidsteer.diagnosis.recordings import replay_all, terrain_setup
from skidsteer.reports.real_data import diagnose_recordings
from skidsteer.robot import load_model, load_robot
from _machine import loadavg, machine, save_results

TARGETS_S = {"one terrain": 180.0, "all terrains": 600.0}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default="../shared/data/borealtc")
    parser.add_argument("--null", action="store_true",
                        help="also diagnose the base model's own replays of the hard floors")
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
                         "cause": result["motion"]["cause"],
                         "reason": result["motion"]["reason"]})
        if args.null:
            null = Path(tmp) / "null"
            robot = load_robot("husky_a200")
            for name in ("FLOORING", "ASPHALT"):
                setup, _ = terrain_setup(robot, "husky_a200", name)
                terrain = read_terrain(Path(args.data) / name, 0.5708)
                runs = [r for r in terrain.data.runs if r.wheels is not None]
                # on the model's own step (explicit 0.1 ms), not the diagnosis's 1 ms
                for i, sim in enumerate(replay_all(load_model(setup), runs, 2)):
                    write_borealtc_run(null / name, i, sim)
            t0 = time.perf_counter()
            result = diagnose_recordings([null], Path(tmp) / "null_out", progress=False)
            rows.append({"what": "null (the base model's own replays)",
                         "terrains": list(result["terrains"]),
                         "wall_s": time.perf_counter() - t0, "target_s": None,
                         "simulations": result["simulations"],
                         "motion": result["motion"]["verdict"],
                         "cause": result["motion"]["cause"],
                         "reason": result["motion"]["reason"],
                         "lines": result.get("lines", {}).get("cause")})
    print("| diagnose | terrains | wall (s) | target (s) | surrogate simulations | verdict |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        target = ("-" if r["target_s"] is None else f"{r['target_s']:.0f} "
                  f"({'met' if r['wall_s'] <= r['target_s'] else 'missed'})")
        print(f"| {r['what']} | {', '.join(r['terrains'])} | {r['wall_s']:.0f} | {target} | "
              f"{r['simulations']} | {r['motion']} {r['cause'] or ''}"
              + (f"; lines: {r['lines'] or 'none named'}" if "lines" in r else "") + " |")
    for r in rows:
        print(f"{r['what']}: {r['reason']}")
    print(machine(), "load before", load_before, "after", loadavg())
    if args.json:
        save_results(args.json, "bench_real_data", rows=rows, load_before=load_before,
                     load_after=loadavg())


if __name__ == "__main__":
    main()
