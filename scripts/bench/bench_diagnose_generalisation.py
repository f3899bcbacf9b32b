"""Benchmark: does `diagnose` name the right cause on datasets nobody tuned it on (issue 21)?

Each dataset is drawn with a fresh seed: the effect (every candidate cause in turn,
a null dataset and an effect outside the candidates), the floor, three swivel
commands, the cause's main parameter clear of the base model (Cause.strong_draw)
and its other parameters from their priors (synth.make_dataset(held="prior")),
3 trials per command.  The issue's two fixed cases come first:

- ``roughness_on_tile``: ground_roughness, 0.35 mm RMS, 5 cm correlation, on tile
  at 15/35/55 deg/s;
- ``anisotropic_frame_on_carpet``: mast_compliance, 400 N m/rad in roll, pitch 0.5x
  as stiff (outside the old prior, which only allowed a stiffer pitch), on carpet.

An outcome per dataset:
- null: right if ``no-discrepancy``;
- an outside effect or a cause: ``inside noise`` when the base model's error is
  already within Z_CONSISTENT (the data show nothing to explain; not counted);
- outside effect: else right if ``unexplained``;
- a cause: else right when the named
  cause (verdict explained or partly-explained) is the hidden one, wrong when it is
  another, missed when nothing is named.  A cause's dataset whose held-out command
  (the one the verdict is judged on) shows no discrepancy of its own (the base
  model within Z_CONSISTENT there) is marked ``held-out quiet``: the effect shows in
  the training commands only, and no held-out test can confirm a cause (since
  1a90586, diagnose holds out another command when the middle one is quiet and two
  show the effect, so a row is quiet only when one command alone shows it).  The report
  gives the rate of right names with and without those.

Every finished dataset is appended to ``--results`` (default ``--out``/results.jsonl)
at once, so a long run can be read while it goes on and, rerun with the same
arguments, resumes.  The datasets and a shared simulation cache live under
``--out`` (regenerated, not committed); the rows behind the committed table are
docs/diagnose-generalisation.jsonl (a few kB), so that a run on another machine
extends the table rather than starting it again; ``--rerun CASE`` runs a case again
with the code as it is (the table shows a case's newest row and says how many it
replaces).  Each row records the code it ran (``code``); a dataset is regenerated from
its seed by the code as it is, so a rough floor's dataset of a row before a86cf90 (one
floor at every correlation length, ground_roughness.surface) comes back as another
realisation of the same parameters.  A long run, not CI: CI keeps the
fixed hidden-effect subset of tests/test_diagnose.py.

    python scripts/bench/bench_diagnose_generalisation.py --datasets 40 --out /tmp/gen \
        --results docs/diagnose-generalisation.jsonl --markdown docs/diagnose-generalisation.md
    python scripts/bench/bench_diagnose_generalisation.py --out /tmp/gen --report
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from pathlib import Path

import numpy as np
from scipy import stats

import skidsteer  # noqa: F401  (registers the plugin)
from _machine import machine  # scripts/bench/, beside this file
from skidsteer.diagnosis import causes
from skidsteer.diagnosis.benchmark_rows import (FIXED, all_rows, clear_causes, drawn_from,
                                                fraction, groups, held_out_quiet, newest_rows,
                                                outcome, proposal_to_follow, right_of,
                                                row_outcome, row_verdict)
from skidsteer.diagnosis.causes import ground_roughness
from skidsteer.diagnosis.evaluate import SEARCH_STARTS, STARTS
from skidsteer.diagnosis.synth import OUTSIDE_EFFECTS, make_dataset
from skidsteer.diagnosis.verdict import Z_CONSISTENT
from skidsteer.reports.benchmarks import rates_table
from skidsteer.reports.diagnosis import diagnose
from skidsteer.reports.markdown import table
from skidsteer.robot import Setup, tire
from skidsteer.simulation.cache import code_fingerprint

FLOORS = ("concrete", "tile", "carpet")  # the plugin's floors (Sec. 3.3 and assumed)
OMEGAS_DEG_S = np.arange(10.0, 65.0, 5.0)  # Sec. 3.2's swivels span 4-64 deg/s


def plan(n_datasets: int, first_seed: int) -> list[dict]:
    """The fixed cases, then n_datasets drawn ones: the effects in turn (causes, null,
    outside), floor and commands drawn from the seed."""
    cases = [{"case": name, **spec} for name, spec in FIXED.items()]
    effects = [*sorted(causes.CAUSES), None, *sorted(OUTSIDE_EFFECTS)]
    for i in range(n_datasets):
        seed = first_seed + i
        rng = np.random.default_rng(seed)
        cases.append({"case": f"draw-{seed}", "effect": effects[i % len(effects)], "seed": seed,
                      "floor": str(rng.choice(FLOORS)),
                      "omegas": tuple(float(w) for w in np.sort(rng.choice(OMEGAS_DEG_S, 3,
                                                                           replace=False))),
                      "params": None})
    return cases


def generate(case: dict, out: Path, trials: int, duration_s: float, threads: int,
             timestep: float | None = None) -> dict:
    """Writes the case's dataset to out/datasets/CASE (simulated at `timestep`, None: the
    model's own); returns its truth."""
    return make_dataset(out / "datasets" / case["case"], case["effect"], case["params"],
                        seed=case["seed"], omegas=case["omegas"], trials=trials,
                        duration_s=duration_s, setup=Setup(build="extended", floor=case["floor"]),
                        nthread=threads, held="prior", timestep=timestep)


