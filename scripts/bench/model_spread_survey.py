"""The base model's errors on the committed benchmark draws, read against the trials'
spread alone (diagnose's default) and with the model's own start-to-start spread at each
command added (diagnose --model-spread; issue 18's option (d)).

A diagnosis says no-discrepancy when the base model's error over all runs is within
Z_CONSISTENT, and names a cause only when its held-out command shows a discrepancy of
its own (base error there above Z_CONSISTENT).  Both move when the scale holds the
model's own scatter: a null whose trials fell in one regime of a command the model
splits (draw 1211) is no longer a discrepancy, and an effect within the model's own
scatter is no longer one either.  This script measures both on the draws' datasets
(regenerated under --out when missing, as the generalisation benchmark makes them),
with the base model only (every command from diagnose's STARTS starts): no fit, so it
says which draws the option moves across the limits, not how the fits then fare.

    python scripts/bench/model_spread_survey.py --out /tmp/gen --rows survey.jsonl \\
        draw-1211 draw-1179 draw-1215

Each draw costs its dataset (9 runs of 20 s) and 15 simulations of 20 s.  Rows are
JSON lines: per scale ("trials", "model"), the base error over all runs, on the
held-out runs (the split made under that scale, as diagnose makes it) and the noise
error; finished draws in --rows are not run again.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import skidsteer  # noqa: E402,F401
from bench_diagnose_ceiling import Measured  # noqa: E402
from bench_diagnose_generalisation import case_of, newest_rows  # noqa: E402
from skidsteer.diagnosis import Z_CONSISTENT  # noqa: E402
from skidsteer.diagnosis.fit import base_group_errors, median_error, split  # noqa: E402

DOCS = Path(__file__).resolve().parents[2] / "docs"


def errors(comparison, measured: Measured) -> dict:
    """The base model's errors as diagnose reads them under `comparison`'s scale: over all
    runs, on the held-out runs of the split made under it, and the noise error."""
    starts, observed = measured.base_starts, measured.observed
    train, held = split(observed, base_group_errors(comparison, starts))
    return {"base_error": median_error(comparison, starts, np.arange(len(observed.run_group))),
            "base_held": median_error(comparison, starts, held, train),
            "noise": comparison.noise_error(),
            "held_out_groups": sorted({int(g) for g in observed.run_group[held]})}


def survey_row(row: dict, out: Path, threads: int) -> dict:
    m = Measured(case_of(row), out, 3, 20.0, threads)
    return {"case": row["case"], "effect": row["effect"], "floor": row["floor"],
            "omegas": row["omegas"], "outcome": row.get("outcome"),
            "trials": errors(m.comparison, m),
            "model": errors(m.comparison.with_model_spread(m.base_starts), m)}


def line(r: dict) -> str:
    def cell(e):
        quiet = " (no-discrepancy)" if e["base_error"] <= Z_CONSISTENT else ""
        return f"{e['base_error']:.2f}{quiet}, held-out {e['base_held']:.2f}"
    return (f"| {r['case']} | {r['effect'] or 'null'} | {r['outcome']} | "
            f"{cell(r['trials'])} | {cell(r['model'])} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="+", help="committed draws (names in the table)")
    ap.add_argument("--out", type=Path, required=True, help="datasets and simulations")
    ap.add_argument("--rows", type=Path, required=True, help="JSON lines, appended")
    ap.add_argument("--results", type=Path, default=DOCS / "diagnose-generalisation.jsonl",
                    help="the draws' rows (default: the committed ones)")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args(argv)
    rows = newest_rows(args.results)
    unknown = [c for c in args.cases if c not in rows]
    if unknown:
        ap.error(f"{args.results} has no row of {', '.join(unknown)}")
    done = newest_rows(args.rows) if args.rows.exists() else {}
    print("| draw | effect | diagnose | trials' spread: base error | with the model's: base "
          "error |\n|---|---|---|---|---|")
    for case in args.cases:
        if case not in done:
            done[case] = survey_row(rows[case], args.out, args.threads)
            with open(args.rows, "a") as f:
                f.write(json.dumps(done[case]) + "\n")
        print(line(done[case]), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
