"""Benchmark: cost per step of the tire plugin versus MuJoCo's native floor contacts
(issue 6's target: the plugin robot costs <= 1.25x the same robot on native contacts).

Three variants of the extended robot on concrete, each built from
skidsteer.load_model("extended", "concrete") by an MjSpec edit, stepped at the
same time step with the same commands in one process:

  plugin  the model as shipped: wheels touch the floor only through skidsteer.tire.
  plugin_implicit  the same with the tire attribute coupling="implicit" (issue 18).
  native  the same robot without the tire plugin (instance, per-wheel references
          and the tire_forces sensor removed); the wheel cylinders collide with
          the floor natively (contype/conaffinity 1, condim 3, friction
          mu_static of concrete 0.86, MuJoCo's default solref/solimp).
          Everything else (masses, motors, belts, integrator, options) unchanged.
  native_armature  native plus 0.01 kg m^2 of rotor inertia on each axle: not the
          shipped robot, a diagnostic of why native contacts swivel slowly.
  bare    the native variant with wheel collisions off and gravity zero: the
          robot floats, no contact at all.  The multibody + motors + sensors
          baseline, so that (plugin - bare) and (native - bare) are the cost of
          each wheel/floor model alone.
  no_collision, no_belts, no_constraints  the shipped robot with MuJoCo's
          collision pass off, its two belt couplings off, or both (then no
          constraint row is left and MuJoCo skips its solver): where the
          shipped robot's step goes.  Only no_collision is the shipped robot
          (its states are compared with plugin's).
  rough_cubic, rough_triangles  the shipped robot on ground_roughness's floor (RMS
          0.35 mm, correlation 5 cm, realisation 0: a 3 m heightfield of 301^2
          samples) as the tire plugin reads it by default (floor_interpolation
          cubic, the samples' B-spline) and as MuJoCo's triangles (mj_rayHfield):
          what a rough floor costs per step, and the spline against the ray.

Each variant is settled for 2 s (untimed), then a swivel at --omega deg/s
(firmware ramp, simulation.DriveGeometry.ramp) of --duration s is stepped by
mujoco.rollout on ONE thread (one MjData, outputs preallocated, so no Python
per step), --repeats times, the variants interleaved so a background load
hits all of them alike.  Reported: min and median microseconds per step and
the plugin/native ratio, at the models' time step (0.1 ms) and at 1 ms; the
mean yaw rate of each variant (last half of the swivel) and its a_y standard
deviation show whether it is a working robot.

    python scripts/bench/bench_plugin_cost.py [--json out.json] [--quick]
        [--omega 30] [--duration 20] [--repeats 5] [--timesteps 1e-4 1e-3]
"""

from __future__ import annotations

import argparse
import statistics
import time

import mujoco
import mujoco.rollout
import numpy as np

import skidsteer
from skidsteer.robot import tire
from skidsteer.simulation import FULLPHYSICS, DriveGeometry, get_state, sensor_slice, settle
from _machine import loadavg, machine, save_results

TARGET_RATIO = 1.25  # issue 6: plugin <= 1.25 x native
WHEELS = ("wheel1", "wheel2", "wheel3", "wheel4")


def _remove_tire_plugin(spec: mujoco.MjSpec) -> None:
    spec.delete(spec.sensor("tire_forces"))
    for name in WHEELS:
        ref = spec.body(name).plugin
        ref.active = False
        ref.name = ""
    spec.delete(tire.instance(spec))


def native_edit(spec: mujoco.MjSpec) -> None:
    """The robot on MuJoCo's own contacts: the wheel cylinders collide with the floor."""
    _remove_tire_plugin(spec)
    mu = tire.floors()["concrete"].mu_static  # the plugin's concrete
    for name in WHEELS:
        for geom in spec.body(name).geoms:
            geom.contype = 1
            geom.conaffinity = 1
            geom.condim = 3
            geom.friction = [mu, 0.005, 0.0001]


NATIVE_ARMATURE = 0.01  # kg m^2, assumed: a geared motor's reflected rotor inertia


def native_armature_edit(spec: mujoco.MjSpec) -> None:
    """native plus rotor inertia on the axles: NOT the shipped robot (diagnostic only).

    A wheel's own inertia (0.07 kg, ~2.5e-4 kg m^2) makes the tangential effective
    mass of its contacts tiny, and MuJoCo's soft friction then yields at well
    under mu N: the native robot scrubs and turns slowly.  Added inertia shows
    whether that, not the cost, is what differs."""
    native_edit(spec)
    for name in WHEELS:
        for joint in spec.body(name).joints:
            joint.armature = NATIVE_ARMATURE


def bare_edit(spec: mujoco.MjSpec) -> None:
    """No wheel/floor model at all and no gravity: the robot floats, nothing touches."""
    _remove_tire_plugin(spec)  # wheel geoms keep contype = conaffinity = 0
    spec.option.gravity = [0.0, 0.0, 0.0]


