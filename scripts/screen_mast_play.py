"""Screen: a mast foot with play, stiff when tapped and soft when swung (issue 66).

The frame rocks on two hinges in series about each axis (roll, pitch) at the mast's
foot: an elastic one, the calibrated frame that fits Table 5.2
(mechanism_features.CALIBRATED_FRAME: 3000 N m/rad, pitch x10, 10 % of critical), and
a play one, a soft residual spring (the frame that lifts a wheel from 64 deg/s,
548 N m/rad, 1 %: finding 8 of docs/reproduction/mechanisms.md) between two stops at
+-gap.  Inside the gap the foot is soft (the two in series, 463 N m/rad in roll); at a
stop it is the elastic hinge's (the stop's own stiffness, I/tau^2 ~ 1e5 N m/rad with
tau = STOP_TIMECONST_S, is 40x stiffer).

Why play and not friction: the calibrated frame's foot carries 18 N m (roll) and 24
N m (pitch) at the peak of Sec. 6.2's free responses, and 0.05-1.1 N m in the steady
swivel at 20-72 deg/s on concrete (--loads; docs/notebook-2026-12-07.md).  A
clamp that slips above a moment (microslip, Iwan or Jenkins elements) softens with load,
so it would slip in the free responses before it slipped in a swivel: the reverse of
what the thesis's robot does.  A gap works by angle, and the soft frame's swivel angles
at <= 45 deg/s (1.8 mrad at the peak) lie below the calibrated frame's free-response
roll (5.5 mrad), so a gap between them would be stiff when tapped and soft when swung.
Measured (docs/notebook-2026-12-07.md): the robot shakes from a gap of ~2 mrad with 1 %
of damping in it, but any gap from 0.05 mrad takes the yaw free response off Table 5.2.

    python scripts/screen_mast_play.py [--gaps 0.5 1 2 4]   # mrad; Table 5.2 per gap
        [--residual-damping 0.01] [--swivel 45 64]        # and the swivel per gap
    python scripts/screen_mast_play.py --loads 20 45 64 72  # the foot's moments and angles
"""

from __future__ import annotations

import argparse
import sys

import mujoco
import numpy as np

import calibrate_frame  # scripts/, beside this file (Table 5.2's free responses, score)
from mechanism_features import CALIBRATED_FRAME  # the frame that fits Table 5.2 best
from skidsteer.diagnosis import causes
from skidsteer.diagnosis.causes.mast_compliance import (
    DAMPING_RATIO, PITCH_STIFFNESS_RATIO, frame_inertia_about_foot)
from skidsteer.experiments.free_response import FREE_RESPONSE_TIMESTEP_S, release
from skidsteer.features.extract import swivel_features
from skidsteer.robot import Setup, load_model
from skidsteer.simulation.drive import DriveGeometry
from skidsteer.simulation.run import run_commanded, settle

MAST = causes.get("mast_compliance")
# the frame that lifts a wheel from 64 deg/s (mechanism_features' lifting_frame: its
# stiffness prior's middle at the damping prior's low end; Table 5.2 excludes it alone)
RESIDUAL_N_M_PER_RAD = 548.0
RESIDUAL_DAMPING_RATIO = DAMPING_RATIO.low
# the clamp between the two hinges: both turn about one axis through one point, so the
# play hinge carries the clamp plate's own inertia (armature; assumed: 1 % of the frame's
# ~0.5 kg m^2, its internal mode at sqrt((K_e + K_r) / J) ~ 130 Hz, above the 50 Hz band)
CLAMP_INERTIA_KG_M2 = 0.005
# the stops: a contact of aluminium parts, far stiffer than either spring (assumed); the
# time constant 2 ms is 80 steps of the screen's 2.5e-5 s
STOP_TIMECONST_S = 0.002
SWIVEL_TIMESTEP_S = 2.5e-5  # the screen's converged step for the steady swivel


def calibrated_frame(stiffness: float = CALIBRATED_FRAME["stiffness_n_m_per_rad"],
                     pitch_ratio: float = CALIBRATED_FRAME[PITCH_STIFFNESS_RATIO.name],
                     damping_ratio: float = CALIBRATED_FRAME[DAMPING_RATIO.name]):
    """mast_compliance's frame hinges as an MjSpec edit (by default the frame that fits
    Table 5.2 best, mechanism_features.CALIBRATED_FRAME)."""
    params = MAST.parameters(stiffness, {PITCH_STIFFNESS_RATIO.name: pitch_ratio,
                                         DAMPING_RATIO.name: damping_ratio})
    return lambda spec: MAST.apply(spec, params)


def mast_play_edit(gap_rad: float, residual_n_m_per_rad: float = RESIDUAL_N_M_PER_RAD,
                   residual_damping_ratio: float = RESIDUAL_DAMPING_RATIO):
    """The MjSpec edit: the calibrated frame's hinges and, in series with each, a play
    hinge (gap 0: the calibrated frame alone)."""
    elastic = calibrated_frame()

    def edit(spec: mujoco.MjSpec) -> None:
        elastic(spec)
        if gap_rad <= 0:
            return
        frame = causes.part(spec, "mast", "mast_play")
        inertia = frame_inertia_about_foot(frame)
        for i, (axis, name) in enumerate((([1, 0, 0], "frame_roll"), ([0, 1, 0], "frame_pitch"))):
            frame.add_joint(name=f"{name}_play", type=mujoco.mjtJoint.mjJNT_HINGE, axis=axis,
                            stiffness=residual_n_m_per_rad,
                            damping=causes.critical_damping(residual_n_m_per_rad, inertia[i],
                                                            residual_damping_ratio),
                            armature=CLAMP_INERTIA_KG_M2,
                            limited=mujoco.mjtLimited.mjLIMITED_TRUE, range=[-gap_rad, gap_rad],
                            solref_limit=[STOP_TIMECONST_S, 1.0])
    return edit


