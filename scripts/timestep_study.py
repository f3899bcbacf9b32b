"""Largest stable time step and the step at which results converge.

Stability: at each step, 20 s of random wheel commands up to the motors'
limits must stay finite with no MuJoCo warning, and a 30 deg/s swivel must
not fall into a numerical limit cycle (accelerometer RMS above 1 g).

Convergence: swivels at 30 and 64 deg/s on concrete (extended build), in
steady state (the 7 s after the first 3 s of swivel), the
accelerometer brought to 1 kHz with an anti-aliasing decimation (what a 1 kHz
logger records), then analysed as Appendix A does (50 Hz low-pass): a_y
amplitude, RMS in the 0-10, 10-20, 20-50 Hz bands, mean yaw rate, and the
locked-wheel roll free-response frequency.  A step has converged when, against
the finest step, the yaw rate is within 1 %, the a_y amplitude within 10 % or
0.05 m/s^2, and every band RMS within 10 % or 0.005 m/s^2.  The absolute
floors matter because the converged steady swivel hardly vibrates (band RMS
~1e-4 m/s^2): a residue of 0.5 mg RMS is negligible for vibration analysis,
and relative errors of nothing are meaningless.  Runs at
the finest step that differ by a 1e-6 rad initial yaw show how chaotic the
swivel is over 10 s (printed).

Run:  python scripts/timestep_study.py [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import mujoco
import numpy as np
from scipy import signal

import skidsteer
from skidsteer.data.files import write_atomically
from skidsteer.features import signals
from skidsteer.simulation import rollout, run_commanded, sensor_slice, settle

STEPS = [2e-3, 1.5e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5]
BANDS = [(0, 10), (10, 20), (20, 50)]
SWIVEL_S = 10.0
TRANSIENT_S = 3.0  # the start of the swivel, excluded (the thesis analyses the middle)


def to_1khz(x: np.ndarray, dt: float) -> tuple[np.ndarray, float]:
    factor = int(round(1e-3 / dt))
    if factor <= 1:
        return x, 1 / dt
    return signal.decimate(x, factor, ftype="fir", axis=0, zero_phase=True), 1 / (factor * dt)


def unstable_reason(dt: float, tire: dict | None = None, build: str = "extended",
                    floor: str = "concrete") -> str | None:
    m = skidsteer.load_model(build, floor, timestep=dt, tire=tire)
    d = mujoco.MjData(m)
    settle(m, d, 0.5)
    rng = np.random.default_rng(0)
    nstep = int(20 / dt)
    hold = max(1, int(0.2 / dt))
    ctrl = np.repeat(rng.uniform(-11.16, 11.16, (nstep // hold + 1, 2)), hold, axis=0)[:nstep]
    states, _ = rollout(m, d, ctrl, nstep)
    if not np.isfinite(states).all() or any(w.number for w in d.warning):
        return "NaN or MuJoCo warning under random commands"
    return None


def roll_frequency(dt: float) -> float:
    m = skidsteer.load_model("extended", "concrete", timestep=dt)
    d = mujoco.MjData(m)
    settle(m, d, 1.0)
    quat = np.empty(4)
    mujoco.mju_axisAngle2Quat(quat, np.array([1.0, 0, 0]), -np.arctan2(2e-3, 0.36))
    mujoco.mju_mulQuat(d.qpos[3:7], quat, d.qpos[3:7].copy())
    d.qvel[:] = 0
    mujoco.mj_forward(m, d)
    _, sensors = rollout(m, d, np.zeros(m.nu), int(round(2.048 / dt)))
    ay, fs = to_1khz(sensors[:, sensor_slice(m, "accelerometer")][:, 1], dt)
    ay = signals.lowpass(ay[:2048], fs, 20.0)  # Sec. 5.2: first 2^11 samples, 20 Hz
    return float(signals.main_peak_hz(ay[:, None], fs, (1.0, 20.0))[0])


def swivel_features(dt: float, yaw0: float = 0.0, omega: float = 30.0) -> dict:
    m = skidsteer.load_model("extended", "concrete", timestep=dt)
    d = mujoco.MjData(m)
    d.qpos[3:7] = [np.cos(yaw0 / 2), 0, 0, np.sin(yaw0 / 2)]
    started = time.perf_counter()
    run = run_commanded(m, 0.0, omega, SWIVEL_S, settle_s=1.0, d=d)
    wall = time.perf_counter() - started
    accel, fs = to_1khz(run.accel, dt)
    accel = accel[int(TRANSIENT_S * fs):]
    raw_rms = float(np.sqrt(((accel - accel.mean(0)) ** 2).mean()))
    low = signals.lowpass(accel, fs)
    f, p = signal.welch(low[:, 1] - low[:, 1].mean(), fs=fs, nperseg=2048)
    band_rms = [float(np.sqrt(np.trapezoid(p[(f >= lo) & (f < hi)], f[(f >= lo) & (f < hi)])))
                for lo, hi in BANDS]
    return {
        "wall_s_per_simulated_s": wall / (SWIVEL_S + 1.0),
        "raw_rms_m_s2": raw_rms,
        "mean_yaw_rate_deg_s": float(np.rad2deg(
            run.gyro[int(TRANSIENT_S / dt):, 2].mean())),
        "ay_amplitude_m_s2": float(signals.amplitude(low)[1]),
        "ay_band_rms_m_s2": band_rms,
    }


AMPLITUDE_FLOOR = 0.05  # m/s^2
BAND_RMS_FLOOR = 0.005  # m/s^2


def converged(row: dict, ref: dict) -> bool:
    amplitude, ref_amplitude = row["ay_amplitude_m_s2"], ref["ay_amplitude_m_s2"]
    return (abs(row["mean_yaw_rate_deg_s"] / ref["mean_yaw_rate_deg_s"] - 1) <= 0.01
            and abs(amplitude - ref_amplitude) <= max(0.10 * ref_amplitude, AMPLITUDE_FLOOR)
            and all(abs(a - b) <= max(0.10 * b, BAND_RMS_FLOOR)
                    for a, b in zip(row["ay_band_rms_m_s2"], ref["ay_band_rms_m_s2"])))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--json", help="write the results here")
    parser.add_argument("--from-json", help="only print the table of a previous --json")
    args = parser.parse_args()
    finest = min(STEPS)
    if args.from_json:
        with open(args.from_json) as fh:
            print_table({float(k): v for k, v in json.load(fh)["rows"].items()})
        return
    repeats = [swivel_features(finest, yaw0) for yaw0 in (1e-6, 2e-6, 3e-6)]
    print("Repeats at the finest step, 30 deg/s (yaw0 = 1e-6, 2e-6, 3e-6 rad):")
    for r in repeats:
        print("  ", {k: r[k] for k in ("mean_yaw_rate_deg_s", "ay_amplitude_m_s2",
                                       "ay_band_rms_m_s2")}, flush=True)
    rows = {}
    for dt in STEPS:
        reason = unstable_reason(dt)
        row = {"unstable": reason}
        if reason is None:
            row["roll_free_response_hz"] = roll_frequency(dt)
            for omega in (30.0, 64.0):
                row[f"swivel_{omega:g}"] = swivel_features(dt, omega=omega)
        rows[dt] = row
        print(f"dt={dt:g}: {row}", flush=True)
    if args.json:
        text = json.dumps({"rows": {str(k): v for k, v in rows.items()}, "repeats": repeats},
                          indent=2)
        write_atomically(Path(args.json), lambda tmp: tmp.write_text(text))
    print_table(rows)


def limit_cycle(row: dict) -> str | None:
    """A swivel that shakes at more than 1 g is numerical, not physical."""
    for omega in ("30", "64"):
        f = row.get(f"swivel_{omega}")
        if f and (f["raw_rms_m_s2"] > 9.81 or f["ay_amplitude_m_s2"] > 9.81):
            return f"numerical limit cycle in the {omega} deg/s swivel (accelerometer > 1 g)"
    return None


def print_table(rows: dict) -> None:
    finest = min(rows)
    for r in rows.values():
        r["unstable"] = r["unstable"] or limit_cycle(r)
    print("\n| dt (s) | stable | roll free response (Hz) | omega* (deg/s) | yaw rate (deg/s) | "
          "a_y amplitude (m/s^2) | a_y RMS 0-10 / 10-20 / 20-50 Hz (m/s^2) | converged | "
          "wall s per simulated s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for dt, r in rows.items():
        if r["unstable"]:
            print(f"| {dt:g} | no: {r['unstable']} | | | | | | | |")
            continue
        for omega in ("30", "64"):
            f = r[f"swivel_{omega}"]
            ok = converged(f, rows[finest][f"swivel_{omega}"])
            f["converged"] = ok
            bands = " / ".join(f"{v:.4f}" for v in f["ay_band_rms_m_s2"])
            print(f"| {dt:g} | yes | {r['roll_free_response_hz']:.2f} | {omega} | "
                  f"{f['mean_yaw_rate_deg_s']:.2f} | {f['ay_amplitude_m_s2']:.3f} | {bands} | "
                  f"{'yes' if ok else 'no'} | {f['wall_s_per_simulated_s']:.3f} |")


if __name__ == "__main__":
    main()
