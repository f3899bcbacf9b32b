"""Benchmark: how often could `diagnose` name the right cause at all (issue 21's ceiling)?

The generalisation benchmark (bench_diagnose_generalisation.py) measures how often
diagnose names the hidden cause.  A miss there has two possible owners: the fit (it
did not find the truth's parameters) or the data (even the truth, simulated as the
diagnosis simulates a fit, would not pass the verdict rules on three commands x three
trials with the middle command held out).  This script separates them: for every
cause's dataset of the generalisation results whose effect is clear of the trials'
noise, it simulates the hidden truth itself (the same edit, parameters and
realisation that made the dataset: synth.truth_edit replayed from the dataset's seed)
exactly as a fit's end is simulated (every command from start 0, the held-out commands
from STARTS starts, the median error), pays the parameters the hidden cause's fit paid
(the row's fitted parameters, and ln REALISATIONS for a random geometry), and puts it
in the row's ranking in place of the hidden cause's own fit.  The verdict rules then
say whether the truth would be named: the ceiling of any fit, given the data and the
rules.  A row keeps what the rules read (the base model's errors on all, held-out and
training runs, the truth's held-out and training errors and score, the trial noise), so
the report judges every row by the rules as they are now.

The other causes' fits are the row's, as they ran (rows of older code read their
errors as they were); the base model's errors and the trial noise are computed again
with the code as it is.  Datasets are regenerated under --out when missing (the same
call as the generalisation benchmark) and simulations are kept in its cache.

    python scripts/bench/bench_diagnose_ceiling.py --out /tmp/gen \
        --results docs/diagnose-generalisation.jsonl --ceiling docs/diagnose-ceiling.jsonl \
        --markdown docs/diagnose-ceiling.md
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

import skidsteer  # noqa: F401  (registers the plugin)
from _machine import machine  # scripts/bench/, beside this file
from bench_diagnose_generalisation import case_of, generate
from skidsteer.data.dataset import read_dataset
from skidsteer.diagnosis import causes
from skidsteer.diagnosis.benchmark_rows import (counts, drawn_from_indices, fraction, judged,
                                                newest_rows, paid_parameters, row_outcome)
from skidsteer.diagnosis.causes import ground_roughness
from skidsteer.diagnosis.comparison import (Comparison, Observed, group_wheel_rates,
                                            model_factory, simulate_groups)
from skidsteer.diagnosis.evaluate import base_group_errors, median_error, over_starts
from skidsteer.diagnosis.split import split
from skidsteer.diagnosis.synth import truth_edit
from skidsteer.diagnosis.verdict import Z_CONSISTENT, n_parameters, penalised_score
from skidsteer.reports.markdown import table
from skidsteer.simulation.backends import LocalBackend
from skidsteer.simulation.cache import SimulationCache, code_fingerprint
from skidsteer.simulation.sensor_chain import SensorChain


def _dataset(case: dict, out: Path, trials: int, duration_s: float, threads: int) -> Path:
    """The case's dataset directory, generated as the generalisation benchmark does
    when it is not there."""
    data = out / "datasets" / case["case"]
    if not (data / "runs.csv").exists():
        generate(case, out, trials, duration_s, threads)
    return data


class Measured:
    """A case's dataset (regenerated under out when missing) compared as diagnose compares
    it: the training and held-out runs, the base model from start 0 and the Comparison
    read at its wheel rates.  simulated() runs a model through the simulation cache."""

    def __init__(self, case: dict, out: Path, trials: int, duration_s: float, threads: int):
        data = _dataset(case, out, trials, duration_s, threads)
        self.backend, self.chain = LocalBackend(threads), SensorChain()
        self.stored = SimulationCache(out / "simulations")
        observed = Observed.from_dataset(read_dataset(data), group_wheel_rates(model_factory()))
        self.groups, self.duration_s = observed.groups, observed.duration_s
        self.base = self.simulated(model_factory())
        # the records' wheel orders at the base model's wheel rates, as diagnose_observed
        self.observed = observed.with_wheel_rates(self.base.wheel_rates_hz)
        self.comparison = Comparison(self.observed)
        self.base_starts = self.over_starts(self.base, model_factory(),
                                            list(range(len(self.groups))))
        self.train, self.held = split(self.observed,
                                      base_group_errors(self.comparison, self.base_starts))

    def simulated(self, factory):
        return simulate_groups([(factory, self.groups)], self.duration_s, self.chain,
                               backend=self.backend, cache=self.stored, signals=False)[0]

    def over_starts(self, first, factory, which: list[int]):
        return over_starts(first, factory, self.groups, which, self.duration_s, self.chain,
                           self.backend, None, self.stored)


def ceiling_case(case: dict, row: dict, out: Path, trials: int, duration_s: float,
                 threads: int) -> dict:
    """The truth of one dataset simulated as a fit's end: what the verdict reads."""
    started = time.perf_counter()
    m = Measured(case, out, trials, duration_s, threads)
    comparison, train, held = m.comparison, m.train, m.held
    run_group = m.observed.run_group
    base_starts = m.base_starts
    held_groups = sorted({int(g) for g in run_group[held]})
    all_runs = np.arange(len(run_group))

    # the truth, replayed from the seed as synth.make_dataset drew it
    edit, values = truth_edit(case["effect"], case["params"], np.random.default_rng(case["seed"]),
                              "clear", "prior")
    if not all(np.isclose(values[k], v) for k, v in row["truth"].items()):
        raise RuntimeError(f"{case['case']}: the replayed truth {values} is not the dataset's "
                           f"{row['truth']} (synth.make_dataset draws in another order now)")
    truth_model = model_factory(edit)
    truth_first = m.simulated(truth_model)
    truth_starts = m.over_starts(truth_first, truth_model, held_groups)
    held_errors = [comparison.error(s.features, held, train) for s in truth_starts]
    truth_held = float(np.median(held_errors))
    own = next((f for f in row.get("ranking", []) if f["cause"] == case["effect"]), None)
    n_params = n_parameters(case["effect"], len(paid_parameters(case["effect"], own)))
    return {"case": case["case"], "effect": case["effect"], "floor": case["floor"],
            "omegas": list(case["omegas"]), "truth": values,
            "base_error": median_error(comparison, base_starts, all_runs),
            "base_held": median_error(comparison, base_starts, held, train),
            "base_train": comparison.error(m.base.features, train), "n_train": int(len(train)),
            "noise": comparison.noise_error(),
            "truth_held": truth_held, "truth_held_starts": held_errors,
            "truth_train": comparison.error(truth_first.features, train),
            "truth_score": penalised_score(truth_held, n_params, len(train)),
            "fit_held": own["held_out_error"] if own else None,
            "seconds": round(time.perf_counter() - started, 1),
            "code": code_fingerprint()[:12]}


