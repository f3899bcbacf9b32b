"""Benchmark: the step the motion diagnosis of real recordings runs at.

diagnosis.identify simulates the robot's turns on the implicit coupling at 1 ms
(MOTION_TIMESTEP_S); the models' own step is the explicit 0.1 ms.  Side by side in one
run on this machine: the Husky's effective-track factor chi and centripetal ratio for
constant commands (in place, tight and gentle arcs) and the fore-aft line of a
drivetrain error (diagnosis.lines) on a straight run, at each step, with the wall time
per simulated second.  Criteria (set before the runs): chi within 1 %, the centripetal
ratio within 0.02 (its measured scatter is 0.2), the line's power within 1 dB.  Measured
(2026-12-06): chi within 0.01 % at 1 ms (0.45 % at 2 ms), 5.5-6.7 times cheaper per
simulated second; the centripetal ratio within 0.01 for the identified robot, 0.15 off
for the base model (the thesis's law); the drivetrain's line 1.4-2.4 dB off at 1 ms:
the lines are fitted at the model's own 0.1 ms (diagnosis.lines).

    python scripts/bench/bench_motion_step.py [--json out.json]
"""

import argparse
import time

import numpy as np

from skidsteer.diagnosis import identify, lines, motion
from skidsteer.experiments.replay import replay
from skidsteer.features.segments import Segment, segment_vibration
from skidsteer.robot import Setup, load_model
from skidsteer.simulation.drive import DriveGeometry
from _machine import loadavg, machine, save_results

STEPS = [("explicit", 1e-4), ("implicit", 1e-3), ("implicit", 2e-3)]
GROUPS = [identify.Group("turn_in_place", -0.10, 0.10), identify.Group("arc", 0.07, 0.23),
          identify.Group("arc", 0.20, 0.25), identify.Group("arc", 0.30, 0.60)]
ROBOTS = {"base": ({}, {}),
          "identified": ({"tread_lateral_friction_ratio": 0.54}, {"slip_law": "combined"})}
SETUP = Setup(robot="husky_a200", build="base", floor="flooring")


def model(coupling, dt, values, settings, edit=None):
    def edited(spec):
        motion.apply(spec, values)
        if edit is not None:
            edit(spec)
    return load_model(SETUP, timestep=dt, tire={"coupling": coupling, **settings},
                      edit=edited)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="write the results to this file")
    args = parser.parse_args()
    load_before = loadavg()
    rows = []
    for robot, (values, settings) in ROBOTS.items():
        for coupling, dt in STEPS:
            m = model(coupling, dt, values, settings)
            t0 = time.perf_counter()
            out = identify.simulate_groups(m, GROUPS, nthread=1)
            wall = time.perf_counter() - t0
            simulated = (len(GROUPS) + 1) * (identify.SETTLE_S + identify.SURROGATE_S)
            track = 2 * DriveGeometry.from_model(m).half_track
            chi = [(g.right_mps - g.left_mps) / track / yaw
                   for g, (yaw, _) in zip(GROUPS, out)]
            k = [a_y / ((g.left_mps + g.right_mps) / 2 * yaw) for g, (yaw, a_y) in
                 zip(GROUPS[1:], out[1:])]
            rows.append({"robot": robot, "coupling": coupling, "timestep_s": dt,
                         "chi": chi, "centripetal_ratio": k,
                         "wall_s_per_simulated_s": wall / simulated})
    run = lines.straight_run(0.4, 100.0)
    seg = Segment(run.path.name, 1.0, float(run.time_s[-1]), "straight", 0.4, 0.4)
    for coupling, dt in STEPS:
        m = model(coupling, dt, {}, {}, lines.drivetrain_edit(18, [1e-4]))
        v = segment_vibration(seg, replay(m, run), 0.1651)
        rows.append({"robot": "drivetrain 0.1 mm at order 18, 0.4 m/s", "coupling": coupling,
                     "timestep_s": dt,
                     "line_db": [float(10 * np.log10(v["power"][17, a])) for a in range(3)]})
    reference = {r["robot"]: r for r in rows if r["timestep_s"] == 1e-4}
    print("| robot | coupling, step | chi (in place, arcs) | off the 0.1 ms explicit | "
          "centripetal ratio | line a_x, a_y, a_z (dB) | wall s per simulated s |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        ref = reference[r["robot"]]
        if "chi" in r:
            off = max(abs(a / b - 1) for a, b in zip(r["chi"], ref["chi"]))
            print(f"| {r['robot']} | {r['coupling']} {r['timestep_s']:g} s | "
                  f"{', '.join(f'{c:.3f}' for c in r['chi'])} | {off:.2%} | "
                  f"{', '.join(f'{c:.3f}' for c in r['centripetal_ratio'])} | - | "
                  f"{r['wall_s_per_simulated_s']:.4f} |")
        else:
            print(f"| {r['robot']} | {r['coupling']} {r['timestep_s']:g} s | - | "
                  f"{max(abs(a - b) for a, b in zip(r['line_db'], ref['line_db'])):.2f} dB | - "
                  f"| {', '.join(f'{x:.1f}' for x in r['line_db'])} | - |")
    if args.json:
        save_results(args.json, "bench_motion_step", rows=rows, load_before=load_before,
                     load_after=loadavg())
    print(machine())


if __name__ == "__main__":
    main()
