"""The diagnosis benchmarks' rows judged by the verdict rules as they are now: a row of
scripts/bench/bench_diagnose_generalisation.py keeps what the rules read (the base model's
errors, the trial noise, every fit's errors and score), a row of
scripts/bench/bench_diagnose_ceiling.py the hidden truth's, so a rule changed later is
judged on every stored row without simulating again.  The benchmarks' reports and the
README's table of fresh draws (scripts/update_readme_tables.py) read them through here.
"""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

from scipy import stats

from skidsteer.diagnosis import causes
from skidsteer.diagnosis.next_command import worth_recording
from skidsteer.diagnosis.synth import OUTSIDE_EFFECTS
from skidsteer.diagnosis.verdict import (MIN_GAIN, Z_CONSISTENT, gain, preferred_in_training,
                                         rivals, separated, told_from_base, verdict)

# the generalisation benchmark's fixed cases (its drawn ones follow from their seeds)
FIXED = {
    "roughness_on_tile": dict(effect="ground_roughness", seed=2101, floor="tile",
                              omegas=(15.0, 35.0, 55.0),
                              params={"height_rms_m": 3.5e-4, "correlation_length_m": 0.05}),
    "anisotropic_frame_on_carpet": dict(
        effect="mast_compliance", seed=2102, floor="carpet", omegas=(15.0, 30.0, 60.0),
        params={"stiffness_n_m_per_rad": 400.0, "pitch_stiffness_ratio": 0.5,
                "damping_ratio": 0.03}),
}
NAMING = ("explained", "partly-explained")  # verdicts that name a cause


def outcome(effect: str | None, said: str, cause: str | None, baseline_error: float) -> str:
    """right / wrong / missed / inside noise (bench_diagnose_generalisation.py's docstring
    says when); said: the verdict."""
    named = cause if said in NAMING else None
    if effect is None:
        return "right" if said == "no-discrepancy" else "wrong"
    if baseline_error <= Z_CONSISTENT:
        return "inside noise"
    if effect in OUTSIDE_EFFECTS:
        return "right" if said == "unexplained" else "wrong"
    if named is None:
        return "missed"
    return "right" if named == effect else "wrong"


def row_verdict(row: dict) -> tuple[str, str | None]:
    """(verdict, named cause) under the verdict rules as they are now: a row keeps what
    they read (the base model's errors, the trial noise, every fit's errors and score),
    so a rule changed later is judged on every row without simulating again.  Rows
    written before they kept it (no "ranking", or no "base_train") give the verdict they
    had (the committed rows have the base model's training error: rows written before it
    was kept got it afterwards from their datasets)."""
    if "ranking" not in row or "base_train" not in row:
        return row["verdict"], row["cause"]
    fits = [SimpleNamespace(**f) for f in row["ranking"]]
    result, named, _ = verdict(row["baseline_error"], row["held_out"][0], fits, row["noise"],
                               base_train=row["base_train"], n_train=row["n_train"])
    return result, named.cause if named is not None else None


def wrong_name(row: dict) -> bool:
    """Whether the row names a cause (under the rules as they are now) that is not its
    hidden one: a "wrong" outcome that names nothing (a null said unexplained) is not a
    wrong name; the nulls' rate counts it."""
    return row_outcome(row) == "wrong" and row_verdict(row)[1] is not None


def row_outcome(row: dict) -> str:
    """A row's outcome under the rules as they are now (rows keep the one they had)."""
    return outcome(row["effect"], *row_verdict(row), row["baseline_error"])


def held_out_quiet(row: dict) -> bool:
    """A cause's dataset whose held-out command shows no discrepancy of its own."""
    return (row["effect"] in causes.CAUSES and row_outcome(row) != "inside noise"
            and row["held_out"][0] <= Z_CONSISTENT)


def fraction(k: int, n: int) -> str:
    """'k of n (p%)', as every summary of both benchmarks says it."""
    return f"{k} of {n}" + (f" ({k / n:.0%})" if n else "")


def right_of(rows: list[dict]) -> tuple[int, int]:
    """(rows whose outcome is right, rows)."""
    return sum(row_outcome(r) == "right" for r in rows), len(rows)