def case_of(row: dict) -> dict:
    """A row's case as plan() made it: the row holds its effect, seed, floor and commands
    (the effect cycle of plan() depends on --first-seed; the row does not), the fixed
    cases' parameters are FIXED's."""
    return {**{k: row[k] for k in ("case", "effect", "seed", "floor", "omegas")},
            "params": FIXED.get(row["case"], {}).get("params")}


def run_case(case: dict, out: Path, trials: int, duration_s: float, threads: int,
             search_starts: int = SEARCH_STARTS, timestep: float | None = None,
             model_spread: bool = False, rough_floor_normal: str | None = None,
             held_out: list[str] | None = None, loop: bool = False) -> dict:
    """The case's row: its dataset generated and diagnosed, both at `timestep` (None: the
    model's own step, as every committed row); model_spread: diagnose's (False in every
    committed row); rough_floor_normal: the tire plugin's floor_normal on
    ground_roughness's floor, the data's and the fits' (None: the plugin's default, as
    every committed row); held_out: the commands diagnose holds out (None: it chooses,
    as in every committed row); loop: follow the report (follow_up)."""
    data = out / "datasets" / case["case"]
    with ground_roughness.contact_normal(rough_floor_normal):
        started = time.perf_counter()
        truth = generate(case, out, trials, duration_s, threads, timestep)
        generated_s = time.perf_counter() - started
        result = diagnose(data, None, nthread=threads, progress=True, timestep=timestep,
                          cache_dir=out / "simulations", search_starts=search_starts,
                          model_spread=model_spread, held_out=held_out)
    best = result["ranking"][0] if result["ranking"] else {}
    row = {**{k: v for k, v in case.items() if k != "params"},
            "truth": truth["parameters"], "verdict": result["verdict"],
            "cause": result["cause"], "reason": result["reason"],
            "parameters": result["parameters"],
            "best": best.get("cause"), "best_held_out_error": best.get("held_out_error"),
            "baseline_error": result["baseline_error_all_runs"],
            "held_out": [result["gain"]["baseline_error"], result["gain"]["extended_error"]],
            "removed": result["gain"]["relative_reduction"],
            "held_out_groups": result["dataset"]["held_out_groups"],
            **({"held_out_given": held_out} if held_out is not None else {}),
            # what the verdict rules read (_verdict judges the row again by the rules of
            # the day)
            "noise": result["gain"]["noise_error"],
            "base_train": result["baseline_error_training"], "n_train": result["training_runs"],
            # the intervals too (from fresh draws 1201 on): recovery() counts how often they
            # hold the hidden value; and the training errors over the starts they are read
            # against (from draw 1209 on); and a random geometry's realisation (newer rows):
            # which phases or bumps the fit's values hold for
            "ranking": [{k: f[k] for k in ("cause", "held_out_error", "train_error", "score",
                                           "fitted", "parameters", "interval",
                                           "train_errors_over_starts", "unprobed",
                                           "realisation")}
                        for f in result["ranking"]],
            "outcome": outcome(case["effect"], result["verdict"], result["cause"],
                               result["baseline_error_all_runs"]),
            "generate_s": round(generated_s, 1), "diagnose_s": result["wall_time_s"],
            # the code that diagnosed it (a resumed run may mix versions: the report says)
            "code": code_fingerprint()[:12], "search_starts": result["search_starts"],
            # the step the data and the model were simulated at (None: the model's own;
            # issue 18's question, asked of 1211 at 0.05 ms)
            "timestep_s": timestep,
            # the comparison's scale held the base model's start-to-start spread (issue
            # 18's option (d), asked of the draws 1177-1215 and the nulls)
            "model_spread": model_spread,
            # the rough floor's contact normal (None: the plugin's default, vertical)
            "rough_floor_normal": rough_floor_normal,
            # the swivels proposed to tell two undecided fits apart (diagnosis.next_command),
            # or to confirm the training runs' lead when the held-out runs are quiet
            # (next_command_purpose says which); older rows have none
            "next_commands": result["next_commands"],
            "next_command_purpose": result.get("next_command_purpose")}
    if loop:
        row["loop"] = follow_up(row, case, out, trials, duration_s, threads, search_starts,
                                timestep, model_spread, rough_floor_normal)
    return row


