"""The skidsteer command line.

Every command that simulates takes the robot (``--model``: a robot's name, its
folder, or an MJCF file), the build (``--build``) and the floor (``--floor``);
the dataset commands read docs/data-format.md.  ``--config`` and ``--surface``,
the names of earlier releases, still work and say what replaced them.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from skidsteer.cli import options as opt
from skidsteer.data.dataset import run_file_name
from skidsteer.data.files import write_atomically
from skidsteer.data.imu import is_imu_folder
from skidsteer.data.recording import DataError, write_run
from skidsteer.diagnosis.evaluate import SEARCH_STARTS, STARTS
from skidsteer.diagnosis.intervals import unprobed_note
from skidsteer.experiments.free_response import FREE_RESPONSE_AXES, free_response
from skidsteer.experiments.pull import pull
from skidsteer.experiments.rest import tire_loads
from skidsteer.experiments.straight import straight
from skidsteer.experiments.sweep import THESIS_OMEGAS_DEG_S, plan, run_sweep
from skidsteer.experiments.swivel import run_swivel, swivel_summary
from skidsteer.reports.analysis import analyze_paths
from skidsteer.reports.diagnosis import compare, diagnose
from skidsteer.reports.real_data import diagnose_recordings
from skidsteer.reports.reproduction import reproduce
from skidsteer.robot import DEFAULT_ROBOT, PLATFORM_MOUNT, Setup, load_robot, robot_names
from skidsteer.robot.plugin import library_path
from skidsteer.simulation.backends import BackendUnavailable

DATA_FORMAT = "docs/data-format.md"  # the dataset layout the readers accept
# diagnosis.comparison's error when no run of a dataset can be compared
DEFAULT = load_robot(DEFAULT_ROBOT)


def _print_json(data: dict) -> None:
    print(json.dumps(data, indent=2))


# ------------------------------------------------------------------ commands

def cmd_swivel(args: argparse.Namespace) -> int:
    setup = opt.setup_of(args, mount=args.mount)
    started = time.perf_counter()
    run = run_swivel(args.omega, setup, args.duration, args.settle, args.timestep)
    wall = time.perf_counter() - started
    out = Path(args.out) if args.out else Path("out") / run_file_name(
        0, args.omega, args.duration, setup)
    time_s, accel = run.accelerometer_log()
    write_run(out, time_s, accel)
    command = {"v_mps": 0.0, "omega_deg_s": args.omega, "robot": args.model,
               "build": args.build, "floor": args.floor, "mount": args.mount,
               "variant": args.variant, "duration_s": args.duration}
    summary = swivel_summary(run, command)
    features = summary["features"]
    summary.update({
        "amplitude_m_s2": features["amplitude_m_s2"],
        "main_peak_hz": features["main_peak_hz"],
        "samples": int(len(time_s)), "sample_rate_hz": features["sample_rate_hz"],
        "wall_time_s": wall, "accelerometer_log": str(out),
    })
    if args.json:
        _print_json(summary)
        return 0
    print(f"swivel in place at {args.omega:g} deg/s on {args.floor} "
          f"({args.build} build, {args.variant} model, cube on the {args.mount}, "
          f"{args.duration:g} s simulated in {wall:.1f} s)")
    print(f"  mean yaw rate        {summary['mean_yaw_rate_deg_s']:.2f} deg/s")
    print(f"  wheel-lift fraction  {summary['wheel_lift_fraction']:.3f}")
    for axis in "xyz":
        print(f"  a_{axis}: amplitude {features['amplitude_m_s2'][axis]:.3f} m/s^2 "
              f"(steady {features['steady_amplitude_m_s2'][axis]:.3f}, 1-50 Hz RMS "
              f"{features['rms_m_s2'][axis]:.4f}), "
              f"main peak {features['main_peak_hz'][axis]:.2f} Hz, "
              f"low band {features['low_band_peak_hz'][axis]:.2f} Hz, "
              f"high band {features['high_band_peak_hz'][axis]:.2f} Hz")
    print(f"  accelerometer log    {out}")
    print("  (amplitude: Appendix A, whole record incl. the start of the motion; steady: "
          "central 2^14 samples)")
    return 0


def cmd_free_response(args: argparse.Namespace) -> int:
    result = free_response(args.axis, opt.setup_of(args), timestep=args.timestep)
    if args.json:
        _print_json(result)
    else:
        print(f"{args.axis} free response ({args.variant} model, a_{result['accelerometer_axis']}):"
              f" peak {result['peak_hz']:.2f} Hz (FFT bin {result['bin_hz']:.3f} Hz), "
              f"refined {result['refined_peak_hz']:.3f} Hz, decay {result['decay_per_s']:.2f} 1/s")
    return 0


def cmd_pull(args: argparse.Namespace) -> int:
    result = pull(args.direction, args.height, args.wheels, args.slip_velocity,
                  setup=opt.setup_of(args), distance_m=args.distance, timestep=args.timestep)
    if args.out:
        trace = np.column_stack([result["trace"]["travel_m"], result["trace"]["force_N"]])
        write_atomically(Path(args.out), lambda tmp: np.savetxt(
            tmp, trace, delimiter=",", header="travel_m,force_N", comments="",
            fmt=["%.7f", "%.4f"]))
    if args.json:
        _print_json(result)
        return 0
    fmt = lambda x, spec: "n/a" if x is None else format(x, spec)  # noqa: E731
    print(f"{args.direction} pull at {args.height:g} m, wheels {args.wheels} "
          f"({args.build} on {args.floor}, sum N = {result['normal_force_sum_N']:.1f} N)")
    print(f"  first peak {fmt(result['first_peak_N'], '.1f')} N, max {result['max_force_N']:.1f} N, "
          f"{result['teeth']} teeth, ramp slope {fmt(result['ramp_slope_N_per_m'], '.0f')} N/m, "
          f"steady {result['steady_force_N']:.1f} N")
    return 0


def cmd_straight(args: argparse.Namespace) -> int:
    result = straight(args.speed, args.duration, setup=opt.setup_of(args), timestep=args.timestep)
    if args.json:
        _print_json(result)
    else:
        for key, value in result.items():
            print(f"  {key:24s} {value}")
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    omegas = args.omega or list(THESIS_OMEGAS_DEG_S)
    runs = plan(omegas, args.floor or ["concrete", "tile", "carpet"], args.build or ["extended"],
                trials=args.trials, duration_s=args.duration, mount=args.mount,
                variant=args.variant, suffix="." + args.format, seed=args.seed,
                robot=args.model)
    started = time.perf_counter()
    with opt.backend_of(args) as backend:
        run_sweep(Path(args.out), runs, progress=not args.quiet, backend=backend,
                  timestep=args.timestep)
    print(f"{len(runs)} runs in {args.out} ({time.perf_counter() - started:.1f} s)")
    return 0


def cmd_analyze(args: argparse.Namespace) -> int:
    result = analyze_paths(args.path, args.out, figures=not args.no_figures, robot=args.model)
    if args.json:
        _print_json(result)
    else:
        print(f"analysed {len(result.get('runs', []))} runs into {args.out}"
              f" ({len(result.get('skipped', []))} skipped)")
        for skipped in result.get("skipped", []):
            print(f"  skipped {skipped['file']}: {skipped['reason']}")
    return 0


def cmd_reproduce(args: argparse.Namespace) -> int:
    with opt.backend_of(args) as backend:
        report = reproduce(Path(args.out), quick=args.quick, nthread=args.threads,
                           progress=not args.quiet, backend=backend, timestep=args.timestep)
    print(f"report: {report}")
    return 0


def cmd_tire_loads(args: argparse.Namespace) -> int:
    result = tire_loads(opt.setup_of(args))
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        for name, n, e in zip(result["wheels"], result["normal_forces_N"], result["eq_2_24_N"]):
            print(f"{name}: N = {n:8.3f} N   (eq. 2.24: {e:8.3f} N)")
        print(f"sum {result['sum_N']:.3f} N, m g {result['weight_N']:.3f} N "
              f"(ratio {result['sum_over_weight']:.6f})")
    return 0


def _run_on_dataset(func, args: argparse.Namespace, **extra):
    """(result, exit code): func(dataset, out, ...) with the dataset commands' options;
    a bad dataset is a message naming it and exit code 2."""
    try:
        with opt.backend_of(args) as backend:
            result = func(args.dataset, args.out, model=args.model,
                          progress=not args.no_progress, timestep=args.timestep,
                          figures=not args.no_figures, backend=backend, **extra)
    except (DataError, ValueError, FileNotFoundError) as err:
        print(f"skidsteer: {err}", file=sys.stderr)
        return None, 2
    if args.json:
        _print_json(result)
        return None, 0
    return result, 0


def cmd_compare(args: argparse.Namespace) -> int:
    result, code = _run_on_dataset(compare, args)
    if result is None:
        return code
    print(f"base model error {result['baseline_error_all_runs']:.2f} (RMS z against the "
          f"trials' spread): {result['verdict']}; report: {args.out}/report.md")
    for d in result["discrepancies"][:5]:
        print(f"  {d['group']}: {d['feature']} measured {d['measured']:.3g} simulated "
              f"{d['simulated']:.3g} (z {d['z']:+.1f})")
    for s in result["skipped_runs"]:
        print(f"  skipped {s.get('file')}: {s.get('reason')}")
    return 0


def _print_verdict(result: dict, *more: str) -> None:
    """A diagnosis's verdict, cause, reason (and more lines), fitted parameters."""
    cause = f" cause: {result['cause']}" if result["cause"] else ""
    print(f"verdict: {result['verdict']}{cause}")
    print(f"  {result['reason']}")
    for line in more:
        print(line)
    for name, value in result["parameters"].items():
        interval = result["intervals"].get(name)
        # a side open for want of a probe (intervals.unprobed_sides) says so, as in the report
        note = unprobed_note(result.get("unprobed", {}).get(name))
        extra = f" (interval {interval[0]:.3g} to {interval[1]:.3g}{note})" if interval else ""
        print(f"  {name} = {value:.4g}{extra}")


