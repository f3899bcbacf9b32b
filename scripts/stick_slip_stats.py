"""Why a slow swivel needs a small time step: the tires' stick/slip per wheel.

In eq. 4.12's linear regime (|lambda| < lambda_max) the friction factors are
mu_y = |v_y| / (r |omega| lambda_max) and mu_x = |Delta v_x| / (r |omega| lambda_max):
below the speed v* = r |omega| lambda_max the friction limit grows in
proportion to the rim's slip speed, a viscous friction of coefficient
c = mu_s N / v*.  The plugin applies it explicitly (a passive force from the
start-of-step state), so what decides the accuracy is c h / m_eff, with m_eff
the inertia the wheel's contact point sees laterally (1 / J M^-1 J^T).  c grows
as 1/|omega|: the slower the swivel, the smaller the step it needs.

For each time step this prints, per wheel, the fraction of time each contact
point sticks, its stick/slip switches per second, the mean friction factors and
slip speeds, the a_y line in 20-50 Hz of the steady swivel, and c h / m_eff of
each wheel's lateral direction.  Each run: settle 2 s, ramp and 4 s of swivel,
then --seconds of steady swivel stepped one mj_step at a time (~20 s at 1e-5 s).

    python scripts/stick_slip_stats.py [--omega 10] [--steps 1e-4 2e-5 1e-5]
        [--variant ours|thesis] [--seconds 3]
"""

from __future__ import annotations

import argparse

import sys
from pathlib import Path

import mujoco
import numpy as np

import skidsteer
from skidsteer.features import signals
from skidsteer.robot import load_spec
from skidsteer.simulation import DriveGeometry, rollout, sensor_slice, settle

# the law's internals (contact kinematics, friction factors) from its Python reference
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import tire_reference as tr  # noqa: E402

def lateral_effective_mass(m: mujoco.MjModel, d: mujoco.MjData, ref: tr.TireReference) -> list:
    """Per wheel (normal force N, 1 / (J M^-1 J^T) of its lateral contact direction, kg)."""
    mujoco.mj_forward(m, d)
    out = []
    for wheel in ref.wheels:
        k, frame, point = tr.wheel_contact(m, d, wheel, ref.floors)
        jac = np.zeros((3, m.nv))
        mujoco.mj_jac(m, d, jac, None, point, wheel.body)
        j = frame[2] @ jac  # frame rows: n, t_x, t_y
        x = np.zeros((1, m.nv))
        mujoco.mj_solveM(m, d, x, j.reshape(1, -1))
        out.append((tr.normal_force(ref.params, k), 1.0 / float(j @ x[0])))
    return out


def measure(dt: float, omega_deg_s: float, variant: str, seconds: float) -> dict:
    m = skidsteer.load_model("extended", "concrete", timestep=dt, variant=variant)
    d = mujoco.MjData(m)
    config = load_spec("extended", "concrete", variant=variant).plugins[0].config
    ref = tr.TireReference(m, tr.TireParams.from_config(dict(config)))
    settle(m, d, 2.0)
    loads = lateral_effective_mass(m, d, ref)
    n = int(round(4.0 / dt))
    ctrl = DriveGeometry.from_model(m).ramp(m, 0.0, omega_deg_s, n)
    rollout(m, d, ctrl, n)
    d.ctrl[:] = ctrl[-1]
    nstep = int(round(seconds / dt))
    every = max(1, int(round(1e-4 / dt)))  # friction factors sampled every 0.1 ms
    adr = m.plugin_stateadr[0]
    nwheel = len(ref.wheels)
    stuck = np.zeros((nstep, nwheel, 2))
    ay = np.zeros(nstep)
    acc = sensor_slice(m, "accelerometer")
    factors, speeds = [], []
    for i in range(nstep):
        if i % every == 0:
            ks = [tr.wheel_contact(m, d, w, ref.floors)[0] for w in ref.wheels]
            factors.append([tr.friction_factors(ref.params, k) for k in ks])
            speeds.append([(abs(k.slip_x), abs(k.slip_y), abs(k.rolling_speed)) for k in ks])
        mujoco.mj_step(m, d)
        stuck[i] = d.plugin_state[adr:adr + 6 * nwheel].reshape(nwheel, 2, 3)[:, :, 2]
        ay[i] = d.sensordata[acc][1]
    speeds = np.array(speeds).mean(axis=0)
    # 1 s Welch segments (1 Hz bins, 3 averaged): the line moves by Hz between steps
    f, psd = signals.welch_spectrum(ay - ay.mean(), 1 / dt, nperseg=int(round(1.0 / dt)))
    mu_s = ref.params.mu_static
    return {
        "stuck": stuck.mean(axis=0), "switches_per_s": np.abs(np.diff(stuck, axis=0)).sum(0) / seconds,
        "factors": np.array(factors).mean(axis=0), "speeds": speeds,
        "line_hz": float(signals.band_peak_hz(f, psd, signals.HIGH_BAND_HZ)),
        "line_rms": float(np.sqrt(signals.band_power(f, psd, signals.HIGH_BAND_HZ))),
        # c h / m_eff = mu_s N h / (r |omega| lambda_max m_eff), rolling speed measured
        "c_h_over_m": [mu_s * load * dt / (speeds[w, 2] * ref.params.lambda_max * mass)
                       for w, (load, mass) in enumerate(loads)],
        "loads": loads,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--omega", type=float, default=10.0, help="swivel command, deg/s")
    parser.add_argument("--steps", type=float, nargs="+", default=[1e-4, 2e-5, 1e-5])
    parser.add_argument("--variant", choices=("ours", "thesis"), default="ours")
    parser.add_argument("--seconds", type=float, default=3.0, help="steady swivel analysed, s")
    args = parser.parse_args()
    print(f"{args.variant} model, extended build on concrete, {args.omega:g} deg/s swivel; "
          "per wheel 1-4 (Table 5.1 numbering), x then y")
    print("\n| dt (s) | stuck fraction | switches per s | mean mu_x, mu_y | mean |dv_x|, |v_y|, "
          "r|omega| (m/s) | c h / m_eff, lateral | a_y 20-50 Hz: peak Hz, RMS m/s^2 |")
    print("|---|---|---|---|---|---|---|")
    for dt in args.steps:
        r = measure(dt, args.omega, args.variant, args.seconds)

        def per_wheel(a, fmt):
            return "; ".join("/".join(fmt.format(v) for v in np.atleast_1d(row)) for row in a)

        print(f"| {dt:g} | {per_wheel(r['stuck'], '{:.2f}')} | "
              f"{per_wheel(r['switches_per_s'], '{:.0f}')} | {per_wheel(r['factors'], '{:.2f}')} | "
              f"{per_wheel(r['speeds'], '{:.4f}')} | {per_wheel(r['c_h_over_m'], '{:.3f}')} | "
              f"{r['line_hz']:.0f}, {r['line_rms']:.4f} |", flush=True)
    print("\nnormal force N (N) and lateral m_eff (kg) per wheel at rest: " +
          "; ".join(f"{n:.1f}, {mass:.2f}" for n, mass in r["loads"]))


if __name__ == "__main__":
    main()