def follow_up(row: dict, case: dict, out: Path, trials: int, duration_s: float,
              threads: int, search_starts: int, timestep: float | None, model_spread: bool,
              rough_floor_normal: str | None) -> dict | None:
    """What a user who follows the report gets: where the diagnosis proposes a command
    worth recording (benchmark_rows.proposal_to_follow), that command's trials are
    generated from the draw's truth (a trial's seed depends on the draw's seed, the
    command and the trial only, so the draw's own runs are the same) and the dataset is
    diagnosed again with it held out (diagnose --hold-out), as the report says to.  The
    second diagnosis's row (run_case's, without a loop of its own), with the command
    followed; None when there is nothing to follow."""
    proposal = proposal_to_follow(row)
    if proposal is None:
        return None
    followed = {**case, "case": f"{case['case']}-plus{proposal['omega_deg_s']:g}",
                "omegas": tuple(sorted([*case["omegas"], proposal["omega_deg_s"]]))}
    second = run_case(followed, out, trials, duration_s, threads, search_starts, timestep,
                      model_spread, rough_floor_normal, held_out=[proposal["command"]])
    return {**second, "followed": {k: proposal[k] for k in ("command", "omega_deg_s",
                                                            "separation")},
            "purpose": row["next_command_purpose"]}


def _recovery(row: dict) -> str:
    """The named cause's main parameter, fitted over hidden, where the name is right."""
    if row_outcome(row) != "right" or row["effect"] not in causes.CAUSES:
        return "-"
    main = causes.get(row["effect"]).main.name
    # the named fit's, from the ranking: a row named only under a rule added after it was
    # written keeps no "parameters" of its own
    fitted = next((f["parameters"] for f in row.get("ranking", [])
                   if f["cause"] == row["effect"] and "parameters" in f),
                  row["parameters"])[main]
    return f"{fitted:.3g} / {row['truth'][main]:.3g} ({fitted / row['truth'][main]:.2f}x)"


def _versions(rows: list[dict]) -> list[tuple[str, int]]:
    """(code fingerprint, how many datasets it diagnosed), in the rows' order."""
    return list(Counter(r.get("code", "not recorded") for r in rows).items())