def disabled(*flags: mujoco.mjtDisableBit):
    """The shipped robot with MuJoCo's `flags` off (a diagnostic of where its step goes):
    mjDSBL_CONTACT, the collision pass (the plugin's wheel forces do not come from it, and
    on a flat floor nothing else touches, so the run is the shipped robot's bit for bit,
    behaviour's same_as_plugin says whether it was; a tipped robot would fall through);
    mjDSBL_EQUALITY, the two belt couplings (NOT the shipped robot: each side's servo then
    drives the mean of two wheels free to turn apart); both, no constraint row at all,
    so MuJoCo skips its constraint solver."""
    def edit(spec: mujoco.MjSpec) -> None:
        for flag in flags:
            spec.option.disableflags |= flag
    return edit


CONTACT, EQUALITY = mujoco.mjtDisableBit.mjDSBL_CONTACT, mujoco.mjtDisableBit.mjDSBL_EQUALITY
ROUGH_FLOOR = {"height_rms_m": 3.5e-4, "correlation_length_m": 0.05}  # issue 21's case


def rough_floor_edit(spec: mujoco.MjSpec) -> None:
    """The shipped robot on ground_roughness's floor (ROUGH_FLOOR, realisation 0)."""
    from skidsteer.diagnosis.causes import ground_roughness
    ground_roughness.apply(spec, ROUGH_FLOOR, 0)


VARIANTS = {"plugin": None, "plugin_implicit": None, "native": native_edit,
            "native_armature": native_armature_edit, "bare": bare_edit,
            "no_collision": disabled(CONTACT), "no_belts": disabled(EQUALITY),
            "no_constraints": disabled(CONTACT, EQUALITY),
            "rough_cubic": rough_floor_edit, "rough_triangles": rough_floor_edit}
TIRE = {"plugin_implicit": {"coupling": "implicit"},  # tire attributes per variant
        "rough_triangles": {"floor_interpolation": "triangles"}}


def prepare(name: str, timestep: float, control: np.ndarray) -> dict:
    m = skidsteer.load_model("extended", "concrete", timestep=timestep, edit=VARIANTS[name],
                             tire=TIRE.get(name))
    d = mujoco.MjData(m)
    settle(m, d, 2.0)
    nstep = len(control)
    return {"m": m, "d": d, "initial": get_state(m, d), "control": control[None],
            "state": np.empty((1, nstep, mujoco.mj_stateSize(m, FULLPHYSICS))),
            "sensordata": np.empty((1, nstep, m.nsensordata)), "times": []}


def timed_rollout(v: dict) -> float:
    start = time.perf_counter()
    mujoco.rollout.rollout(v["m"], v["d"], v["initial"], v["control"],
                           nstep=v["control"].shape[1], state=v["state"],
                           sensordata=v["sensordata"])
    return time.perf_counter() - start


def behaviour(v: dict) -> dict:
    """Is it a working robot?  From the last timed rollout."""
    m, sensors, states = v["m"], v["sensordata"][0], v["state"][0]
    half = len(sensors) // 2
    gyro_z = sensors[half:, sensor_slice(m, "gyro")][:, 2]
    accel_y = sensors[half:, sensor_slice(m, "accelerometer")][:, 1]
    qpos_z = states[:, 1 + 2]  # FULLPHYSICS state: time, then qpos (free joint x, y, z, ...)
    ncon = None
    if m.opt.gravity[2] != 0:
        d = mujoco.MjData(m)  # contacts of the final state
        mujoco.mj_setState(m, d, states[-1], FULLPHYSICS)
        mujoco.mj_forward(m, d)
        ncon = int(d.ncon)
    return {"mean_yaw_rate_deg_s": float(np.rad2deg(gyro_z.mean())),
            "ay_std_m_s2": float(accel_y.std()),
            "chassis_height_m": [float(qpos_z.min()), float(qpos_z.max())],
            "contacts_at_end": ncon,
            "finite": bool(np.isfinite(states).all())}


def run_timestep(timestep: float, args) -> dict:
    nstep = int(round(args.duration / timestep))
    plugin_model = skidsteer.load_model("extended", "concrete", timestep=timestep)
    control = DriveGeometry.from_model(plugin_model).ramp(plugin_model, 0.0, args.omega, nstep)
    variants = {name: prepare(name, timestep, control) for name in VARIANTS}
    for v in variants.values():  # warm-up (page faults of the output arrays, caches)
        timed_rollout(v)
    for _ in range(args.repeats):
        for v in variants.values():
            v["times"].append(timed_rollout(v))
    rows = {}
    for name, v in variants.items():
        per_step = [t / nstep * 1e6 for t in v["times"]]
        rows[name] = {"us_per_step_min": min(per_step),
                      "us_per_step_median": statistics.median(per_step),
                      "wall_s_per_rollout": v["times"], **behaviour(v),
                      # every state of the last rollout equal to the shipped robot's
                      "same_as_plugin": bool(np.array_equal(v["state"],
                                                            variants["plugin"]["state"]))}
    ratio_min = rows["plugin"]["us_per_step_min"] / rows["native"]["us_per_step_min"]
    ratio_median = rows["plugin"]["us_per_step_median"] / rows["native"]["us_per_step_median"]
    implicit_ratio = (rows["plugin_implicit"]["us_per_step_median"]
                      / rows["plugin"]["us_per_step_median"])
    return {"timestep_s": timestep, "nstep": nstep, "rows": rows,
            "plugin_over_native_min": ratio_min, "plugin_over_native_median": ratio_median,
            "implicit_over_explicit_median": implicit_ratio,
            "meets_target": ratio_median <= TARGET_RATIO}


