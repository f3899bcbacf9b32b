"""Calibrate the frame's compliance (mast_compliance) on Table 5.2, then predict the
swivel (issue 19, item 3).

Fitted set: Table 5.2 of the thesis, the free responses of the extended robot at
rest (roll, pitch, yaw: peak frequency and decay rate, measured with the cube on
the platform as the model's accelerometer is), read from
python/skidsteer/reports/thesis_measurements.toml.  The swivel features at
omega <= 40 deg/s that the issue names as the fitted set carry no information on
the frame here: every point of the frame's prior stays below 0.19 m/s^2 of steady
a_y amplitude at 20-45 deg/s on concrete and no wheel lifts
(docs/reproduction/mechanisms/mast_grid_concrete_low.md), far under Sec. 3.2's
large vibrations, so the free responses are what constrains it.

For every point of a grid over the frame's prior (roll stiffness, pitch/roll
stiffness ratio, damping ratio) the three free responses are simulated as
reproduction.py does (skidsteer.experiments.free_response, at its converged
step) and scored by the largest relative frequency error over the three axes
(the issue's target: within 10 %, goal 5 %) and the largest decay factor (target
1.6).  A frame's score is the larger of the two in units of their targets (<= 1: both met;
the rigid model scores 1.02, its roll frequency +10.2 %).  The prediction
(--predict N) then swivels the extended build on concrete and carpet at the lift-off
rates with the N best-scoring frames; the platform has no frame, so its swivel is
the base model's.

Usage:  python scripts/calibrate_frame.py [--markdown docs/reproduction/frame_calibration.md]
        [--predict N]   (swivel the N best-scoring frames; default 2) [--json FILE]
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import screen_mechanisms  # noqa: E402  (the swivel measurement of the screen)
from skidsteer.diagnosis import causes  # noqa: E402
from skidsteer.experiments.free_response import free_response  # noqa: E402
from skidsteer.reports import thesis_measurements  # noqa: E402
from skidsteer.robot import Setup  # noqa: E402

AXES = ("roll", "pitch", "yaw")
# the grid over the frame's prior: roll stiffness at 7 log-spaced points of its
# prior, the pitch/roll ratio at 1, 10 and 100, the damping ratio at its ends and middle
ROLL_POINTS = 7
RATIOS = (1.0, 10.0, 100.0)
PREDICT_OMEGAS = {"concrete": [48.0, 56.0, 64.0, 72.0, 80.0, 88.0, 96.0],
                  "carpet": [40.0, 48.0, 56.0, 64.0, 72.0, 80.0]}
PREDICT_TIMESTEP_S = 2.5e-5  # the screen's converged step for the steady swivel


def free_responses(params: dict | None) -> dict:
    cause = causes.get("mast_compliance")
    edit = None if params is None else (lambda spec: cause.apply(spec, params, 1))
    out = {}
    for axis in AXES:
        r = free_response(axis, edit=edit)
        # the highest peak below the bin spacing, as reproduction.py compares it
        out[axis] = (float(r["refined_peak_hz"]), float(r["decay_per_s"]))
    return out


def normalized(freq_error: float, decay_factor: float, max_freq_error: float,
               max_decay_factor: float) -> float:
    """One number per frame: the larger of the frequency error and the decay factor, each
    in units of its target (<= 1: both targets met; the rigid model is at 1.02)."""
    return max(freq_error / max_freq_error, np.log(decay_factor) / np.log(max_decay_factor))


def score(responses: dict, measured) -> tuple[float, float]:
    """(largest relative frequency error, largest decay factor) over the axes."""
    freq_error, decay_factor = 0.0, 1.0
    for axis in AXES:
        m = measured.free_response[axis]
        f, decay = responses[axis]
        freq_error = max(freq_error, abs(f - m["peak_hz"]) / m["peak_hz"])
        ratio = decay / m["decay_per_s"] if decay > 0 else float("inf")
        decay_factor = max(decay_factor, ratio, 1 / ratio if ratio > 0 else float("inf"))
    return freq_error, decay_factor


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--markdown", type=Path, default=None)
    ap.add_argument("--predict", type=int, default=2)
    ap.add_argument("--json", type=Path, default=None, help="write the grid's responses here")
    ap.add_argument("--from-json", type=Path, default=None,
                    help="take the grid's responses from a --json file instead of simulating")
    args = ap.parse_args(argv)
    measured = thesis_measurements.load()
    targets = measured.free_response["targets"]
    max_freq_error, max_decay_factor = (targets["frequency_relative_error"],
                                        targets["decay_factor"])
    cause = causes.get("mast_compliance")
    roll = cause.main
    damping, ratio_param = cause.held
    t0 = time.time()
    if args.from_json:
        rows = [(r["frame"], r["parameters"], {a: tuple(v) for a, v in r["responses"].items()})
                for r in json.loads(args.from_json.read_text())]
    else:
        rows = [("rigid (base model)", None, free_responses(None))]
        for u, ratio, zeta in itertools.product(np.linspace(0, 1, ROLL_POINTS), RATIOS,
                                                (damping.low, damping.value, damping.high)):
            k = float(roll.from_unit(u))
            params = cause.parameters(k, {damping.name: zeta, ratio_param.name: ratio})
            rows.append((f"{k:.0f} N m/rad, pitch x{ratio:g}, zeta {zeta:.2g}", params,
                         free_responses(params)))
            print(rows[-1][0], rows[-1][2], f"{time.time() - t0:.0f} s", flush=True)
    scored = [(label, params, resp, *score(resp, measured)) for label, params, resp in rows]
    scored = [(*r, normalized(r[3], r[4], max_freq_error, max_decay_factor)) for r in scored]
    # the prediction uses the frames that fit Table 5.2 best, whether or not they meet
    # both targets (the rigid model itself misses them narrowly): the table says which
    best = sorted([r for r in scored if r[1] is not None], key=lambda r: r[5])
    lines = [f"`python scripts/calibrate_frame.py {' '.join(argv or sys.argv[1:])}`", "",
             "Fitted set: Table 5.2 (free responses of the extended robot at rest; "
             "measured roll/pitch/yaw "
             + ", ".join(f"{measured.free_response[a]['peak_hz']:.2f} Hz, "
                         f"{measured.free_response[a]['decay_per_s']:g}/s" for a in AXES)
             + f").  Targets: frequencies within {max_freq_error:.0%}, "
               f"decay rates within a factor {max_decay_factor:g}.", "",
             "| frame | roll (Hz, 1/s) | pitch (Hz, 1/s) | yaw (Hz, 1/s) | "
             "largest frequency error | largest decay factor | score (<= 1: both met) |",
             "|---|---|---|---|---|---|---|"]
    for label, _, resp, ferr, dfac, total in scored:
        cells = [f"{resp[a][0]:.2f}, {resp[a][1]:.2f}" for a in AXES]
        lines.append(f"| {label} | " + " | ".join(cells) +
                     f" | {ferr:.1%} | {dfac:.2f} | {total:.2f} |")
    if args.json:
        args.json.write_text(json.dumps([{"frame": r[0], "parameters": r[1],
                                          "responses": r[2], "score": r[5]} for r in scored],
                                         indent=1))
    if args.predict:
        lines += ["", f"Prediction (not fitted): the steady swivel of the {args.predict} frames "
                  f"that fit Table 5.2 best, extended build, {PREDICT_TIMESTEP_S:g} s.", "",
                  "| frame | floor | omega (deg/s) | steady a_y amplitude (m/s^2) | "
                  "lift fraction | mean yaw rate (deg/s) | P_osc (W) |", "|---|---|---|---|---|---|---|"]
        for label, params, *_ in best[:args.predict]:
            edit = (lambda spec, p=params: cause.apply(spec, p, 1))
            for floor, omegas in PREDICT_OMEGAS.items():
                for row in screen_mechanisms.simulate(Setup(build="extended", floor=floor),
                                                      edit, omegas, 14.0,
                                                      timestep=PREDICT_TIMESTEP_S):
                    lines.append(f"| {label} | {floor} | {row['omega_deg_s']:g} | "
                                 f"{row['steady_amplitude_y_m_s2']:.3f} | "
                                 f"{row['lift_fraction']:.3f} | "
                                 f"{row['mean_yaw_rate_deg_s']:.1f} | "
                                 f"{row['tire_power_into_vibration_w']:.1e} |")
                    print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    print(text)
    if args.markdown:
        args.markdown.write_text(text)
    print(f"{time.time() - t0:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