def swivel(edit, omega_deg_s: float) -> str:
    """The extended build on concrete swivelling at omega (20 s at the screen's step):
    its steady a_y amplitude and mean yaw rate after the first 3 s."""
    m = load_model(Setup(build="extended", floor="concrete"), timestep=SWIVEL_TIMESTEP_S,
                   edit=edit)
    run = run_commanded(m, 0.0, omega_deg_s, 20.0)
    time_s, accel = run.accelerometer_log()
    f = swivel_features(time_s, accel)
    return (f"steady a_y amplitude {f['steady_amplitude_m_s2']['y']:.3f} m/s^2, yaw rate "
            f"{np.rad2deg(run.gyro[run.time_s >= 3, 2].mean()):.1f} deg/s")


def foot_loads(edit, omegas: list[float]) -> list[str]:
    """Peak moment (N m) and angle (mrad) of the frame's roll and pitch hinges under
    `edit` (calibrated_frame's): in the roll and pitch free responses (Sec. 6.2's release,
    the free responses' step) and in 12 s swivels on concrete (the last three quarters,
    about their mean)."""
    setup = Setup(build="extended", floor="concrete")

    def loads(m, d, ctrl, nstep, skip):
        dofs = [m.jnt_dofadr[m.joint(n).id] for n in ("frame_roll", "frame_pitch")]
        qpos = [m.jnt_qposadr[m.joint(n).id] for n in ("frame_roll", "frame_pitch")]
        rows = []
        for i in range(nstep):
            if ctrl is not None:
                d.ctrl[:] = ctrl[i]
            mujoco.mj_step(m, d)
            rows.append([-(d.qfrc_spring[j] + d.qfrc_damper[j]) for j in dofs]
                        + [1e3 * d.qpos[j] for j in qpos])
        rows = np.asarray(rows[skip:])
        peak = np.abs(rows - (rows.mean(axis=0) if ctrl is not None else 0)).max(axis=0)
        return (f"moment {peak[0]:.2f}, {peak[1]:.2f} N m; angle {peak[2]:.2f}, "
                f"{peak[3]:.2f} mrad (roll, pitch)")

    out = []
    for axis in ("roll", "pitch"):
        m = load_model(setup, timestep=FREE_RESPONSE_TIMESTEP_S, edit=edit)
        d = mujoco.MjData(m)
        settle(m, d, 2.0)
        release(m, d, axis)
        out.append(f"free response {axis}: " + loads(m, d, None, int(2.0 / m.opt.timestep), 0))
    for omega in omegas:
        m = load_model(setup, timestep=SWIVEL_TIMESTEP_S, edit=edit)
        d = mujoco.MjData(m)
        settle(m, d, 2.0)
        nstep = int(12.0 / m.opt.timestep)
        ctrl = DriveGeometry.from_model(m).ramp(m, 0.0, omega, nstep)
        out.append(f"swivel {omega:g} deg/s: " + loads(m, d, ctrl, nstep, nstep // 4))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--gaps", type=float, nargs="+", default=[0.5, 1.0, 2.0, 4.0],
                    help="the play's half-width, mrad")
    ap.add_argument("--residual-damping", type=float, default=RESIDUAL_DAMPING_RATIO,
                    help="the play hinge's damping ratio (of its residual spring)")
    ap.add_argument("--swivel", type=float, nargs="*", default=[],
                    help="also swivel at these omega (deg/s) on concrete: steady a_y amplitude")
    ap.add_argument("--loads", type=float, nargs="*", default=None,
                    help="instead: the foot's loads in the free responses and in swivels at "
                         "these omega (deg/s), on the calibrated and the lifting frame")
    args = ap.parse_args(argv)
    if args.loads is not None:
        for label, edit in (("calibrated frame", calibrated_frame()),
                            ("lifting frame", calibrated_frame(RESIDUAL_N_M_PER_RAD, 1.0,
                                                               RESIDUAL_DAMPING_RATIO))):
            for line in foot_loads(edit, args.loads):
                print(f"{label}: {line}", flush=True)
        return 0
    print("| gap (mrad) | roll Hz, decay 1/s | pitch | yaw | largest frequency error | "
          "largest decay factor | score (<= 1: Table 5.2 met) |")
    print("|---|---|---|---|---|---|---|")
    for gap in args.gaps:
        edit = mast_play_edit(gap * 1e-3, residual_damping_ratio=args.residual_damping)
        responses = calibrate_frame.free_responses_of(edit)
        freq, decay, total = calibrate_frame.score(responses)
        cells = [f"{responses[a]['refined_peak_hz']:.2f}, {responses[a]['decay_per_s']:.2f}"
                 for a in calibrate_frame.AXES]
        print(f"| {gap:g} | " + " | ".join(cells)
              + f" | {100 * freq:.1f} % | {decay:.2f} | {total:.2f} |", flush=True)
        for omega in args.swivel:
            print(f"    swivel {omega:g} deg/s: {swivel(edit, omega)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
