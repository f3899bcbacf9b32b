"""docs/real-data/borealtc.md: skidsteer diagnose on every terrain of the BorealTC
recordings of a Husky A200 (issue 20), one table.

Usage:  python scripts/borealtc_report.py [--data ../shared/data/borealtc]
        [--out /tmp/borealtc-diagnoses] [--markdown docs/real-data/borealtc.md]
Each terrain is `skidsteer diagnose DATA/TERRAIN --model husky_a200 --out OUT/TERRAIN`
(its diagnosis.json and report.md stay under --out; --reuse takes them from there
instead of diagnosing again).  ~2-6 min per terrain on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from skidsteer.reports.real_data import diagnose_recordings

HEAD = """# Real recordings: the Husky A200 of BorealTC

`{command}`

What `skidsteer diagnose` says about real recordings nobody here produced: the
public BorealTC dataset (D. LaRocque, W. Guimont-Martin, D.-A. Duclos,
P. Giguère, F. Pomerleau, "Proprioception Is All You Need: Terrain
Classification for Boreal Forests", IROS 2024; CC0), a Clearpath Husky A200
driven on four terrains, IMU at 100 Hz and the wheel speeds at 6.5 Hz
([data format](../data-format.md#imu-runs-real-recordings-with-wheel-speeds)).
The model is `models/husky_a200` (public mass properties, the rest assumed;
its floors stated before any comparison).  Every run is replayed on the base
model from its own wheel speeds; every span of one kind of command (turning in
place, arc, straight) of at least 3 s is a trial.  The feature is the
effective-track factor chi, the yaw rate the wheel speeds predict from the
track over the one the gyro measures (1: no slip), of the segments turning in
place and of the arcs, each its own feature (|predicted| >= 3 deg/s); the
scatter is that of the repeated segments (robust standard error of their
median).  A cause is fitted on the even-numbered runs'
segments and judged on the odd-numbered ones (held out).

| terrain | runs (skipped) | chi in place, measured (segments) | base model | chi in arcs, measured (segments) | base model | verdict | cause, fitted on half the runs (interval) | held-out runs: chi with the cause vs measured | floor | time (s) |
|---|---|---|---|---|---|---|---|---|---|---|
"""

TAIL = """
What the table says, and what it does not:

- On the rigid floors the base model turns 1.5-1.65 times slower for its wheel
  speeds than the robot does (chi 2.1-2.35 against 1.35-1.45), in place and in
  arcs, far outside the segments' scatter.  With the floors' friction stated
  before the comparison (the thesis's sets), the target "chi turning in place
  on flooring within 10 %" is missed by ~58 %.
- Turning in place: a skid-steer robot turning in place drags its wheels
  sideways against lateral friction in proportion to each wheel's load; the
  URDF puts the centre of mass 8.5 cm right of the centre line (65 % of the
  weight on one side), and the loaded side resists as if the robot were wider.
  The motion cause `com_lateral_offset` (skidsteer.diagnosis.motion), found in
  these data and tested on hidden-effect data (tests/test_real_data.py), is the
  most likely cause on flooring: fitted on half the runs it brings the held-out
  runs' chi in place to within ~7 % of the measured (a diagnosis, fitted: it
  counts as such), but not within the segments' tight scatter, and it leaves
  the arcs untouched.  With the centre of mass simply centred (not fitted), the
  model turns in place at chi 1.33 (constant 15.6 deg/s swivel), 2 % from the
  measured 1.35.
- Arcs: no candidate closes them (the model's 2.2-2.35 against 1.42-1.45).  In
  an arc the wheels roll, and the thesis's law gives a rolling wheel lateral
  friction in proportion to its lateral slip over its rolling speed and
  lambda_max (eq. 4.12b); even lambda_max at its prior's top leaves chi at 1.85.
  What the law lacks here is the suspect: the verdict is "unexplained", with the
  most likely cause and what it leaves.
- Sandy loam and snow are not rigid floors: the robot sinks, bulldozes and
  gets stuck (in 10 of the 27 snow runs the robot hardly turns while its
  wheels do); chi there is a property of the ground that no rigid-floor cause
  has, and the verdict is "unexplained" with that reason rather than a wrong
  name.
- The wheel speeds in these files behave like the commanded set points (steps
  of 1/127 m/s, held unchanged for seconds, unchanged while the robot is
  stuck), so chi here is the commanded over the measured yaw rate; the replay
  uses them as the servos' targets.
- Vibration: on the hard floors the straight segments hold lines at 18, 36 and
  54 times the wheels' rotation rate (17.3 Hz per m/s of rim speed) on every
  axis, strongest on a_x (fore-aft) and at 36; the base model's round wheels on a
  flat floor make none, and its broad level is 2-3 orders of magnitude below the
  robot's.  The cause added for it, `tread_lugs` (the tire plugin's `lug_count`,
  `lug_depth`: a wheel rolling as a polygon; skidsteer.diagnosis.tread, tested on
  hidden-effect data), identifies 18 lugs from the lines and fits a depth of
  1 mm (asphalt) to 3.2 mm (flooring), but puts the line where a rolling polygon
  puts it, on a_z (at order 18 too strong by 13-30 dB on the held-out runs)
  with almost nothing fore-aft (a_x short by 12-50 dB): what makes these
  lines pushes the robot along its track, which a radial tread does not.  A
  drivetrain order (each side's motor drives both wheels: a gear or chain
  meshing 18 or 36 times per wheel revolution) is the candidate this points to; nothing public here says how the Husky's wheels are
  driven, so it is left as the finding.  On sandy loam and snow no line
  stands out (the lugs sink in), and the vibration verdict is "unexplained"
  with the ground named as the reason.
"""


VIBRATION_HEAD = """
## Vibration

Per kind of segment (at least 5): the lines at fixed multiples of the wheels'
rotation rate (wheel orders, local maxima of the segments' median prominence of
at least 6 dB over the PSD beside them; orders whose frequency the 100 Hz record
cannot hold, above 45 Hz, are not judged) and the RMS per axis from 1 to 45 Hz,
recording against the base model replaying the same runs.

| terrain | kind (segments) | lines in the recordings: order, axis (dB) | the model at those orders (dB) | RMS recorded a_x, a_y, a_z (m/s^2) | base model | vibration verdict |
|---|---|---|---|---|---|---|
"""


def _vibration_rows(terrain: str, vib: dict) -> list[str]:
    rows = []
    for kind, v in vib["kinds"].items():
        recorded = [f for f in v["lines"] if f["in"] == "recording"]
        lines = ", ".join(f"{f['order']} a_{f['axis']} ({f['measured_db']:.0f})"
                          for f in recorded) or "none"
        model = ", ".join("-" if f["simulated_db"] is None else f"{f['simulated_db']:.0f}"
                          for f in recorded) or "-"
        rms = ", ".join(f"{e['measured_m_s2']:.3f}" for e in v["rms"].values())
        base = ", ".join(f"{e['simulated_m_s2']:.3f}" for e in v["rms"].values())
        rows.append(f"| {terrain} | {kind} ({v['segments']}) | {lines} | {model} | {rms} | "
                    f"{base} | {vib['verdict']} |\n")
    if not rows:
        rows.append(f"| {terrain} | - | - | - | - | - | {vib['verdict']} |\n")
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data/borealtc"))
    ap.add_argument("--out", type=Path, default=Path("/tmp/borealtc-diagnoses"))
    ap.add_argument("--markdown", type=Path, default=None)
    ap.add_argument("--model", default="husky_a200")
    ap.add_argument("--reuse", action="store_true",
                    help="take a terrain's diagnosis.json from --out when it is there")
    args = ap.parse_args(argv)
    terrains = sorted(p for p in args.data.iterdir() if p.is_dir())
    if not terrains:
        print(f"{args.data}: no terrain folders", file=sys.stderr)
        return 2
    command = "python scripts/borealtc_report.py " + " ".join(
        argv if argv is not None else sys.argv[1:])
    lines, reasons = [HEAD.format(command=command)], ["\nThe verdicts' reasons:\n\n"]
    vibration = [VIBRATION_HEAD]
    vibration_reasons = ["\nThe vibration verdicts' reasons:\n\n"]
    for folder in terrains:
        saved = args.out / folder.name / "diagnosis.json"
        if args.reuse and saved.is_file():
            r = json.loads(saved.read_text())
        else:
            r = diagnose_recordings(folder, args.out / folder.name, model=args.model)
        runs = len({row["run"] for row in r["runs"]})
        chi = {kind: f"{f['measured']['median']:.2f} +- {f['measured']['stderr']:.2f} "
                     f"({f['measured']['n']})" for kind, f in r["features"].items()}
        base = {kind: f"{f['simulated']['median']:.2f}" for kind, f in r["features"].items()}
        cell = (lambda d, k: d.get(k, "-"))
        gain = r["gain"]
        cause, held = "-", "-"
        if gain:
            name, value = next(iter(gain["parameters"].items()))
            interval = gain["intervals"].get(name)
            cause = (f"{gain['cause']}{' (named)' if r['cause'] else ' (most likely)'}: "
                     f"{name} = {value:.3g}"
                     + (f" ({interval[0]:.3g} to {interval[1]:.3g})" if interval else ""))
            held = "; ".join(f"{k} {e['held_out_model']:.2f} vs {e['held_out_measured']:.2f}"
                             for k, e in gain["per_kind"].items()) + (
                f" ({gain['share_removed']:.0%} removed)")
        lines.append(f"| {folder.name} | {runs} ({len(r['skipped'])}) | "
                     f"{cell(chi, 'turn_in_place')} | {cell(base, 'turn_in_place')} | "
                     f"{cell(chi, 'arc')} | {cell(base, 'arc')} | **{r['verdict']}** | "
                     f"{cause} | {held} | {r['floor_note']} | {r['wall_time_s']:.0f} |\n")
        reasons.append(f"- **{folder.name}**: {r['reason']}\n")
        vibration += _vibration_rows(folder.name, r["vibration"])
        vibration_reasons.append(f"- **{folder.name}**: {r['vibration']['reason']}\n")
        print(lines[-1], end="", flush=True)
    text = "".join(lines) + "".join(reasons) + "".join(vibration) + "".join(vibration_reasons) + TAIL
    if args.markdown:
        args.markdown.parent.mkdir(parents=True, exist_ok=True)
        args.markdown.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