def _holds_recordings(path) -> bool:
    """Real recordings (data.imu), or a folder of terrain folders of them."""
    p = Path(path)
    return is_imu_folder(p) or (p.is_dir() and any(
        is_imu_folder(q) for q in p.iterdir() if q.is_dir()))


def cmd_diagnose(args: argparse.Namespace) -> int:
    recordings = [_holds_recordings(p) for p in args.dataset]
    if any(recordings):
        given = ([f"--search-starts {args.search_starts}"]
                 if args.search_starts != SEARCH_STARTS else []) + (
                     ["--model-spread"] if args.model_spread else []) + (
                     [f"--hold-out {c}" for c in args.hold_out or []])
        if given:
            print(f"skidsteer: {' and '.join(given)}: "
                  f"{'apply' if len(given) > 1 else 'applies'} to a swivel dataset's fits; "
                  f"{', '.join(args.dataset)} hold real recordings, diagnosed by terrain "
                  "(alternate runs held out)", file=sys.stderr)
            return 2
        if not all(recordings):
            print("skidsteer: diagnose takes several paths only of real recordings (terrains); "
                  "not recordings: " + ", ".join(p for p, r in zip(args.dataset, recordings)
                                                   if not r), file=sys.stderr)
            return 2
        return _diagnose_recordings(args)
    if len(args.dataset) != 1:
        print(f"skidsteer: a swivel dataset ({DATA_FORMAT}) is diagnosed alone; got "
              f"{len(args.dataset)} paths", file=sys.stderr)
        return 2
    args.dataset = args.dataset[0]
    result, code = _run_on_dataset(diagnose, args, candidates=args.cause or None,
                                   cache_dir=args.cache, search_starts=args.search_starts,
                                   model_spread=args.model_spread, held_out=args.hold_out)
    if result is None:
        return code
    g = result["gain"]
    likely = result["most_likely"]
    _print_verdict(result, *([f"  most likely: {likely['cause']} ({likely['removed']:.0%} of "
                              "the discrepancy removed; not named)"]
                             if likely and not likely["named"] else []),
                   *([f"  best pair: {' + '.join(result['best_pair']['causes'])} (held-out "
                      f"{result['best_pair']['held_out_error']:.2f})"]
                     if result["best_pair"] and result["best_pair"]["better_than_best"] else []))
    print(f"gain on held-out runs: error {g['baseline_error']:.2f} -> {g['extended_error']:.2f}"
          f" (trial noise {g['noise_error']:.2f}; {g['relative_reduction']:.0%} of the "
          f"discrepancy removed, {g['extended_cause'] or 'no cause'})")
    for s in result["skipped_runs"]:
        print(f"  skipped {s.get('file')}: {s.get('reason')}")
    if result["simulations"]["reused"]:
        print(f"resumed: {result['simulations']['reused']} simulations reused from "
              f"{result['simulations']['cache']}")
    print(f"report: {args.out}/report.md ({result['wall_time_s']} s)")
    return 0