def summary(rows: list[dict], verdicts: list[dict]) -> str:
    """How often the truth would be named, and diagnose where it would, in one sentence."""
    rates = counts(rows, verdicts)
    stops = Counter(v["stopped_by"] for v in verdicts if not v["named"])
    return (f"{len(rows)} causes' datasets clear of the trials' noise: the truth itself would "
            f"be named in {fraction(*rates['named'])}; of those whose held-out command "
            f"shows a discrepancy (base error above {Z_CONSISTENT:g}), "
            f"{fraction(*rates['judged'])}.  diagnose named "
            f"{fraction(*rates['diagnose'])} of the datasets where the truth would "
            "be named.  Where the truth is not named, the rule that stops it: "
            + (", ".join(f"{k} {n}" for k, n in sorted(stops.items())) or "none") + ".")


def report(rows: list[dict], diagnosed: dict[str, dict], draws_from: int | None = None) -> str:
    """The table; diagnosed: the generalisation benchmark's newest row per case; the
    summary also of the draws from seed draws_from on, if given."""
    verdicts = [judged(r, diagnosed[r["case"]]) for r in rows]
    later = drawn_from_indices(rows, diagnosed, draws_from)
    lines = [table(["case", "effect", "floor", "deg/s", "base held-out", "truth held-out",
                    "truth removes", "fit held-out", "with the truth", "diagnose"],
                   [[r["case"], r["effect"], r["floor"],
                     "/".join(f"{w:g}" for w in r["omegas"]), f"{r['base_held']:.2f}",
                     f"{r['truth_held']:.2f}", f"{v['removed']:.0%}",
                     "-" if r["fit_held"] is None else f"{r['fit_held']:.2f}",
                     "named" if v["named"] else f"not named ({v['stopped_by']})",
                     v["diagnose"]] for r, v in zip(rows, verdicts)]).rstrip(), "",
             summary(rows, verdicts)]
    if later:
        seeds = [diagnosed[rows[i]["case"]]["seed"] for i in later]
        lines.append(f"Draws from {draws_from} on ({min(seeds)}-{max(seeds)}): "
                     + summary([rows[i] for i in later], [verdicts[i] for i in later]))
    lines += [
             "By the code that diagnosed the rows (simulation cache fingerprint): "
             + "; ".join(_by_code(rows, verdicts, diagnosed)) + ".",
             f"Machine: {machine()}."]
    return "\n".join(lines)


