"""Every command judged: one verdict read over leave-one-command-out folds.

A diagnosis holds out one command (split.split) and rests its verdict on that command's
runs: a command the hidden effect leaves quiet confirms nothing, and two causes fitting
the trained commands alike are told apart on one command only.  Here a dataset of three
commands or more is diagnosed once per command with that command held out
(diagnose_observed's held_out), and each fold's results are read together: a cause's
held-out error is the RMS over the folds of its error on the fold's held-out runs (every
run predicted once, by fits that never saw its command), its training error the RMS of
the folds' training errors, its score the mean of the folds' scores (each paying for the
parameters that fold fitted), the base model's errors likewise.  verdict.verdict reads
the combined errors exactly as it reads one split's.

The folds are diagnosis summaries (summary.summary_of: diagnosis.json's data), so stored
diagnoses are combined without simulating again.
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np

from skidsteer.diagnosis.verdict import verdict


@dataclasses.dataclass(frozen=True)
class FoldFit:
    """One cause read over every fold (verdict.FitLike)."""

    cause: str
    held_out_error: float  # RMS over the folds of the fold's held-out error
    train_error: float  # RMS over the folds of the fold's training error
    score: float  # mean over the folds of the fold's score
    fitted: list[str]  # the parameters the fold fitting the most fitted
    held_out_errors: tuple[float, ...]  # per fold, in the folds' order
    parameters: tuple[dict, ...]  # per fold


@dataclasses.dataclass(frozen=True)
class EveryCommand:
    """The combined verdict (every_command_verdict's result)."""

    verdict: str
    named: FoldFit | None
    reason: str
    fits: list[FoldFit]  # best (lowest combined score) first
    held_out: list[str]  # each fold's held-out command, in the folds' order
    base_held: float  # the base model's held-out error, RMS over the folds
    base_train: float  # the base model's training error, RMS over the folds


def _rms(values: Sequence[float]) -> float:
    return float(np.sqrt(np.mean(np.square(values))))


def _held_out_command(summary: dict, where: str) -> str:
    held = summary["dataset"]["held_out_groups"]
    if len(held) != 1:
        raise ValueError(f"{where}: a fold holds out one command; it holds out "
                         f"{len(held)} ({', '.join(held) or 'none'})")
    return held[0]


def split_verdict(summary: dict) -> tuple[str, str | None]:
    """(verdict, named cause) of one fold alone, by the verdict rules as they are now
    (the single split diagnose reads), from what its summary keeps."""
    fits = sorted((FoldFit(f["cause"], f["held_out_error"], f["train_error"], f["score"],
                           list(f["fitted"]), (f["held_out_error"],), (dict(f["parameters"]),))
                   for f in summary["ranking"]), key=lambda f: f.score)
    result, named, _ = verdict(summary["baseline_error_all_runs"],
                               summary["gain"]["baseline_error"], fits,
                               summary["gain"]["noise_error"],
                               base_train=summary["baseline_error_training"],
                               n_train=int(summary["training_runs"]),
                               held_out_new_commands=True)
    return result, named.cause if named is not None else None


def every_command_verdict(folds: Sequence[dict]) -> EveryCommand:
    """The verdict over `folds`: diagnosis summaries (summary.summary_of) of one dataset,
    each holding out one command, every command held out once.  A cause is read where
    every fold fitted it (a cause one fold could not fit has no error on its command).

    Errors name the fold (its held-out command) and the field: folds of different
    datasets (their base model's error on all runs or trial noise differ), a command held
    out twice or never, fewer than three folds."""
    if len(folds) < 3:
        raise ValueError(f"{len(folds)} folds: every command judged needs a dataset of "
                         "three commands or more, one fold per command")
    held_out = [_held_out_command(f, f"fold {i}") for i, f in enumerate(folds)]
    groups = sorted(folds[0]["dataset"]["groups"])
    if sorted(held_out) != groups:
        raise ValueError(f"the folds hold out {', '.join(held_out)}; every command of the "
                         f"dataset ({', '.join(groups)}) must be held out once")
    first = folds[0]
    for name, fold in zip(held_out, folds):
        for field, value, reference in (
                ("baseline_error_all_runs", fold["baseline_error_all_runs"],
                 first["baseline_error_all_runs"]),
                ("gain.noise_error", fold["gain"]["noise_error"], first["gain"]["noise_error"])):
            if not np.isclose(value, reference, rtol=1e-9):
                raise ValueError(f"fold holding out {name}: {field} {value!r} differs from "
                                 f"{reference!r}: the folds are not of one dataset")
    by_cause = [{f["cause"]: f for f in fold["ranking"]} for fold in folds]
    common = [c for c in by_cause[0] if all(c in fits for fits in by_cause[1:])]
    fits = sorted((FoldFit(
        cause=c,
        held_out_error=_rms([fits[c]["held_out_error"] for fits in by_cause]),
        train_error=_rms([fits[c]["train_error"] for fits in by_cause]),
        score=float(np.mean([fits[c]["score"] for fits in by_cause])),
        fitted=max((list(fits[c]["fitted"]) for fits in by_cause), key=len),
        held_out_errors=tuple(float(fits[c]["held_out_error"]) for fits in by_cause),
        parameters=tuple(dict(fits[c]["parameters"]) for fits in by_cause))
        for c in common), key=lambda f: f.score)
    base_held = _rms([f["gain"]["baseline_error"] for f in folds])
    base_train = _rms([f["baseline_error_training"] for f in folds])
    # the fewest training runs: the profile bound (verdict.profile_factor) is the widest
    n_train = min(int(f["training_runs"]) for f in folds)
    result, named, reason = verdict(first["baseline_error_all_runs"], base_held, fits,
                                    first["gain"]["noise_error"], base_train=base_train,
                                    n_train=n_train, held_out_new_commands=True)
    return EveryCommand(result, named, reason + f" (every command held out once: "
                        f"{', '.join(held_out)})", fits, held_out, base_held, base_train)