def _diagnose_recordings(args: argparse.Namespace) -> int:
    """diagnose on real recordings of one robot on one or several terrains
    (diagnosis.recordings; written by reports.real_data)."""
    if args.model is None:
        print(f"skidsteer: {', '.join(args.dataset)} hold real recordings: name the robot they "
              f"are of with --model (one of {', '.join(robot_names())}, a folder or an MJCF "
              "file)", file=sys.stderr)
        return 2
    try:
        result = diagnose_recordings(args.dataset, args.out, model=args.model,
                                     progress=not args.no_progress,
                                     leave_one_out=not args.no_leave_one_out,
                                     candidates=args.cause or None)
    except (DataError, ValueError, FileNotFoundError) as err:
        print(f"skidsteer: {err}", file=sys.stderr)
        return 2
    if args.json:
        _print_json(result)
        return 0
    m = result["motion"]
    print(f"motion: {m['verdict']}" + (f" cause: {m['cause']}" if m["cause"] else ""))
    print(f"  {m['reason']}")
    if m["named"]:
        for name, value in m["named"]["robot"].items():
            low, high = m["named"]["intervals"][name]
            print(f"  robot {name} = {value:.4g} (interval {low:.3g} to {high:.3g})")
        for terrain, values in m["named"]["terrain"].items():
            for name, value in values.items():
                low, high = m["named"]["intervals"][f"{name}@{terrain}"]
                print(f"  {terrain} {name} = {value:.4g} (interval {low:.3g} to {high:.3g})")
    for name, t in result["terrains"].items():
        g = t["ground"]
        chi = ", ".join(f"{k.replace('/held_out', '')} {e['measured']:.2f} measured, base "
                        f"{e.get('base', float('nan')):.2f}"
                        + (f", extended {e['extended']:.2f}" if "extended" in e else "")
                        for k, e in t["chi"].items() if k.endswith("/held_out"))
        print(f"{name}: {'deformable (' + '; '.join(g['evidence']) + ')' if g['deformable'] else 'rigid'}"
              + (f"; held-out chi: {chi}" if chi else ""))
    if result.get("lines"):
        print(f"vibration: {result['lines']['verdict']}: {result['lines']['reason']}")
    print(f"identified robot: {result['extended_model']}; report: {args.out}/report.md "
          f"({result['wall_time_s']} s)")
    for s in result["skipped"]:
        print(f"  skipped {s.get('file')}: {s.get('reason')}")
    return 0


