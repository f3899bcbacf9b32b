"""docs/real-data/borealtc.md: skidsteer diagnose on the BorealTC recordings of a Husky
A200, every terrain at once (the robot and each rigid terrain identified apart, leave
one terrain out, the ground's evidence, the wheel-order lines), with its two figures.

Usage:  python scripts/borealtc_report.py [--data ../shared/data/borealtc]
        [--out /tmp/borealtc-diagnosis] [--markdown docs/real-data/borealtc.md] [--reuse]
The diagnosis is `skidsteer diagnose DATA --model husky_a200 --out OUT` (its
diagnosis.json, report.md, figures and identified robot stay under --out; --reuse reads
them from there instead of diagnosing again).
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

from skidsteer.reports import real_data
from skidsteer.reports.markdown import table

HEAD = """# Real recordings: the Husky A200 of BorealTC

`{command}`

What `skidsteer diagnose` says about real recordings nobody here produced: the public
BorealTC dataset (D. LaRocque, W. Guimont-Martin, D.-A. Duclos, P. Giguère,
F. Pomerleau, "Proprioception Is All You Need: Terrain Classification for Boreal
Forests", IROS 2024; CC0), a Clearpath Husky A200 driven on four terrains, IMU at 100 Hz,
wheel speeds and motor currents at 6.5 Hz
([data format](../data-format.md#imu-runs-real-recordings-with-wheel-speeds)).  The
model is `models/husky_a200` (public mass properties, the rest assumed).  All four
terrains are diagnosed together: the robot's parameters are shared by every rigid
terrain, each terrain has its own; alternate runs of each terrain train, the others
are held out ([the method](../diagnose.md)).  {wall}

![chi per turning segment: measured, base model, identified robot](figures/chi_per_segment.png)
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default="../shared/data/borealtc")
    parser.add_argument("--out", default="/tmp/borealtc-diagnosis")
    parser.add_argument("--markdown", default="docs/real-data/borealtc.md")
    parser.add_argument("--reuse", action="store_true")
    args = parser.parse_args()
    out, markdown = Path(args.out), Path(args.markdown)
    if args.reuse and (out / real_data.RESULT).is_file():
        result = json.loads((out / real_data.RESULT).read_text())
    else:
        result = real_data.diagnose_recordings([args.data], out, model="husky_a200")
    figures = markdown.parent / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    for name in result["figures"]:
        shutil.copy(out / name, figures / Path(name).name)
    command = (f"skidsteer diagnose {args.data} --model husky_a200 --out {args.out}  "
               f"(this page: python scripts/borealtc_report.py)")
    wall = (f"The diagnosis took {result['wall_time_s']:.0f} s on this project's 2-core "
            f"machine ({result['simulations']} surrogate simulations).")
    md = [HEAD.format(command=command, wall=wall), summary(result)]
    body = real_data.render(result)
    md.append(body[body.index("## How the robot turns"):])
    for name in result["figures"]:
        if "spectrum" in name:
            md.append(f"\n![{Path(name).stem}](figures/{Path(name).name})\n")
    markdown.write_text("".join(md))
    print(f"wrote {markdown}")


def summary(result: dict) -> str:
    """One row per terrain: held-out chi measured, base and identified robot."""
    rows = []
    for name, t in result["terrains"].items():
        for key, e in t["chi"].items():
            if not key.endswith("/held_out"):
                continue
            rows.append([name, "deformable" if t["ground"]["deformable"] else "rigid",
                         key.split("/")[0].replace("_", " "), e["n"],
                         f"{e['measured']:.2f}", f"{e.get('base', float('nan')):.2f}",
                         f"{e['extended']:.2f}" if "extended" in e else "-",
                         real_data._off(e.get("extended"), e["measured"])])
    m = result["motion"]
    return (f"\n**Motion: {m['verdict']}**" + (f" ({m['cause']})" if m["cause"] else "")
            + f". {m['reason']}\n\n"
            + table(["terrain", "ground", "turns", "held-out segments", "chi measured",
                     "base model", "identified robot", "off"], rows) + "\n")


if __name__ == "__main__":
    main()