def _by_code(rows: list[dict], verdicts: list[dict], diagnosed: dict[str, dict]) -> list[str]:
    """Per code version of the generalisation rows: how often the truth would be named
    and how often diagnose named those."""
    codes = list(dict.fromkeys(diagnosed[r["case"]].get("code", "not recorded") for r in rows))
    parts = []
    for code in codes:
        mine = [v for r, v in zip(rows, verdicts)
                if diagnosed[r["case"]].get("code", "not recorded") == code]
        named = [v for v in mine if v["named"]]
        parts.append(f"{code}: the truth named in {len(named)} of {len(mine)}, diagnose "
                     f"named {sum(v['diagnose'] == 'right' for v in named)} of those")
    return parts


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="the generalisation benchmark's "
                    "--out (datasets and simulation cache)")
    ap.add_argument("--results", type=Path, required=True,
                    help="the generalisation benchmark's rows")
    ap.add_argument("--ceiling", type=Path, required=True, help="this benchmark's rows "
                    "(JSON lines, appended as each case finishes; a rerun resumes)")
    ap.add_argument("--only", nargs="*", help="only these cases")
    ap.add_argument("--rerun", nargs="*", default=[], help="run these cases again (their "
                    "earlier rows stay in the file; the table shows a case's newest row)")
    ap.add_argument("--trials", type=int, default=3)
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--report", action="store_true", help="print the table and stop")
    ap.add_argument("--markdown", type=Path, help="also write the table to this file")
    ap.add_argument("--draws-from", type=int, help="also summarise the draws from this seed "
                    "on (the README's 1080)")
    args = ap.parse_args(argv)

    newest = newest_rows(args.results)
    if not args.report:
        done = set(newest_rows(args.ceiling))
        todo = [case_of(row) for name, row in newest.items()
                if row["effect"] in causes.CAUSES and row_outcome(row) != "inside noise"
                and (name not in done or name in args.rerun)
                and (not args.only or name in args.only)]
        # the misses first (what the ceiling is to explain), then the newest rows
        todo.sort(key=lambda c: (row_outcome(newest[c["case"]]) != "missed", -c["seed"]))
        for i, case in enumerate(todo):
            # the row's rough floor, as its data and fits had it (rows without the
            # field: the plugin's default)
            try:
                with ground_roughness.contact_normal(
                        newest[case["case"]].get("rough_floor_normal")):
                    result = ceiling_case(case, newest[case["case"]], args.out, args.trials,
                                          args.duration, args.threads)
            except Exception as err:  # one broken case does not sink the run
                print(f"{case['case']}: failed: {err!r}", flush=True)
                continue
            with args.ceiling.open("a") as f:
                f.write(json.dumps(result) + "\n")
            print(f"[{i + 1}/{len(todo)}] {case['case']} {case['effect']}: held-out error "
                  f"base {result['base_held']:.2f}, truth {result['truth_held']:.2f}; training "
                  f"base {result['base_train']:.2f}, truth {result['truth_train']:.2f} "
                  f"({result['seconds']:.0f} s)", flush=True)
    rows = list(newest_rows(args.ceiling).values())
    text = report(rows, newest, args.draws_from)
    print(text)
    if args.markdown:
        args.markdown.write_text(
            "# Could diagnose name the cause at all? (the truth's verdict)\n\nGenerated by "
            f"`python scripts/bench/bench_diagnose_ceiling.py --out DIR --results {args.results} "
            f"--ceiling {args.ceiling} --markdown {args.markdown}"
            + (f" --draws-from {args.draws_from}" if args.draws_from is not None else "")
            + "` (`--report` to tabulate the "
            "rows only); the method is in the script's docstring.  Each dataset's hidden truth "
            "is simulated as a fit's end and judged by the verdict rules beside the other "
            "causes' fits of its generalisation row: \"with the truth\" says whether it would "
            "be named, and by which rule not; \"diagnose\" is the generalisation benchmark's "
            "outcome.  A random geometry's truth uses its own realisation, which a fit never "
            "knows (it tries 8): for those rows the ceiling is an upper bound.  The training "
            "rules read the lower of the truth's training error and its cause's fit's (a fit's "
            "is the lowest of a search, the truth's one simulation).\n\n" + text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
