"""Calibrate the frame's compliance (mast_compliance) on Table 5.2, then predict the
swivel (issue 19, item 3).

Fitted set: Table 5.2 of the thesis, the free responses of the extended robot at
rest (roll, pitch, yaw: peak frequency and decay rate, measured with the cube on
the platform as the model's accelerometer is), read from
python/skidsteer/data/thesis_measurements.toml.  The swivel features at
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
the rigid model scores 1.01: roll +10.1 %, yaw decay x1.61).  The prediction
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

import screen_mechanisms  # scripts/, beside this file (the swivel measurement of the screen)
from skidsteer.diagnosis import causes
from skidsteer.diagnosis import thesis_targets  # Table 5.2 and the comparison with it
from skidsteer.diagnosis.causes.mast_compliance import DAMPING_RATIO, PITCH_STIFFNESS_RATIO
from skidsteer.experiments.free_response import free_response
from skidsteer.robot import Setup

MAST = causes.get("mast_compliance")

AXES = ("roll", "pitch", "yaw")
# the grid over the frame's prior: roll stiffness at 7 log-spaced points of its
# prior, the pitch/roll ratio at 1, 10 and 100, the damping ratio at its ends and middle
ROLL_POINTS = 7
RATIOS = (1.0, 10.0, 100.0)
PREDICT_OMEGAS = {"concrete": [48.0, 56.0, 64.0, 72.0, 80.0, 88.0, 96.0],
                  "carpet": [40.0, 48.0, 56.0, 64.0, 72.0, 80.0]}
PREDICT_TIMESTEP_S = 2.5e-5  # the screen's converged step for the steady swivel


def free_responses(params: dict | None) -> dict:
    """axis -> {refined_peak_hz, decay_per_s} of the extended robot with this frame (None:
    rigid), as reproduction.py measures them."""
    return free_responses_of(None if params is None else
                             (lambda spec: MAST.apply(spec, params, 1)))


def free_responses_of(edit) -> dict:
    """free_responses of the extended robot under any MjSpec edit (None: as built)."""
    out = {}
    for axis in AXES:
        r = free_response(axis, edit=edit)
        out[axis] = {key: float(r[key]) for key in ("refined_peak_hz", "decay_per_s")}
    return out


def score(responses: dict) -> tuple[float, float, float]:
    """(largest |frequency error|, largest decay factor) over the axes against Table 5.2,
    and one number: the larger of the two in units of its target (<= 1: both met)."""
    compared = [thesis_targets.against_table_5_2(axis, responses[axis]) for axis in AXES]
    freq_error = max(abs(c["frequency_error"]) for c in compared)
    decay_factor = max(c["decay_factor"] for c in compared)
    total = max(freq_error / thesis_targets.FREQUENCY_TARGET,
                np.log(decay_factor) / np.log(thesis_targets.DECAY_TARGET_FACTOR))
    return freq_error, decay_factor, total


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--markdown", type=Path, default=None)
    ap.add_argument("--predict", type=int, default=2)
    ap.add_argument("--json", type=Path, default=None, help="write the grid's responses here")
    ap.add_argument("--from-json", type=Path, default=None,
                    help="take the grid's responses from a --json file instead of simulating")
    args = ap.parse_args(argv)
    t0 = time.time()
    if args.from_json:
        rows = [(r["frame"], r["parameters"], r["responses"])
                for r in json.loads(args.from_json.read_text())]
    else:
        rows = [("rigid (base model)", None, free_responses(None))]
        for u, ratio, zeta in itertools.product(
                np.linspace(0, 1, ROLL_POINTS), RATIOS,
                (DAMPING_RATIO.low, DAMPING_RATIO.value, DAMPING_RATIO.high)):
            k = float(MAST.main.from_unit(u))
            params = MAST.parameters(k, {DAMPING_RATIO.name: zeta,
                                         PITCH_STIFFNESS_RATIO.name: ratio})
            rows.append((f"{k:.0f} N m/rad, pitch x{ratio:g}, zeta {zeta:.2g}", params,
                         free_responses(params)))
            print(rows[-1][0], rows[-1][2], f"{time.time() - t0:.0f} s", flush=True)
    scored = [(label, params, resp, *score(resp)) for label, params, resp in rows]
    # the prediction uses the frames that fit Table 5.2 best, whether or not they meet
    # both targets (the rigid model itself misses them narrowly): the table says which
    best = sorted([r for r in scored if r[1] is not None], key=lambda r: r[5])
    measured = thesis_targets.TABLE_5_2
    lines = [f"`python scripts/calibrate_frame.py {' '.join(argv or sys.argv[1:])}`", "",
             "Fitted set: Table 5.2 (free responses of the extended robot at rest; "
             "measured roll/pitch/yaw "
             + ", ".join(f"{measured[a]['peak_hz']:.2f} Hz, "
                         f"{measured[a]['decay_per_s']:g}/s" for a in AXES)
             + f").  Targets: frequencies within {thesis_targets.FREQUENCY_TARGET:.0%}, "
               f"decay rates within a factor {thesis_targets.DECAY_TARGET_FACTOR:g}.", "",
             "| frame | roll (Hz, 1/s) | pitch (Hz, 1/s) | yaw (Hz, 1/s) | "
             "largest frequency error | largest decay factor | score (<= 1: both met) |",
             "|---|---|---|---|---|---|---|"]
    for label, _, resp, ferr, dfac, total in scored:
        cells = [f"{resp[a]['refined_peak_hz']:.2f}, {resp[a]['decay_per_s']:.2f}"
                 for a in AXES]
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
            edit = (lambda spec, p=params: MAST.apply(spec, p, 1))
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
