"""Screen candidate vibration mechanisms against the thesis's discriminating swivel
observations (issue 19, item 2), with the power that feeds each vibration.

For every mechanism at the low end, middle and high end of its physical prior
(never at a value chosen from the features), the extended build and the bare
platform swivel on a floor at a few commanded rates; per run it reports

- the steady a_y amplitude ((max - min) / 2) and RMS of the accelerometer band-passed
  to 1-50 Hz over the steady window (from STEADY_FROM_S; Sec. 3.2's "large vibration"
  observable, without the start-up breakaway) and the two highest a_y peaks,
- the fraction of the steady window with a wheel off the floor (the lift-off
  onset "above about 64 deg/s", Sec. 3.2),
- the mean yaw rate,
- the power flow into the vibration: P_osc = sum over wheels and directions of
  the time mean of f~ . v~, where f~ is the tire force and v~ the chassis
  velocity at the wheel's contact point, both band-passed to 1-50 Hz.  P_osc > 0:
  the tires pump energy into the chassis vibration (a self-excited oscillation
  has an energy source there); P_osc < 0: they damp it, and a vibration that
  persists is forced (floor, wheels) or numerical.

Usage:  python scripts/screen_mechanisms.py [--floor concrete] [--omegas 20 45 64 72]
        [--duration 12] [--out docs/reproduction/mechanisms.md]
The thresholds of the verdicts are the issue's targets (frame-only: extended >= 3x
platform a_y amplitude at 45 deg/s; lift between 56 and 72 deg/s, none at 48).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import mujoco
import mujoco.rollout
import numpy as np
from scipy import signal

from skidsteer.diagnosis import causes
from skidsteer.diagnosis.causes.mast_compliance import DAMPING_RATIO as MAST_DAMPING_RATIO
from skidsteer.features.extract import STEADY_FROM_S, swivel_features
from skidsteer.robot import Setup, load_model, roles
from skidsteer.simulation.drive import DriveGeometry
from skidsteer.simulation.run import LOG_RATE_HZ, settle

BAND_HZ = (1.0, 50.0)  # Sec. 3.2's analysis band (Appendix A low-pass at 50 Hz)
LIFT_ONSET_FRACTION = 0.01  # the "lift fraction > 1 % of the steady window"
EDGE_S = 0.2  # cut from each end of the filtered steady window (the filter's edge transients)


def _contact_sites(spec: mujoco.MjSpec) -> list[str]:
    """Adds, per wheel, a site on the wheel's parent body at the wheel's contact point
    at rest (wheel centre minus the radius along the parent's z) and a velocimeter
    there (velocity of the chassis point, in the parent's axes: at small roll and pitch
    the contact frame's t_x, t_y)."""
    names = []
    for body in spec.bodies:
        if body.plugin is not None and body.plugin.active and body.parent is not None:
            cyl = [g for g in body.geoms if g.type in (mujoco.mjtGeom.mjGEOM_CYLINDER,
                                                         mujoco.mjtGeom.mjGEOM_SPHERE)]
            if not cyl:
                continue
            radius = float(cyl[0].size[0])
            name = f"screen_contact_{body.name}"
            pos = np.asarray(body.pos, float) + np.array([0.0, 0.0, -radius])
            body.parent.add_site(name=name, pos=pos.tolist())
            spec.add_sensor(name=name, type=mujoco.mjtSensor.mjSENS_VELOCIMETER,
                            objtype=mujoco.mjtObj.mjOBJ_SITE, objname=name)
            names.append(name)
    return names


def _band(x: np.ndarray, fs: float) -> np.ndarray:
    """x band-passed to BAND_HZ along axis 0 (4th-order Butterworth, zero phase)."""
    sos = signal.butter(4, BAND_HZ, "bandpass", fs=fs, output="sos")
    return signal.sosfiltfilt(sos, x, axis=0)


def compose(*edits):
    """One MjSpec edit doing each of `edits` in turn (None: skipped)."""
    def edit(spec):
        for e in edits:
            if e is not None:
                e(spec)
    return edit


def simulate(setup: Setup, edit, omegas, duration_s: float, nthread: int = 2,
             tire=None, timestep: float | None = None) -> list[dict]:
    holder = {}

    def add_sites(spec):
        holder["sites"] = _contact_sites(spec)

    m = load_model(setup, tire=tire, edit=compose(edit, add_sites), timestep=timestep)
    r = roles.roles_of(m)
    dt = m.opt.timestep
    nstep = int(round(duration_s / dt))
    drive = DriveGeometry.from_model(m)
    controls = np.stack([drive.ramp(m, 0.0, w, nstep) for w in omegas])
    settled = settle(m, mujoco.MjData(m), 2.0)
    initial = np.repeat(settled[None], len(omegas), axis=0)
    datas = [mujoco.MjData(m) for _ in range(nthread)]
    states, sensors = mujoco.rollout.rollout(m, datas, initial, controls, nstep=nstep)
    tire = r.sensor_slice(m, r.tire_forces, "tire_forces")
    acc = r.sensor_slice(m, r.accelerometer, "accelerometer")
    vel = [slice(int(m.sensor(n).adr[0]), int(m.sensor(n).adr[0]) + 3) for n in holder["sites"]]
    rows = []
    decim = max(1, int(round(1 / (LOG_RATE_HZ * dt))))  # the logger's 1 kHz
    edge = int(round(EDGE_S * LOG_RATE_HZ))
    for k, w in enumerate(omegas):
        t = states[k, :, 0] - initial[k, 0]
        f = sensors[k, :, tire].reshape(nstep, -1, 3)
        v = np.stack([sensors[k, :, s] for s in vel], axis=1)  # (n, nwheel, 3)
        steady = t >= STEADY_FROM_S
        fs = 1 / dt
        fb = _band(f[steady][:, :, 1:], fs)
        vb = _band(v[steady][:, :, :2], fs)
        p_osc = float(np.mean(np.sum(fb * vb, axis=(1, 2))))
        lift = float((f[steady][:, :, 0] <= 0).any(axis=1).mean())
        time_s, accel = t[::decim], sensors[k, ::decim, acc]
        feats = swivel_features(time_s, accel)
        ss = accel[time_s >= STEADY_FROM_S]
        ss = _band(ss, 1 / (dt * decim))[edge:-edge]
        gyro = sensors[k, :, r.sensor_slice(m, r.gyro, "gyro")] if r.gyro is not None else None
        yaw = float(np.degrees(gyro[steady, 2].mean())) if gyro is not None else float("nan")
        rows.append({
            "omega_deg_s": float(w),
            "steady_amplitude_y_m_s2": float(np.ptp(ss[:, 1]) / 2),
            "rms_y_m_s2": float(np.sqrt(np.mean(ss[:, 1] ** 2))),
            "top_peaks_y_hz": [p for p in feats["top_peaks_hz"]["y"][:2]],
            "lift_fraction": lift,
            "mean_yaw_rate_deg_s": yaw,
            "tire_power_into_vibration_w": p_osc,
        })
    return rows


KICK_RAD_S = 0.01  # roll and pitch rate added to the chassis: 0.3 mrad at 5 Hz, a linear probe
KICK_AT_S = 8.0  # after the ramp-in (< 3 s) and 5 s of steady swivel
RESPONSE_S = 3.0
WINDOW_S = 0.2  # envelope: the largest |response| per window


def stability(setup: Setup, edit, omegas, nthread: int = 2, tire=None,
              timestep: float | None = None, kick_rad_s: float = KICK_RAD_S) -> list[dict]:
    """The steady swivel's least-damped roll/pitch motion, measured exactly: the state
    after KICK_AT_S is stepped twice, as is and with the chassis's roll and pitch rates
    raised by kick_rad_s; the difference of the two gyro signals is the response to
    the kick alone (the simulation is deterministic).  Its envelope's log-linear
    decay rate sigma (1/s; < 0: the steady swivel is unstable and a vibration grows)
    and the frequency of its largest spectral line are reported."""
    m = load_model(setup, tire=tire, edit=edit, timestep=timestep)
    r = roles.roles_of(m)
    dt = m.opt.timestep
    n1, n2 = int(round(KICK_AT_S / dt)), int(round(RESPONSE_S / dt))
    drive = DriveGeometry.from_model(m)
    controls = np.stack([drive.ramp(m, 0.0, w, n1) for w in omegas])
    settled = settle(m, mujoco.MjData(m), 2.0)
    datas = [mujoco.MjData(m) for _ in range(nthread)]
    states, _ = mujoco.rollout.rollout(m, datas, np.repeat(settled[None], len(omegas), 0),
                                       controls, nstep=n1)
    # the chassis's free joint; FULLPHYSICS states are time, qpos, qvel, ...
    dof = 1 + m.nq + int(m.jnt_dofadr[m.body_jntadr[r.chassis]])
    initial = []
    for k in range(len(omegas)):
        s0 = states[k, -1].copy()
        s1 = s0.copy()
        s1[dof + 3] += kick_rad_s  # free joint: angular velocity in the body frame
        s1[dof + 4] += kick_rad_s
        initial += [s0, s1]
    hold = np.repeat(controls[:, -1:, :], 2, axis=0).repeat(n2, axis=1)
    _, sensors = mujoco.rollout.rollout(m, datas, np.stack(initial), hold, nstep=n2)
    gyro = r.sensor_slice(m, r.gyro, "gyro")
    tire_sl = r.sensor_slice(m, r.tire_forces, "tire_forces")
    rows = []
    per = int(round(WINDOW_S / dt))
    for k, w in enumerate(omegas):
        d = sensors[2 * k + 1, :, gyro][:, :2] - sensors[2 * k, :, gyro][:, :2]
        nwin = len(d) // per
        env = np.array([np.abs(d[i * per:(i + 1) * per]).max() for i in range(nwin)])
        t_env = (np.arange(nwin) + 0.5) * WINDOW_S
        use = env > 1e-4 * env.max()
        use[0] = False  # the kick's first window holds the fast tire transients
        sigma = float(-np.polyfit(t_env[use], np.log(env[use]), 1)[0]) if use.sum() >= 3 \
            else float("inf")
        freq = np.fft.rfftfreq(len(d), dt)
        spec = np.abs(np.fft.rfft(d - d.mean(0), axis=0)).sum(axis=1)
        band = (freq >= 1.0) & (freq <= 50.0)
        lift = float((sensors[2 * k, :, tire_sl].reshape(n2, -1, 3)[:, :, 0] <= 0)
                     .any(axis=1).mean())
        rows.append({"omega_deg_s": float(w), "decay_rate_per_s": sigma,
                     "response_hz": float(freq[band][np.argmax(spec[band])]),
                     "lift_fraction": lift})
    return rows


# Kinetic friction falling with sliding speed: a property of the tire law (the
# plugin's sliding_friction_ratio alpha_s and sliding_velocity v_S), not a cause
# module, so screened here through the tire attributes.  Priors, stated before the
# screen ran:
SLIDING_FRICTION_RATIO = causes.Parameter(
    "sliding_friction_ratio", 0.6, 1.0, 0.8, log=False,
    source="assumed: rubber's friction has a pronounced maximum in sliding speed and falls "
           "above it (Grosch 1963; Schallamach 1963; Persson 2001) but does not collapse on a "
           "dry floor; the thesis measured kinetic friction only at 1 mm/s (Sec. 3.3), so up "
           "to a 40 % fall at a swivel's sliding speeds is allowed; 1 is the thesis's law; "
           "value: the middle")
SLIDING_VELOCITY = causes.Parameter(
    "sliding_velocity", 0.01, 0.3, 0.055, log=True,
    source="assumed: the friction peak of tread rubber lies between mm/s and m/s (Grosch 1963; "
           "Persson 2001); 0.01-0.3 m/s spans the swivel's sliding speeds (median 0.04-0.14 "
           "m/s at 20-64 deg/s, extended build on concrete); value: the geometric middle, "
           "rounded")
FALLING = "falling_friction"


PRIOR_POINTS = (("low", 0.0), ("mid", 0.5), ("high", 1.0))


def prior_points(parameter, points=PRIOR_POINTS) -> list[tuple[str, float]]:
    """(where, value) of a prior at its low end, middle and high end (or `points`)."""
    return [(where, float(parameter.from_unit(u))) for where, u in points]


def falling_friction_list() -> list[tuple[str, dict]]:
    """(label, tire attributes): alpha_s at the low end (the strongest fall) and the
    middle of its prior, each with v_S at the low end, middle and high end of its."""
    return [(f"{FALLING} alpha_s {a_where}/v_S {v_where} ({alpha:.2g}, {v_s:.2g} m/s)",
             {"sliding_friction_ratio": alpha, "sliding_velocity": v_s})
            for a_where, alpha in prior_points(SLIDING_FRICTION_RATIO, PRIOR_POINTS[:2])
            for v_where, v_s in prior_points(SLIDING_VELOCITY)]


# The lateral force coupled to the normal load: the plugin's stiffness_y_load_exponent
# n (K_y (N / N_0)^n, N_0 the load at which K_y was measured).  Prior, stated before
# the screen ran:
LOAD_EXPONENT = causes.Parameter(
    "stiffness_y_load_exponent", 0.3, 1.0, 0.55, log=True,
    source="assumed: from a carcass whose lateral stiffness grows weakly with load (0.3) to "
           "one proportional to it, as the Magic Formula's cornering stiffness is well below "
           "the tire's rating (1; Pacejka, Tire and Vehicle Dynamics, 2012, Ch. 4); the P3-AT's "
           "tires carry 56-65 N, far below any rating; value: the geometric middle, rounded")
LOAD_COUPLING = "load_coupling"


def load_coupling_list() -> list[tuple[str, dict]]:
    """(label, tire attributes): n at the low end, middle and high end of its prior."""
    return [(f"{LOAD_COUPLING} n {where} ({n:.2g})", {"stiffness_y_load_exponent": n})
            for where, n in prior_points(LOAD_EXPONENT)]


# The drivetrain: the P3-AT's per-side velocity loop with an integral term and a
# limited torque, in place of the model's stiff proportional servo (kv = 100 N m s/rad,
# no limit; models/pioneer3at/parts/drive.xml).  The loop is PI with the proportional
# term on the measured speed (tau = K_i * integral(omega* - omega) - K_p * omega,
# saturated at tau_max): for a disturbance of a steady swivel it is the PI loop
# exactly, and it holds the commanded speed without droop.  Priors, stated before
# the screen ran:
DRIVE_GAIN = causes.Parameter(
    "drive_gain_n_m_s_per_rad", 10.0, 100.0, 31.6, log=True,
    source="assumed: no public value of the P3-AT firmware's gains in SI units (ARIA reads "
           "TransKP/KV/KI from the robot's flash in firmware units); from the model's stiff "
           "servo (100) down to a loop 10x softer, whose proportional term alone lets a "
           "side's steady swivel torque (8-10 N m) slow the wheels by ~1 rad/s; value: the "
           "geometric middle, rounded")
DRIVE_INTEGRAL_CORNER = causes.Parameter(
    "drive_integral_corner_hz", 0.5, 5.0, 1.58, log=True,
    source="assumed: K_i = 2 pi f K_p, the integral's corner f at its top about an octave "
           "below the 4-12 Hz body modes (Table 5.2) and at its bottom still removing the "
           "proportional droop within a second of the swivel's 14 s; value: the geometric "
           "middle, rounded")
DRIVE_TORQUE_LIMIT = causes.Parameter(
    "drive_torque_limit_n_m", 9.8, 11.7, 10.7, log=False,
    source="bounded by the thesis's runs and the model: the motors held the extended build's "
           "steady swivel on carpet at 64 deg/s (Sec. 3.2; 9.7 N m per side in the model, "
           "p99 of the steady window at 1e-4 s), and a limit above the start-up peak "
           "(11.7 N m, extended on carpet) never acts; Sec. 3.2: the motors stall when the "
           "robot hops; value: the middle, rounded")
DRIVETRAIN = "drivetrain"


def drivetrain_edit(gain: float, corner_hz: float, torque_limit: float):
    """An edit making each drive actuator the PI loop above (general actuator: integrator
    dynamics on the commanded speed, gain K_i, bias -K_i q - K_p qdot, force range)."""
    integral = 2 * np.pi * corner_hz * gain

    def edit(spec: mujoco.MjSpec) -> None:
        m = spec.compile()
        r = roles.roles_of(m)
        names = {m.actuator(i).name for i in (*r.left, *r.right)}
        for act in spec.actuators:
            if act.name not in names:
                continue
            act.dyntype = mujoco.mjtDyn.mjDYN_INTEGRATOR
            act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
            act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
            act.gainprm[0] = integral
            act.biasprm[0:3] = [0.0, -integral, -gain]
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.forcerange = [-torque_limit, torque_limit]
    return edit


def drivetrain_list() -> list[tuple[str, dict]]:
    """(label, drivetrain parameters): the gain at the low end, middle and high end of its
    prior, the corner and the torque limit at the middle of theirs; and the middle gain
    with the torque limit at the low end (the tightest)."""
    corner = DRIVE_INTEGRAL_CORNER.value
    limit = DRIVE_TORQUE_LIMIT.value
    out = []
    for where, u in (("low", 0.0), ("mid", 0.5), ("high", 1.0)):
        gain = float(DRIVE_GAIN.from_unit(u))
        out.append((f"{DRIVETRAIN} K_p {where} ({gain:.3g} N m s/rad, {corner:.3g} Hz, "
                    f"{limit:.3g} N m)", {"gain": gain, "corner_hz": corner,
                                          "torque_limit": limit}))
    gain = DRIVE_GAIN.value
    out.append((f"{DRIVETRAIN} K_p mid, tau_max low ({gain:.3g} N m s/rad, {corner:.3g} Hz, "
                f"{DRIVE_TORQUE_LIMIT.low:.3g} N m)",
                {"gain": gain, "corner_hz": corner, "torque_limit": DRIVE_TORQUE_LIMIT.low}))
    return out


@dataclasses.dataclass(frozen=True)
class Mechanism:
    """One row of the screen: a cause of skidsteer.diagnosis at given parameters (or
    none: the base model), tire attributes and a drivetrain on top of it."""

    label: str
    name: str  # what --only selects
    cause: str | None = None
    params: dict | None = None
    tire: dict = dataclasses.field(default_factory=dict)
    drive: dict | None = None  # drivetrain_edit's arguments

    def edit(self):
        cause = causes.get(self.cause) if self.cause else None
        return compose(drivetrain_edit(**self.drive) if self.drive else None,
                        (lambda spec: cause.apply(spec, self.params, 1)) if cause else None)


def mechanism_list() -> list[Mechanism]:
    """Every cause at its prior's low end, middle and high end, the falling friction and
    the load coupling of the tire law and the drivetrain over their priors, each paired with
    mast_compliance at the middle of its prior, and the frame's stiffness x damping."""
    out = [Mechanism("base", "base")]
    for name, cause in causes.CAUSES.items():
        if name in ("sensor_mount", "friction_levels", "slip_lambda_max"):
            continue  # not vibration sources: a sensor's pose, mu levels, lambda_max are
            # parameters of the base law, screened by the floors and variants
        for where, u in (("low", 0.0), ("mid", 0.5), ("high", 1.0)):
            value = float(cause.main.from_unit(u))
            out.append(Mechanism(f"{name} {where} ({cause.main.name} = {value:.3g})", name,
                                 name, cause.parameters(value, {})))
    mast = causes.get("mast_compliance")
    mid = float(mast.main.from_unit(0.5))
    with_mast = {"cause": "mast_compliance", "params": mast.parameters(mid, {})}
    for label, tire in falling_friction_list():
        out.append(Mechanism(label, FALLING, tire=tire))
    for label, tire in falling_friction_list():
        out.append(Mechanism(f"{label} + mast_compliance mid ({mid:.3g})",
                             f"{FALLING}+mast_compliance", tire=tire, **with_mast))
    # the frame's two parameters together: stiffness at five points of its prior, each
    # with the damping ratio at the low end and the middle of its prior (what sets the
    # onset is the balance of the tires' power and the frame's damping)
    for u in (0.0, 0.25, 0.5, 0.75, 1.0):
        k = float(mast.main.from_unit(u))
        for zeta in (MAST_DAMPING_RATIO.low, MAST_DAMPING_RATIO.value):
            out.append(Mechanism(f"mast_compliance grid ({k:.3g} N m/rad, zeta {zeta:.2g})",
                                 "mast_compliance_grid", "mast_compliance",
                                 mast.parameters(k, {MAST_DAMPING_RATIO.name: zeta})))
    for label, tire in load_coupling_list():
        out.append(Mechanism(label, LOAD_COUPLING, tire=tire))
    for label, tire in load_coupling_list():
        out.append(Mechanism(f"{label} + mast_compliance mid ({mid:.3g})",
                             f"{LOAD_COUPLING}+mast_compliance", tire=tire, **with_mast))
    for label, drive in drivetrain_list():
        out.append(Mechanism(label, DRIVETRAIN, drive=drive))
    for label, drive in drivetrain_list():
        out.append(Mechanism(f"{label} + mast_compliance mid ({mid:.3g})",
                             f"{DRIVETRAIN}+mast_compliance", drive=drive, **with_mast))
    return out


def markdown(results: list[dict], stability_mode: bool, command: str) -> str:
    """The results as one markdown table, headed by the command that made them."""
    if stability_mode:
        head = ["mechanism", "build", "omega (deg/s)", "decay rate (1/s)", "response (Hz)",
                "lift fraction (no kick)"]
        keys = ["decay_rate_per_s", "response_hz", "lift_fraction"]
    else:
        head = ["mechanism", "build", "omega (deg/s)", "steady a_y amplitude (m/s^2)",
                "a_y RMS (m/s^2)", "two highest a_y peaks (Hz)", "lift fraction",
                "mean yaw rate (deg/s)", "P_osc (W)"]
        keys = ["steady_amplitude_y_m_s2", "rms_y_m_s2", "top_peaks_y_hz", "lift_fraction",
                "mean_yaw_rate_deg_s", "tire_power_into_vibration_w"]

    def cell(value):
        if isinstance(value, list):
            return ", ".join(f"{v:.2f}" for v in value if v is not None)
        if abs(value) >= 1e-3 or value == 0:
            return f"{value:.3f}"
        return f"{value:.1e}"

    lines = [f"`{command}`", "", "| " + " | ".join(head) + " |",
             "|" + "---|" * len(head)]
    for res in results:
        for row in res["rows"]:
            if "not_applicable" in row:
                continue
            lines.append("| " + " | ".join([res["mechanism"], res["build"],
                                            f"{row['omega_deg_s']:g}"] +
                                           [cell(row[k]) for k in keys]) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--floor", default="concrete")
    ap.add_argument("--omegas", type=float, nargs="+", default=[20.0, 45.0, 64.0, 72.0])
    ap.add_argument("--duration", type=float, default=12.0)
    ap.add_argument("--only", nargs="*", help="mechanism names to run (default: all)")
    ap.add_argument("--tire", type=json.loads, default=None,
                    help="tire attributes for every run, JSON (e.g. a friction law)")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--markdown", type=Path, default=None,
                    help="write the results as a markdown table here")
    ap.add_argument("--timestep", type=float, default=None,
                    help="time step in s (default: the model's)")
    ap.add_argument("--builds", nargs="+", default=["extended", "platform"])
    ap.add_argument("--stability", action="store_true",
                    help="measure the steady swivel's decay rate after a kick instead")
    ap.add_argument("--kick", type=float, default=KICK_RAD_S,
                    help=f"--stability: the roll and pitch rate kick, rad/s (default {KICK_RAD_S})")
    args = ap.parse_args(argv)
    results = []
    t0 = time.time()
    for mechanism in mechanism_list():
        if args.only and mechanism.name not in args.only:
            continue
        label, edit = mechanism.label, mechanism.edit()
        tire = {**(args.tire or {}), **mechanism.tire} or None
        for build in args.builds:
            setup = Setup(build=build, floor=args.floor)
            try:
                if args.stability:
                    rows = stability(setup, edit, args.omegas, tire=tire,
                                     timestep=args.timestep, kick_rad_s=args.kick)
                    results.append({"mechanism": label, "build": build, "rows": rows})
                    for row in rows:
                        print(f"{label:55s} {build:8s} {row['omega_deg_s']:5.0f} "
                              f"sigma {row['decay_rate_per_s']:7.2f} /s at "
                              f"{row['response_hz']:5.2f} Hz lift {row['lift_fraction']:.3f}",
                              flush=True)
                    continue
                rows = simulate(setup, edit, args.omegas, args.duration, tire=tire,
                                timestep=args.timestep)
            except causes.NotApplicable as e:
                rows = [{"not_applicable": str(e)}]
            results.append({"mechanism": label, "build": build, "rows": rows})
            for row in rows:
                if "not_applicable" in row:
                    print(f"{label:55s} {build:8s} n/a", flush=True)
                    continue
                print(f"{label:55s} {build:8s} {row['omega_deg_s']:5.0f} "
                      f"amp {row['steady_amplitude_y_m_s2']:7.3f} rms {row['rms_y_m_s2']:7.4f} "
                      f"peaks {row['top_peaks_y_hz']} lift {row['lift_fraction']:.3f} "
                      f"yaw {row['mean_yaw_rate_deg_s']:6.1f} P_osc "
                      f"{row['tire_power_into_vibration_w']:+.2e} W",
                      flush=True)
    print(f"{time.time() - t0:.0f} s", file=sys.stderr)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    if args.markdown:
        command = "python scripts/screen_mechanisms.py " + " ".join(
            a for a in (argv if argv is not None else sys.argv[1:]))
        args.markdown.write_text(markdown(results, args.stability, command))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
