"""Benchmark: every command judged (leave-one-command-out) against one held-out command.

diagnose holds out one command of three and rests its verdict on that command's three
runs (diagnosis.split).  diagnosis.folds reads instead one verdict over three folds, each
holding out another command: every run is predicted once by fits that never saw its
command.  This script measures both on the same fresh draws of the generalisation
benchmark: for each chosen row of its results it diagnoses the row's dataset once per
command with that command held out (diagnose --hold-out; datasets regenerated under --out
when missing, simulations kept in its cache), combines the folds
(folds.every_command_verdict) and writes one row per case with its folds (what the verdict
rules read of each, so the report judges every row by the rules as they are now).  The
report sets beside each other the single split's verdict, the folds' combined one, each
fold's own, and the cost of both.  Each fold is kept under OUT/folds as it finishes, so a
killed run resumes.

The single split is the fold holding out the row's command, diagnosed by the code as it
is (the row's own outcome, maybe of older code, is kept beside it).  The cost: that fold's
wall time against the three folds' (without proposing a next command, which either
verdict may add); a fold that ran beside another job ran slower, so the ratio of one
case is rough and the report gives the median.

    python scripts/bench/bench_every_command.py --out /tmp/gen \
        --results docs/diagnose-generalisation.jsonl --every docs/diagnose-every-command.jsonl \
        --cases draw-1302 draw-1305 --markdown docs/diagnose-every-command.md
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import skidsteer  # noqa: F401  (registers the plugin)
from _machine import machine  # scripts/bench/, beside this file
from bench_diagnose_ceiling import _dataset
from bench_diagnose_generalisation import case_of
from skidsteer.diagnosis import causes
from skidsteer.diagnosis.benchmark_rows import fraction, newest_rows, outcome, row_outcome
from skidsteer.diagnosis.folds import every_command_verdict, split_verdict
from skidsteer.diagnosis.verdict import Z_CONSISTENT
from skidsteer.reports.diagnosis import diagnose
from skidsteer.reports.markdown import table
from skidsteer.simulation.cache import code_fingerprint

# what a fold keeps of its diagnosis summary: what the verdicts read (folds.split_verdict,
# folds.every_command_verdict), the fitted parameters, the fold's own verdict and its time
RANKED = ("cause", "held_out_error", "train_error", "score", "fitted", "parameters")


def fold_path(out: Path, case: str, command: str) -> Path:
    return out / "folds" / f"{case}-{command}.json"


def compact(summary: dict) -> dict:
    """A fold as a row keeps it: the diagnosis summary's fields the verdicts read, its own
    verdict and its time."""
    return {"dataset": {k: summary["dataset"][k] for k in ("groups", "held_out_groups")},
            "ranking": [{k: f[k] for k in RANKED} for f in summary["ranking"]],
            "gain": {k: summary["gain"][k] for k in ("baseline_error", "noise_error")},
            **{k: summary[k] for k in ("baseline_error_all_runs", "baseline_error_training",
                                       "training_runs", "verdict", "cause", "wall_time_s")}}


def folds_of(case: dict, out: Path, trials: int, duration_s: float,
             threads: int) -> list[dict]:
    """The case's folds, one per command held out (kept as compact() keeps them), each
    read from OUT/folds where a run (this one or a killed one) stored it, else diagnosed
    and stored."""
    data = _dataset(case, out, trials, duration_s, threads)
    folds = []
    for omega in case["omegas"]:
        command = f"v0-w{omega:g}"
        path = fold_path(out, case["case"], command)
        if not path.exists():
            result = diagnose(data, None, nthread=threads, progress=True, figures=False,
                              cache_dir=out / "simulations", next_command=False,
                              held_out=[command])
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(compact(result), default=float))
        folds.append(json.loads(path.read_text()))
    return folds


def every_row(row: dict, folds: list[dict]) -> dict:
    """The case's row: its folds, and what the generalisation row said (maybe of older
    code)."""
    return {"case": row["case"], "effect": row["effect"], "seed": row["seed"],
            "single_held_out": row["held_out_groups"][0],
            "row_outcome": row_outcome(row), "row_code": row.get("code"),
            "row_diagnose_s": row["diagnose_s"], "folds": folds,
            "code": code_fingerprint()[:12]}


def judged(row: dict) -> dict:
    """Both verdicts by the rules as they are now: the single split (the fold holding out
    the row's command) and every command (folds.every_command_verdict), each with its
    outcome and time (every command: the three folds')."""
    summaries = row["folds"]
    found = every_command_verdict(summaries)
    i = found.held_out.index(row["single_held_out"])
    single, single_named = split_verdict(summaries[i])
    named = found.named.cause if found.named is not None else None
    base_error = summaries[0]["baseline_error_all_runs"]
    return {"single": {"verdict": single, "cause": single_named,
                       "outcome": outcome(row["effect"], single, single_named, base_error),
                       "base_held": summaries[i]["gain"]["baseline_error"],
                       "diagnose_s": summaries[i]["wall_time_s"]},
            "every": {"verdict": found.verdict, "cause": named,
                      "outcome": outcome(row["effect"], found.verdict, named, base_error),
                      "base_held": found.base_held, "reason": found.reason,
                      "diagnose_s": sum(f["wall_time_s"] for f in summaries)},
            "folds": [split_verdict(s) for s in summaries], "held_out": found.held_out}


def report(rows: list[dict]) -> str:
    """The side-by-side table and its summary."""
    seen = [(r, judged(r)) for r in rows]
    lines = [table(["case", "hidden", "held out (base error there)", "one held-out command",
                    "every command (base error)", "each fold alone", "s: one / every"],
                   [[r["case"], r["effect"] or "none",
                     f"{r['single_held_out'].split()[0]} ({j['single']['base_held']:.2f})",
                     f"{j['single']['verdict']} {j['single']['cause'] or ''} "
                     f"({j['single']['outcome']})",
                     f"{j['every']['verdict']} {j['every']['cause'] or ''} "
                     f"({j['every']['outcome']}; {j['every']['base_held']:.2f})",
                     "; ".join(f"{h.split()[0]}: {named or said}"
                               for h, (said, named) in zip(j["held_out"], j["folds"])),
                     f"{j['single']['diagnose_s']:.0f} / {j['every']['diagnose_s']:.0f}"]
                    for r, j in seen]).rstrip(), ""]
    clear = [(r, j) for r, j in seen if r["effect"] in causes.CAUSES
             and j["single"]["outcome"] != "inside noise"]
    for scheme, said in (("single", "one held-out command"), ("every", "every command")):
        right = sum(j[scheme]["outcome"] == "right" for _, j in clear)
        wrong = sum(j[scheme]["outcome"] == "wrong" for _, j in seen)
        lines.append(f"- {said}: {fraction(right, len(clear))} clear causes named right; "
                     f"{wrong} wrong outcome(s) over all {len(seen)} rows")
    quiet = [j for _, j in clear if j["single"]["base_held"] <= Z_CONSISTENT]
    if quiet:
        lines.append(f"- {len(quiet)} of the clear causes have the single split's held-out "
                     f"command quiet (base error within {Z_CONSISTENT}); every command names "
                     f"{sum(j['every']['outcome'] == 'right' for j in quiet)} of them")
    # a null or an effect inside the noise stops after the base model: no fold to time
    ratios = [j["every"]["diagnose_s"] / j["single"]["diagnose_s"] for _, j in seen
              if j["single"]["diagnose_s"] > 60]
    if ratios:
        lines.append(f"- cost: every command takes {np.median(ratios):.1f}x the single "
                     f"split's diagnosis time (median of {len(ratios)}; "
                     f"{min(ratios):.1f}-{max(ratios):.1f}x)")
    changed = sum(r["row_outcome"] != j["single"]["outcome"] for r, j in seen)
    if changed:
        lines.append(f"- {changed} row(s) whose generalisation row (older code) had another "
                     "outcome than this code's single split")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="the generalisation benchmark's "
                    "--out: its datasets and simulation cache; the folds go to OUT/folds")
    ap.add_argument("--results", type=Path, required=True, help="the generalisation "
                    "benchmark's rows")
    ap.add_argument("--every", type=Path, required=True, help="this benchmark's rows (JSON "
                    "lines; finished cases are not run again)")
    ap.add_argument("--cases", nargs="*", default=[], help="the rows' cases to run")
    ap.add_argument("--report", action="store_true", help="tabulate the rows and stop")
    ap.add_argument("--trials", type=int, default=3)
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--markdown", type=Path, help="also write the table to this file")
    args = ap.parse_args(argv)
    rows = newest_rows(args.results)
    missing = [c for c in args.cases if c not in rows]
    if missing:
        ap.error(f"{args.results} has no row of {', '.join(missing)}")
    done = newest_rows(args.every)
    for case in [] if args.report else args.cases:
        if case in done:
            continue
        started = time.perf_counter()
        folds = folds_of(case_of(rows[case]), args.out, args.trials, args.duration,
                         args.threads)
        row = every_row(rows[case], folds)
        done[case] = row
        with open(args.every, "a") as f:
            f.write(json.dumps(row) + "\n")
        seen = judged(row)
        print(f"{case}: one held-out command {seen['single']['outcome']}, every command "
              f"{seen['every']['verdict']} {seen['every']['cause'] or ''} "
              f"({seen['every']['outcome']}; {time.perf_counter() - started:.0f} s)",
              flush=True)
    text = report([done[c] for c in done])
    print(text)
    if args.markdown:
        args.markdown.write_text(
            "# every command judged against one held-out command\n\nGenerated by `python "
            f"scripts/bench/bench_every_command.py --out DIR --results {args.results} "
            f"--every {args.every} --cases CASE ... --markdown {args.markdown}` "
            "(`--report` to tabulate the rows only); what each column means is in the "
            f"script's docstring.\n\n{text}\nMachine: {machine()}.\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