def clear_causes(rows: list[dict], code: str | None = None) -> list[dict]:
    """The causes' datasets whose effect is clear of the trials' noise (of one code
    version, when given)."""
    return [r for r in rows if r["effect"] in causes.CAUSES and row_outcome(r) != "inside noise"
            and code in (None, r.get("code", "not recorded"))]


def groups(rows: list[dict]) -> dict[str, list[dict]]:
    """The rows a summary rates: the causes clear of the noise ("effects"), those of them
    whose held-out command shows a discrepancy ("judged"), the nulls and the outside
    effects clear of the noise."""
    effects = clear_causes(rows)
    return {"effects": effects, "judged": [r for r in effects if not held_out_quiet(r)],
            "nulls": [r for r in rows if r["effect"] is None],
            "outside": [r for r in rows if r["effect"] in OUTSIDE_EFFECTS
                        and row_outcome(r) != "inside noise"]}


def proposal_to_follow(row: dict) -> dict | None:
    """The command a user following the report records next: the diagnosis's first
    proposal (next_commands, best first) where it reaches the limit a discrepancy needs
    (next_command.worth_recording); None where nothing is proposed or no swivel would
    tell (the report then says so and proposes nothing to record)."""
    proposals = row.get("next_commands") or []
    return proposals[0] if proposals and worth_recording(proposals[0]) else None


def loop_outcome(row: dict) -> str | None:
    """The row's outcome after the report is followed: the second diagnosis's (with the
    proposed command recorded and held out, the row's "loop") where a command was worth
    recording, the first one's where none was; None where one was and the row did not
    follow it (rows written before the loop was run, or before proposals were kept)."""
    if "next_commands" not in row:
        return None
    if proposal_to_follow(row) is None:
        return row_outcome(row)
    second = row.get("loop")
    return row_outcome(second) if second else None


# the confidence of the rates' intervals (two-sided; Clopper-Pearson, exact for k of n)
RATE_CONFIDENCE = 0.95


def rate_interval(k: int, n: int) -> tuple[float, float] | None:
    """The RATE_CONFIDENCE interval of a rate of k in n (scipy's exact binomial one);
    None for no rows."""
    if n == 0:
        return None
    ci = stats.binomtest(k, n).proportion_ci(RATE_CONFIDENCE, method="exact")
    return float(ci.low), float(ci.high)


def three_rates(rows: list[dict], truths: dict[str, dict]) -> dict[str, dict]:
    """Per hidden cause (and "all") over the clear causes of `rows`: (a) "named", the
    first diagnosis names the hidden cause; (b) "ceiling", the hidden truth itself would
    be named by the same rules (judged on the ceiling row of the same case, `truths`
    by case; rows without one are not counted); (c) "loop", named after the report is
    followed (loop_outcome; rows that did not follow a proposal are not counted), each as
    (k, n); "followed", the rows that recorded a proposed command; "wrong", the names
    that are not the hidden cause, first or after the loop (every row, nulls and outside
    effects included, is in "all")."""
    out: dict[str, dict] = {}
    clear = clear_causes(rows)
    for cause in [*sorted({r["effect"] for r in clear}), "all"]:
        mine = [r for r in clear if cause in ("all", r["effect"])]
        ceiling = [judged(truths[r["case"]], r)["named"] for r in mine if r["case"] in truths]
        after = [loop_outcome(r) for r in mine]
        after = [o for o in after if o is not None]
        every = rows if cause == "all" else mine
        out[cause] = {
            "named": right_of(mine), "ceiling": (sum(ceiling), len(ceiling)),
            "loop": (sum(o == "right" for o in after), len(after)),
            "followed": sum(bool(r.get("loop")) for r in mine),
            "wrong": sum(wrong_name(r) or bool(r.get("loop") and wrong_name(r["loop"]))
                         for r in every)}
    return out


def drawn_from(rows: list[dict], draws_from: int | None) -> list[dict]:
    """The drawn rows (not the fixed cases) from seed draws_from on (none without one)."""
    return [r for r in rows if draws_from is not None and r["case"] not in FIXED
            and r["seed"] >= draws_from]