def cmd_view(args: argparse.Namespace) -> int:
    from skidsteer.simulation.viewer import launch  # opens a window: only when asked

    target = args.target
    if target.lower().endswith(".xml") or "/" in target:
        setup = Setup(robot=target, floor=args.floor)
    elif target in load_robot(args.model).builds:
        setup = Setup(robot=args.model, build=target, floor=args.floor)
    elif target in robot_names():
        setup = Setup(robot=target, floor=args.floor)
    else:
        raise ValueError(f"unknown model {target!r}: use a build of {args.model} "
                         f"({', '.join(load_robot(args.model).builds)}), a robot "
                         f"({', '.join(robot_names())}) or an MJCF .xml file")
    launch(setup)
    return 0


def cmd_plugin_path(args: argparse.Namespace) -> int:
    """The plugin library's absolute path (or folder), for MuJoCo's own viewers to load."""
    path = library_path().resolve()
    print(path.parent if args.dir else path)
    return 0


def cmd_render(args: argparse.Namespace) -> int:
    from skidsteer.tasks.video import render_swivel  # dm_control and OpenGL: only here

    result = render_swivel(task=args.task, omega_deg_s=args.omega, seconds=args.seconds,
                           out=args.out, width=args.width, height=args.height, fps=args.fps,
                           floor=args.floor, build=args.build, seed=args.seed)
    print(result["video"])
    print(result["still"])
    return 0