def _verdict_shown(row: dict) -> str:
    """The verdict now, and the one the row was written with where they differ."""
    now = row_verdict(row)[0]
    return now if now == row["verdict"] else f"{now} (was {row['verdict']})"


def _rate(rows: list[dict]) -> str:
    return fraction(*right_of(rows))


def summary(rows: list[dict]) -> str:
    """The outcomes of rows in one sentence: counts, the clear causes' rate of right names
    (with and without the held-out-quiet ones), the nulls and the outside effects."""
    counts = {k: sum(row_outcome(r) == k for r in rows)
              for k in ("right", "wrong", "missed", "inside noise")}
    rated = groups(rows)
    return (f"{len(rows)} datasets: {counts['right']} right, {counts['wrong']} wrong, "
            f"{counts['missed']} missed, {counts['inside noise']} inside the trials' noise; "
            f"causes clear of the noise named right in {_rate(rated['effects'])}; of those "
            f"whose held-out command shows a discrepancy (base error above "
            f"{Z_CONSISTENT:g}), {_rate(rated['judged'])}; nulls no-discrepancy in "
            f"{_rate(rated['nulls'])}; outside effects clear of the noise unexplained in "
            f"{_rate(rated['outside'])}.")


def recovery(rows: list[dict]) -> list[dict]:
    """Per hidden cause and parameter: how its fit recovers the hidden value, over every
    row whose ranking holds the hidden cause's fit with that parameter fitted (named or
    not: the fit is there whatever the verdict).  A parameter held at its prior is not
    counted.  above: fits above the hidden value; p: the two-sided sign test of as many
    above as below (scipy.stats.binomtest), ties dropped; with_interval, inside: the rows
    that kept the fit's interval of that parameter read against the fit's start-to-start
    scatter (fit.interval_bound: the rows that kept the training errors over the starts,
    from draw 1209 on; the intervals of 1201-1208 read a narrower bound and are not
    counted) and how many of them hold the hidden value (edges included); bounded,
    bounded_inside: the same for the intervals bounded on both sides (an open side ends
    at the prior's bound: no value the fit probed there left the profile bound, so the
    data do not bound it, and such an interval holds the hidden value by spanning the
    prior, not by locating it)."""
    ratios: dict[tuple[str, str], list[float]] = {}
    inside: dict[tuple[str, str], list[tuple[bool, bool]]] = {}  # (holds it, bounded)
    for r in rows:
        fit = next((f for f in r.get("ranking", []) if f["cause"] == r["effect"]
                    and "parameters" in f), None)
        if fit is None or not r.get("truth"):
            continue
        for name, hidden in r["truth"].items():
            if name in fit.get("fitted", []) and hidden:
                ratios.setdefault((r["effect"], name), []).append(
                    fit["parameters"][name] / hidden)
                if name in fit.get("interval", {}) and fit.get("train_errors_over_starts"):
                    low, high = fit["interval"][name]
                    prior = causes.get(r["effect"]).priors[name]
                    bounded = not (np.isclose(low, prior.low) or np.isclose(high, prior.high))
                    inside.setdefault((r["effect"], name), []).append(
                        (low <= hidden <= high, bounded))
    out = []
    for (cause, name), values in sorted(ratios.items()):
        v = np.array(values)
        above, below = int(np.sum(v > 1)), int(np.sum(v < 1))
        holds = inside.get((cause, name), [])
        bounded = [holds_it for holds_it, both in holds if both]
        out.append({"cause": cause, "parameter": name, "fits": len(v), "above": above,
                    "median": float(np.median(v)),
                    "quartiles": tuple(float(q) for q in np.quantile(v, [0.25, 0.75])),
                    "p": float(stats.binomtest(above, above + below).pvalue)
                    if above + below else 1.0,
                    "with_interval": len(holds), "inside": int(sum(h for h, _ in holds)),
                    "bounded": len(bounded), "bounded_inside": int(sum(bounded))})
    return out