def all_rows(results: Path) -> list[dict]:
    """Every row of the results file, in the order they were run."""
    return ([json.loads(line) for line in results.read_text().splitlines()]
            if results.exists() else [])


def newest_rows(results: Path) -> dict[str, dict]:
    """A case's newest row, by case, in the order of each case's first row (a rerun
    appends; the tables show the newest)."""
    return {r["case"]: r for r in all_rows(results)}


def why_not(fits: list, row: dict, removed: float) -> str:
    """The rule that stops the truth, checked in verdict's order with its own rules."""
    best = fits[0]
    if row["base_held"] <= Z_CONSISTENT:
        return "held-out quiet"
    if best.cause != row["effect"]:
        return f"{best.cause} scores better"
    if removed < MIN_GAIN:
        return "gain"
    if best.score >= row["base_held"] ** 2:
        return "score"
    if not told_from_base(row["base_train"], best, row["n_train"]):
        return "training"
    contending = rivals(fits[1:], row["base_train"], row["n_train"])
    if contending and not separated(row["base_held"], best, contending):
        return "not separated"
    rival = preferred_in_training(best, fits[1:], row["n_train"])
    if rival is not None:
        return f"training prefers {rival.cause}"
    return "other"


def paid_parameters(effect: str, own: dict | None) -> list[str]:
    """The parameters the truth pays for: those the hidden cause's own fit fitted (its
    ranking entry `own`), or every parameter of the cause when the row has none."""
    if own is not None:
        return list(own["fitted"])
    cause = causes.get(effect)
    return [p.name for p in (cause.main, *cause.held)]


def judged(row: dict, diagnosed: dict) -> dict:
    """The verdict the truth gets by the verdict rules as they are now, from what the row
    keeps (the base model's errors, the truth's, the trial noise) and the other causes'
    fits of the generalisation row `diagnosed`: a rule changed later is judged on every
    row without simulating again."""
    own = next((f for f in diagnosed.get("ranking", []) if f["cause"] == row["effect"]), None)
    # the training rules compare training errors, and a fit's is the lowest of its search
    # while the truth's is one simulation: the truth gets the lower of its own and its
    # cause's fit's (a fit that found the truth's basin would reach at least as low), so
    # the ceiling stays an upper bound
    train = min(row["truth_train"], own["train_error"]) if own else row["truth_train"]
    truth = SimpleNamespace(cause=row["effect"], held_out_error=row["truth_held"],
                            train_error=train, score=row["truth_score"],
                            fitted=paid_parameters(row["effect"], own))
    others = [SimpleNamespace(**f) for f in diagnosed.get("ranking", [])
              if f["cause"] != row["effect"]]
    fits = sorted([truth, *others], key=lambda f: f.score)
    result, named, reason = verdict(row["base_error"], row["base_held"], fits, row["noise"],
                                    base_train=row["base_train"], n_train=row["n_train"])
    is_named = named is not None and named.cause == row["effect"]
    removed = gain(row["base_held"], row["truth_held"], row["noise"])
    return {"verdict": result, "named": is_named, "removed": removed, "reason": reason,
            "stopped_by": None if is_named else why_not(fits, row, removed),
            "diagnose": row_outcome(diagnosed)}


def counts(rows: list[dict], verdicts: list[dict]) -> dict[str, tuple[int, int]]:
    """(k, n) of a summary: the truth named ("named"), the same where the held-out command
    shows a discrepancy ("judged"), and diagnose right where the truth is named
    ("diagnose")."""
    named = [v for v in verdicts if v["named"]]
    judged = [v for r, v in zip(rows, verdicts) if r["base_held"] > Z_CONSISTENT]
    return {"named": (len(named), len(rows)),
            "judged": (sum(v["named"] for v in judged), len(judged)),
            "diagnose": (sum(v["diagnose"] == "right" for v in named), len(named))}


def drawn_from_indices(rows: list[dict], diagnosed: dict[str, dict],
                       draws_from: int | None) -> list[int]:
    """The indices of the rows of drawn cases from seed draws_from on (none without one)."""
    return [i for i, r in enumerate(rows) if draws_from is not None
            and r["case"] not in FIXED and diagnosed[r["case"]]["seed"] >= draws_from]