def print_tables(results: list[dict], args) -> None:
    print(f"\nExtended robot, concrete, {args.omega:g} deg/s swivel of {args.duration:g} s, "
          f"{args.repeats} repeats, mujoco.rollout on 1 thread.")
    print("\n| dt (s) | variant | us/step min | us/step median | x native (median) | "
          "over bare (us/step) | mean yaw rate (deg/s) | a_y std (m/s^2) | chassis z (m) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in results:
        native = r["rows"]["native"]["us_per_step_median"]
        bare = r["rows"]["bare"]["us_per_step_median"]
        for name, row in r["rows"].items():
            med = row["us_per_step_median"]
            z = row["chassis_height_m"]
            yaw = "n/a (floating)" if name == "bare" else f"{row['mean_yaw_rate_deg_s']:.2f}"
            print(f"| {r['timestep_s']:g} | {name} | {row['us_per_step_min']:.2f} | {med:.2f} | "
                  f"{med / native:.2f} | {med - bare:+.2f} | {yaw} | "
                  f"{row['ay_std_m_s2']:.3f} | {z[0]:.4f}-{z[1]:.4f} |")
    print("\nWhere the shipped robot's step goes (diagnostic variants: MuJoCo's collision "
          "pass, the belts' constraint rows, both):")
    print("\n| dt (s) | variant | x plugin (median) | states equal to plugin's |")
    print("|---|---|---|---|")
    for r in results:
        shipped = r["rows"]["plugin"]["us_per_step_median"]
        for name in ("no_collision", "no_belts", "no_constraints"):
            row = r["rows"][name]
            print(f"| {r['timestep_s']:g} | {name} | {row['us_per_step_median'] / shipped:.2f} "
                  f"| {'yes' if row['same_as_plugin'] else 'no'} |")
    print("\nA rough floor (ground_roughness, 0.35 mm at 5 cm), read as the samples' cubic "
          "spline (the default) or as MuJoCo's triangles:")
    print("\n| dt (s) | variant | x plugin on the plane (median) | cubic / triangles (median) |")
    print("|---|---|---|---|")
    for r in results:
        shipped = r["rows"]["plugin"]["us_per_step_median"]
        triangles = r["rows"]["rough_triangles"]["us_per_step_median"]
        for name in ("rough_cubic", "rough_triangles"):
            row = r["rows"][name]
            print(f"| {r['timestep_s']:g} | {name} | {row['us_per_step_median'] / shipped:.2f} "
                  f"| {row['us_per_step_median'] / triangles:.2f} |")
    print("\n| dt (s) | plugin / native (min) | plugin / native (median) | "
          f"target <= {TARGET_RATIO} | implicit / explicit coupling (median) |")
    print("|---|---|---|---|---|")
    for r in results:
        print(f"| {r['timestep_s']:g} | {r['plugin_over_native_min']:.2f} | "
              f"{r['plugin_over_native_median']:.2f} | "
              f"{'met' if r['meets_target'] else 'MISSED'} | "
              f"{r['implicit_over_explicit_median']:.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="write the results to this file")
    parser.add_argument("--quick", action="store_true",
                        help="smoke run: 2 s swivel, 2 repeats")
    parser.add_argument("--omega", type=float, default=30.0, help="swivel command, deg/s")
    parser.add_argument("--duration", type=float, default=20.0, help="swivel length, s")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--timesteps", type=float, nargs="+", default=[1e-4, 1e-3])
    args = parser.parse_args()
    if args.quick:
        args.duration, args.repeats = 2.0, 2
    print(f"machine: {machine()}")
    load_before = loadavg()
    print(f"load average before: {load_before}")
    started = time.perf_counter()
    results = [run_timestep(dt, args) for dt in args.timesteps]
    total = time.perf_counter() - started
    load_after = loadavg()
    print_tables(results, args)
    print(f"\nload average after: {load_after}; benchmark wall time {total:.0f} s")
    if args.json:
        save_results(args.json, "plugin_cost", loadavg_before=load_before,
                     loadavg_after=load_after, omega_deg_s=args.omega,
                     duration_s=args.duration, repeats=args.repeats, quick=args.quick,
                     wall_s=total, target_ratio=TARGET_RATIO, results=results)


if __name__ == "__main__":
    main()