def recovery_table(rows: list[dict]) -> str:
    """recovery() as a table."""
    return table(["cause", "parameter", "fits", "above the hidden value",
                  "fitted / hidden: median", "middle half", "sign test p",
                  "hidden inside the interval", "... of those bounded both sides"],
                 [[c["cause"], c["parameter"], str(c["fits"]), str(c["above"]),
                   f"{c['median']:.2f}", f"{c['quartiles'][0]:.2f}-{c['quartiles'][1]:.2f}",
                   f"{c['p']:.3f}",
                   f"{c['inside']} of {c['with_interval']}" if c["with_interval"] else "-",
                   f"{c['bounded_inside']} of {c['bounded']}" if c["bounded"] else "-"]
                  for c in recovery(rows)]).rstrip()


def followed_table(rows: list[dict]) -> str:
    """The rows whose report proposed a command worth recording: the command, the first
    verdict and the one after it was recorded and held out."""
    out = []
    for r in rows:
        proposal = proposal_to_follow(r)
        if proposal is None:
            continue
        second = r.get("loop")
        out.append([r["case"], r["effect"] or "(none)", r.get("next_command_purpose") or "-",
                    f"{proposal['omega_deg_s']:g} deg/s ({proposal['separation']:.2f} apart)",
                    f"{row_verdict(r)[0]} ({row_outcome(r)})",
                    "not followed" if not second else
                    f"{row_verdict(second)[0]} {row_verdict(second)[1] or ''} "
                    f"({row_outcome(second)}), held-out {second['held_out'][0]:.2f} -> "
                    f"{second['held_out'][1]:.2f}"])
    return table(["case", "effect", "purpose", "proposed command", "first verdict",
                  "after recording it, held out"], out).rstrip() if out else (
        "(no row proposed a command worth recording)")


def rate_blocks(rows: list[dict], rates_from: list[int]) -> list[list[dict]]:
    """The drawn rows in blocks: from each seed of rates_from (ascending) to the next one
    less one, the last block open-ended (a block of fresh draws is one code's run)."""
    starts = sorted(rates_from)
    return [[r for r in drawn_from(rows, start) if i + 1 == len(starts)
             or r["seed"] < starts[i + 1]] for i, start in enumerate(starts)]