# ------------------------------------------------------------------ the parser

def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="skidsteer", description=__doc__.split("\n\n")[0],
        epilog=f"Datasets (analyze, compare, diagnose): the layout is specified in "
               f"{DATA_FORMAT} of the skidsteer repository.")
    sub = parser.add_subparsers(dest="command", required=True)

    def common(p, build="extended", variant=True, json_output=True):
        opt.add_model(p)
        opt.add_build_floor(p, build)
        if variant:
            opt.add_variant(p)
        if json_output:
            p.add_argument("--json", action="store_true", help="print the result as JSON")

    p = sub.add_parser("swivel", help="swivel in place and write the accelerometer log")
    p.add_argument("--omega", type=opt.OMEGA, default=30.0, help="commanded yaw rate, deg/s")
    p.add_argument("--duration", type=opt.DURATION, default=20.0, help="recorded time, s")
    p.add_argument("--settle", type=opt.SETTLE, default=2.0, help="settling time before, s")
    p.add_argument("--mount", default=PLATFORM_MOUNT,
                   help="where the accelerometer is: platform (where the model puts it) or "
                        f"one of the robot's mounts ({DEFAULT.name}: wheel, on wheel 1)")
    p.add_argument("--out", help=f"accelerometer log, .csv or LabVIEW .xlsx ({DATA_FORMAT})")
    opt.add_timestep(p)
    common(p)
    p.set_defaults(func=cmd_swivel)

    p = sub.add_parser("free-response", help="release and ring down (Sec. 5.2, 6.2)")
    p.add_argument("--axis", choices=tuple(FREE_RESPONSE_AXES), default="roll")
    opt.add_timestep(p, 1e-5, "1e-5, where the decay converges")
    common(p)
    p.set_defaults(func=cmd_free_response)

    p = sub.add_parser("pull", help="testing-machine pull test (Sec. 3.3, 6.2)")
    p.add_argument("--direction", choices=("lateral", "longitudinal"), default="lateral")
    p.add_argument("--height", type=opt.PULL_HEIGHT, default=0.0,
                   help="cable height above the floor, m")
    p.add_argument("--wheels", choices=("locked", "spinning"), default="locked")
    p.add_argument("--slip-velocity", type=opt.SLIP_VELOCITY, default=0.0,
                   help="wheel slip velocity r*omega when spinning, m/s")
    p.add_argument("--distance", type=opt.PULL_DISTANCE, default=None, help="machine travel, m")
    p.add_argument("--out", help="force-distance trace CSV")
    opt.add_timestep(p)
    common(p, build="platform")
    p.set_defaults(func=cmd_pull)

    p = sub.add_parser("straight", help="straight line at constant speed (Fig. 6.8)")
    p.add_argument("--speed", type=opt.SPEED, default=1.0, help="v_x*, m/s")
    p.add_argument("--duration", type=opt.DURATION, default=6.0,
                   help="s (the 0.3 m/s^2 ramp takes 3.3 s)")
    opt.add_timestep(p)
    common(p)
    p.set_defaults(func=cmd_straight)

    p = sub.add_parser("sweep", help="swivel runs omega x floor x build into a dataset directory")
    p.add_argument("--out", required=True, help="dataset directory (runs.csv + one file per run)")
    p.add_argument("--omega", type=opt.OMEGA, action="append",
                   help="deg/s, repeatable (default: the thesis's 2, 4, ..., 64)")
    opt.add_model(p)
    opt.add_build_floor(p, None, None, repeat=True)
    p.add_argument("--mount", default=PLATFORM_MOUNT)
    opt.add_variant(p)
    p.add_argument("--trials", type=opt.TRIALS, default=1, help="repeats per command (seeded)")
    p.add_argument("--seed", type=opt.SEED, default=0)
    p.add_argument("--duration", type=opt.DURATION, default=20.0)
    p.add_argument("--format", choices=("csv", "xlsx"), default="csv")
    opt.add_timestep(p)
    opt.add_backend_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("analyze", help="the thesis's Appendix A analysis of runs or a dataset")
    p.add_argument("path", help=f"a run file (.csv/.xlsx) or a dataset directory ({DATA_FORMAT})")
    p.add_argument("--out", required=True, help="directory for analysis.json and figures")
    opt.add_model(p)
    p.add_argument("--no-figures", action="store_true")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_analyze)

    p = sub.add_parser("reproduce", help="every thesis experiment, report against its figures")
    p.add_argument("--out", required=True, help="directory for report.md, results.json, figures")
    p.add_argument("--quick", action="store_true", help="fewer omegas and shorter runs")
    opt.add_timestep(p, None, "the models' own; the free responses' converged step")
    opt.add_backend_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_reproduce)

    p = sub.add_parser("tire-loads", help="normal forces of the robot at rest")
    common(p, variant=False)
    p.set_defaults(func=cmd_tire_loads)

    for name, func, text in (
            ("compare", cmd_compare, "simulate a measured dataset's runs; where they disagree"),
            ("diagnose", cmd_diagnose, "name the cause of a dataset's discrepancies, fit it, "
                                       "measure the gain")):
        p = sub.add_parser(name, help=text)
        if name == "diagnose":
            p.add_argument("dataset", nargs="+",
                           help=f"a swivel dataset directory ({DATA_FORMAT}); or real "
                                "recordings of one robot (--model) on one or several terrains: "
                                "folders of imu_NN.csv with pro_NN.csv, ROS bags or MCAP files "
                                "(a terrain each, named by its folder), or one folder of "
                                "terrain folders")
        else:
            p.add_argument("dataset", help=f"dataset directory ({DATA_FORMAT})")
        p.add_argument("--out", default=f"{name}-out", help="output directory")
        opt.add_model(p, default=None)
        if name == "diagnose":
            p.add_argument("--cause", action="append",
                           help="fit only this candidate (repeatable; default: all)")
            p.add_argument("--cache", default=None, metavar="DIR",
                           help="keep finished simulations here (default: OUT/.skidsteer-cache)"
                                "; a rerun resumes from them, and diagnoses of several datasets "
                                "of one robot can share one")
            p.add_argument("--search-starts", type=opt.SEARCH_STARTS, default=SEARCH_STARTS,
                           metavar="N",
                           help="a fit's training error is the median over N simulated "
                                f"starts (1-{STARTS}; default {SEARCH_STARTS}: from rest only): "
                                "a guard against one start in a rare regime, at N times the "
                                "search's simulations")
            p.add_argument("--model-spread", action="store_true",
                           help="read every discrepancy against the trials' spread and the "
                                "base model's own start-to-start spread together (its "
                                f"{STARTS} simulated starts of each command): features the "
                                "model itself does not repeat count for less")
            p.add_argument("--hold-out", action="append", metavar="COMMAND",
                           help="test the fits on this command's runs, fitted without them "
                                "(repeatable; a label of diagnosis.json's dataset.groups, "
                                "such as 'v0-w60 tile extended', or 'v0-w60' where one setup "
                                "has it; default: every third command from the second, or "
                                "one that shows the discrepancy)")
            p.add_argument("--no-leave-one-out", action="store_true",
                           help="real recordings on several rigid terrains: skip predicting "
                                "each terrain from the robot identified on the others")
        opt.add_timestep(p)
        opt.add_backend_options(p)
        p.add_argument("--no-progress", action="store_true")
        p.add_argument("--no-figures", action="store_true")
        p.add_argument("--json", action="store_true")
        p.set_defaults(func=func)

    p = sub.add_parser("view", help="open a model in MuJoCo's interactive viewer")
    p.add_argument("target", nargs="?", default=DEFAULT.default_build,
                   help="a build of --model's robot, a robot's name, or an MJCF file")
    opt.add_model(p)
    p.add_argument("--floor", default=None, help="the floor (default: as the MJCF has it)")
    p.add_argument("--surface", dest="floor", action=opt.Deprecated, replacement="--floor",
                   help=argparse.SUPPRESS)
    p.set_defaults(func=cmd_view)

    p = sub.add_parser("plugin-path", help="absolute path of the compiled skidsteer.tire plugin "
                                           "library, for MuJoCo's own viewers (models/README.md)")
    p.add_argument("--dir", action="store_true", help="print the library's folder instead")
    p.set_defaults(func=cmd_plugin_path)

    p = sub.add_parser("render", help="video (.mp4) and still (.png) of the feed-forward swivel "
                                      "in a skidsteer.tasks task")
    p.add_argument("--task", default="swivel", help="pioneer3at task: swivel or swivel_smooth")
    p.add_argument("--omega", type=opt.RENDER_OMEGA, default=60.0,
                   help="commanded yaw rate, deg/s (|omega| in [2, 64], the thesis's range)")
    p.add_argument("--out", default="swivel.mp4", help="video file (.mp4); the still is .png")
    p.add_argument("--seconds", type=opt.VIDEO_SECONDS, default=5.0,
                   help="simulated and video time, s")
    opt.add_build_floor(p)
    p.add_argument("--width", type=opt.VIDEO_WIDTH, default=640, help="pixels, even, <= 1280")
    p.add_argument("--height", type=opt.VIDEO_HEIGHT, default=360, help="pixels, even, <= 720")
    p.add_argument("--fps", type=opt.VIDEO_FPS, default=25.0, help="frames per second, <= 100")
    p.add_argument("--seed", type=opt.SEED, default=0, help="initial-state perturbation seed")
    p.set_defaults(func=cmd_render)
    return parser


def _check_names(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """--build, --floor, --variant and --mount against the robot's, as argparse checks
    choices (the robot is known only once --model is parsed)."""
    try:
        robot = load_robot(args.model) if getattr(args, "model", None) else DEFAULT
    except (ValueError, FileNotFoundError) as err:
        parser.error(f"argument --model: {err}")
    allowed = {"build": tuple(robot.builds) if robot.single_file is None else None,
               "floor": tuple(robot.floors), "variant": robot.variant_names,
               "mount": (PLATFORM_MOUNT, *robot.mounts)}
    for option, choices in allowed.items():
        values = getattr(args, option, None)
        for value in (values if isinstance(values, list) else [values]):
            if value is not None and choices is not None and value not in choices:
                parser.error(f"argument --{option}: invalid choice: {value!r} (choose from "
                             f"{', '.join(map(repr, choices))})")


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    _check_names(parser, args)
    try:
        opt.check_after_parse(parser, args)
        return args.func(args)
    except (ValueError, FileNotFoundError, BackendUnavailable) as error:
        print(f"skidsteer: error: {error}", file=sys.stderr)
        return 2

