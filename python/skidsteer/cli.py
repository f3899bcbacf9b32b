"""The skidsteer command line."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import mujoco
import numpy as np


def _thesis_file_name(v_mps: float, omega_deg_s: float, duration_s: float, build: str,
                      surface: str, suffix: str = ".csv") -> str:
    """The thesis's run file name v{v}-w{omega}-t{duration}-{conf} (Appendix A)."""
    conf = ([] if build == "extended" else ["noFrame"]) + [surface]
    num = lambda x: f"{x:g}"  # noqa: E731
    return f"v{num(v_mps)}-w{num(omega_deg_s)}-t{num(duration_s)}-{'-'.join(conf)}{suffix}"


def cmd_swivel(args: argparse.Namespace) -> int:
    from skidsteer import signals
    from skidsteer.datafiles import write_accelerometer_csv
    from skidsteer.models import load_model
    from skidsteer.simulation import swivel

    m = load_model(args.config, args.surface)
    started = time.perf_counter()
    run = swivel(m, args.omega, args.duration, args.settle)
    wall = time.perf_counter() - started
    out = Path(args.out) if args.out else Path("out") / _thesis_file_name(
        0, args.omega, args.duration, args.config, args.surface)
    time_s, accel = run.accelerometer_log()
    write_accelerometer_csv(out, time_s, accel)

    fs = signals.sample_rate(time_s)
    filtered = signals.lowpass(accel, fs)
    summary = {
        "command": {"v_mps": 0.0, "omega_deg_s": args.omega, "surface": args.surface,
                    "config": args.config, "duration_s": args.duration},
        "mean_yaw_rate_deg_s": run.mean_yaw_rate_deg_s(),
        "wheel_lift_fraction": run.wheel_lift_fraction(),
        "amplitude_m_s2": dict(zip("xyz", signals.amplitude(signals.central(filtered)).tolist())),
        "main_peak_hz": dict(zip("xyz", signals.main_peak_hz(filtered, fs).tolist())),
        "samples": int(len(time_s)),
        "sample_rate_hz": fs,
        "wall_time_s": wall,
        "accelerometer_log": str(out),
    }
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"swivel in place at {args.omega:g} deg/s on {args.surface} "
              f"({args.config} build, {args.duration:g} s simulated in {wall:.1f} s)")
        print(f"  mean yaw rate        {summary['mean_yaw_rate_deg_s']:.2f} deg/s")
        print(f"  wheel-lift fraction  {summary['wheel_lift_fraction']:.3f}")
        for axis in "xyz":
            print(f"  a_{axis}: amplitude {summary['amplitude_m_s2'][axis]:.3f} m/s^2, "
                  f"main peak {summary['main_peak_hz'][axis]:.2f} Hz")
        print(f"  accelerometer log    {out}")
    return 0


def tire_loads(build: str = "extended", surface: str = "concrete",
               settle_s: float = 3.0) -> dict:
    """Normal forces of the robot at rest and the split eq. 2.24 predicts."""
    from skidsteer.models import load_model
    from skidsteer.simulation import sensor_slice, settle
    from skidsteer.tire_reference import find_wheels

    m = load_model(build, surface)
    d = mujoco.MjData(m)
    settle(m, d, settle_s)
    mujoco.mj_forward(m, d)
    normal = d.sensordata[sensor_slice(m, "tire_forces")].reshape(-1, 3)[:, 0]
    wheels = find_wheels(m)
    root = int(m.body_rootid[wheels[0].body])  # the robot's free body
    mass = float(m.body_subtreemass[root])
    weight = mass * float(np.linalg.norm(m.opt.gravity))
    # eq. 2.24 from the compiled geometry: a, b from the CoM to the axles
    com_x = float(d.subtree_com[root] @ d.xmat[root].reshape(3, 3)[:, 0])
    wheel_x = np.array([d.xpos[w.body] @ d.xmat[root].reshape(3, 3)[:, 0] for w in wheels])
    a = com_x - wheel_x.min()
    b = wheel_x.max() - com_x
    rear = wheel_x < com_x
    expected = np.where(rear, b / (2 * (a + b)), a / (2 * (a + b))) * weight
    return {
        "build": build, "surface": surface,
        "wheels": [m.body(w.body).name for w in wheels],
        "normal_forces_N": normal.tolist(),
        "sum_N": float(normal.sum()),
        "weight_N": weight,
        "sum_over_weight": float(normal.sum() / weight),
        "eq_2_24_N": expected.tolist(),
        "relative_error_vs_eq_2_24": ((normal - expected) / expected).tolist(),
    }


def cmd_tire_loads(args: argparse.Namespace) -> int:
    result = tire_loads(args.config, args.surface)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        for name, n, e in zip(result["wheels"], result["normal_forces_N"], result["eq_2_24_N"]):
            print(f"{name}: N = {n:8.3f} N   (eq. 2.24: {e:8.3f} N)")
        print(f"sum {result['sum_N']:.3f} N, m g {result['weight_N']:.3f} N "
              f"(ratio {result['sum_over_weight']:.6f})")
    return 0


def cmd_view(args: argparse.Namespace) -> int:
    from skidsteer.viewer import launch

    launch(args.model, args.surface)
    return 0


def build_parser() -> argparse.ArgumentParser:
    from skidsteer.models import BUILDS, FLOORS

    parser = argparse.ArgumentParser(prog="skidsteer", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("swivel", help="swivel in place and write the accelerometer log")
    p.add_argument("--omega", type=float, default=30.0, help="commanded yaw rate, deg/s")
    p.add_argument("--surface", choices=FLOORS, default="concrete")
    p.add_argument("--duration", type=float, default=20.0, help="recorded time, s")
    p.add_argument("--settle", type=float, default=2.0, help="settling time before, s")
    p.add_argument("--config", choices=sorted(BUILDS), default="extended")
    p.add_argument("--out", help="accelerometer log (CSV, measured-data layout)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_swivel)

    p = sub.add_parser("tire-loads", help="normal forces of the robot at rest")
    p.add_argument("--config", choices=sorted(BUILDS), default="extended")
    p.add_argument("--surface", choices=FLOORS, default="concrete")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_tire_loads)

    p = sub.add_parser("view", help="open a model in MuJoCo's interactive viewer")
    p.add_argument("model", nargs="?", default="extended",
                   help="extended, platform or a path to an MJCF file")
    p.add_argument("--surface", choices=FLOORS, default=None)
    p.set_defaults(func=cmd_view)
    return parser


def main(argv: list[str] | None = None) -> int:
    import skidsteer  # noqa: F401  (registers the plugin)

    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, FileNotFoundError) as error:
        print(f"skidsteer: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