def report(rows: list[dict], draws_from: int | None = None,
           truths: dict[str, dict] | None = None, rates_from: list[int] | None = None) -> str:
    """The table and its summary (also of the draws from seed draws_from on, if given);
    with the ceiling's rows (`truths`, by case), the three rates of each block of draws
    rate_blocks makes of rates_from, and the commands their reports proposed."""
    later = drawn_from(rows, draws_from)
    lines = [table(["case", "effect", "floor", "deg/s", "verdict", "cause", "removed",
                    "held-out error", "fitted / hidden (main parameter)", "outcome", "s"],
                   [[r["case"], r["effect"] or "(none)", r["floor"],
                     "/".join(f"{w:g}" for w in r["omegas"]), _verdict_shown(r),
                     row_verdict(r)[1] or "-",
                     f"{r['removed']:.0%}",
                     f"{r['held_out'][0]:.2f} -> {r['held_out'][1]:.2f}", _recovery(r),
                     row_outcome(r) + (" (held-out quiet)" if held_out_quiet(r) else ""),
                     f"{r['diagnose_s']:.0f}"] for r in rows]).rstrip(), "",
             summary(rows)]
    if later:
        lines.append(f"Draws from {draws_from} on ({min(r['seed'] for r in later)}-"
                     f"{max(r['seed'] for r in later)}), {summary(later)}")
    for rated in rate_blocks(rows, rates_from or []) if truths is not None else []:
        if not rated:
            continue
        seeds = [r["seed"] for r in rated]
        lines += ["", f"Three rates of the draws {min(seeds)}-{max(seeds)} over their causes "
                  "clear of the trials' noise, with 95 % intervals (Clopper-Pearson): (a) "
                  "the diagnosis names the hidden cause; (b) the hidden truth itself would "
                  "be named by the same rules (docs/diagnose-ceiling.md; rows without a "
                  "ceiling row are not counted); (c) named after following the report: "
                  "where it proposes a command worth recording (to separate two fits or to "
                  "confirm the training runs' lead), that command's trials generated from "
                  "the draw's truth and the dataset diagnosed again with it held out "
                  "(--hold-out), the first verdict where it proposes none (rows that did "
                  "not follow a proposal are not counted). Wrong names count the first "
                  "verdict and the one after the loop, on every row of the cause ('all': "
                  "nulls and outside effects included).", "", rates_table(rated, truths),
                  "", "The commands the reports of these draws proposed:", "",
                  followed_table(rated)]
    lines += ["", "How the hidden cause's fit recovers each fitted parameter, over every row "
              "whose ranking holds it (named or not; a parameter held at its prior is not "
              "counted; p: the two-sided sign test of fits above against below the hidden "
              "value; the interval column counts the rows that kept the fit's intervals read "
              "against its start-to-start scatter, from draw 1209 on: a profile bound, Delta "
              "chi^2 = 1 with each training run one observation on the median over the fit's "
              "starts plus one standard deviation of them, so about 68 % would hold the hidden "
              "value if it were calibrated; the last column counts the intervals bounded on "
              "both sides, an open side ending at the prior's bound):",
              "", recovery_table(rows), ""]
    lines += [
             "Code (simulation cache fingerprint: skidsteer's sources, plugin, MuJoCo): "
             + "; ".join(f"{code} for {n} ({_rate(clear_causes(rows, code))} clear causes named "
                         "right)" for code, n in _versions(rows)) + ".",
             f"Machine: {machine()}."]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--datasets", type=int, default=40, help="drawn datasets (besides the "
                    "fixed cases)")
    ap.add_argument("--first-seed", type=int, default=1000, help="the first draw's seed; "
                    "the effects' cycle starts here, so to continue a results file's draws "
                    "give their run's first seed and more --datasets (the committed draws: "
                    "1000-1039 from 1000, 1040-1079 from 1040, 1080-1176 from 1080, 1177 on from "
                    "1177)")
    ap.add_argument("--trials", type=int, default=3)
    ap.add_argument("--duration", type=float, default=20.0, help="record length, s")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--search-starts", type=int, default=SEARCH_STARTS,
                    choices=range(1, STARTS + 1), help="diagnose's "
                    "search_starts (the rows record it; the table's rows use the default)")
    ap.add_argument("--timestep", type=float, help="simulate the data and the model at "
                    "this step, s (default: the model's own; rows of one results file share "
                    "one step)")
    ap.add_argument("--model-spread", action="store_true", help="diagnose with "
                    "--model-spread (rows of one results file share the setting)")
    ap.add_argument("--rough-floor-normal", choices=tire.attributes()["floor_normal"].choices,
                    help="the tire plugin's floor_normal on ground_roughness's floor, in the "
                    "data and in the fits (default: the plugin's, vertical; rows of one "
                    "results file share the setting)")
    ap.add_argument("--loop", action="store_true", help="follow each report: where it "
                    "proposes a command worth recording, generate it from the draw's truth "
                    "and diagnose again with it held out (the row's 'loop')")
    ap.add_argument("--ceiling", type=Path, help="the ceiling benchmark's rows: the report "
                    "adds the three rates of the draws from --rates-from on")
    ap.add_argument("--rates-from", type=int, nargs="+", help="the first seed of the three "
                    "rates' draws (default: --draws-from); several seeds: one block of rates "
                    "from each to the next one less one (a block per code's run of fresh "
                    "draws)")
    ap.add_argument("--only", nargs="*", help="run only these cases (names in the table)")
    ap.add_argument("--rerun", nargs="*", default=[], help="run these cases again with the "
                    "code as it is (their earlier rows stay in the results file; the table "
                    "shows the newest row of a case and counts the ones it replaces)")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--results", type=Path, help="the rows (JSON lines; default: "
                    "OUT/results.jsonl); finished cases in it are not run again")
    ap.add_argument("--report", action="store_true", help="print the table of the results "
                    "so far and stop")
    ap.add_argument("--markdown", type=Path, help="also write the table to this file (the "
                    "README's docs/diagnose-generalisation.md)")
    ap.add_argument("--draws-from", type=int, help="also summarise the draws from this seed "
                    "on (the README's 1080: the first drawn after the held-out errors became "
                    "medians over 5 starts)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    results = args.results or args.out / "results.jsonl"
    done = newest_rows(results)
    rerun = set(args.rerun)
    if not args.report:
        # a results file holds rows of one step and one scale (rows from before a field
        # was recorded read as the default: None, False)
        for field, wanted, read in (("timestep_s", args.timestep, lambda v: v),
                                    ("model_spread", args.model_spread, bool),
                                    ("rough_floor_normal", args.rough_floor_normal,
                                     lambda v: v)):
            other = {read(r.get(field)) for r in done.values()} - {wanted}
            if other:
                ap.error(f"{results} holds rows with {field} {sorted(map(str, other))}, not "
                         f"{wanted}: give another --results")
        for case in plan(args.datasets, args.first_seed):
            if (case["case"] in done and case["case"] not in rerun) or (
                    args.only and case["case"] not in args.only):
                continue
            row = run_case(case, args.out, args.trials, args.duration, args.threads,
                           args.search_starts, args.timestep, args.model_spread,
                           args.rough_floor_normal, loop=args.loop)
            done[row["case"]] = row
            with open(results, "a") as f:
                f.write(json.dumps(row) + "\n")
            print(f"{row['case']}: {row['effect']} -> {row['verdict']} {row['cause'] or ''} "
                  f"({row['outcome']}, {row['diagnose_s']:.0f} s)"
                  + (f"; recorded {row['loop']['followed']['command']} and held out: "
                     f"{row['loop']['verdict']} {row['loop']['cause'] or ''} "
                     f"({row['loop']['outcome']}, {row['loop']['diagnose_s']:.0f} s)"
                     if row.get("loop") else ""), flush=True)
    fixed = list(FIXED)
    text = report(sorted(done.values(), key=lambda r: (0, fixed.index(r["case"]))
                         if r["case"] in FIXED else (1, r["seed"])), args.draws_from,
                  newest_rows(args.ceiling) if args.ceiling else None,
                  args.rates_from if args.rates_from is not None else
                  [args.draws_from] if args.draws_from is not None else None)
    superseded = len(all_rows(results)) - len(done)
    if superseded:
        text += (f"\n{superseded} earlier row(s) of rerun cases are in the results file and "
                 "not in the table.")
    print(text)
    # on the terminal only (the committed table must not change with the code that prints
    # it): which rows a rerun would bring to this code
    current = code_fingerprint()[:12]
    first = args.draws_from or 0  # the draws the README quotes first
    stale = sorted((r for r in done.values() if r.get("code") != current),
                   key=lambda r: (r["case"] in FIXED or r["seed"] < first, r.get("seed", 0)))
    print(f"This code's fingerprint: {current}; {len(done) - len(stale)} of {len(done)} cases "
          f"ran on it. The others, to --rerun: {' '.join(r['case'] for r in stale[:12])}"
          + (" ..." if len(stale) > 12 else ""))
    if args.markdown:
        args.markdown.write_text(
            "# diagnose on fresh draws (issue 21)\n\nGenerated by `python "
            "scripts/bench/bench_diagnose_generalisation.py --out DIR --results "
            f"{results} --markdown {args.markdown}"
            + (f" --draws-from {args.draws_from}" if args.draws_from is not None else "")
            + (f" --ceiling {args.ceiling}" if args.ceiling else "")
            + (" --rates-from " + " ".join(map(str, args.rates_from))
               if args.rates_from is not None else "")
            + "` (with `--datasets N --first-seed S` for "
            "the draws S to S+N-1 and `--report` to tabulate the rows only) from every row "
            f"in {results}, {args.trials} trials of {args.duration:g} s per command; what "
            "each column means is in the script's docstring.\n\n" + text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
