"""A diagnosis as JSON-ready data: what diagnosis.json holds (reports add the run's context)."""

from __future__ import annotations

from skidsteer.diagnosis.evaluate import STARTS
from skidsteer.diagnosis.verdict import gain


def summary_of(found) -> dict:
    """The verdict, the fitted parameters, the ranking and the gain of a diagnose.Diagnosis."""
    named, reference, groups = found.named, found.reference, found.observed.groups
    best = found.fits[0] if found.fits else None
    return {
        "verdict": found.verdict,
        "cause": named.cause if named else None,
        "reason": found.reason,
        "parameters": named.parameters if named else {},
        "intervals": ({k: list(v) for k, v in named.intervals.items()} if named else {}),
        # the intervals' sides open for want of a probe (intervals.unprobed_sides)
        "unprobed": dict(named.unprobed) if named else {},
        # the best candidate whatever the verdict: what it removes and what it leaves
        "most_likely": None if best is None else {
            "cause": best.cause, "named": named is not None,
            "removed": best.removed, "held_out_error": best.held_out_error,
            "parameters": best.parameters,
            "intervals": {k: list(v) for k, v in best.intervals.items()},
            "unprobed": dict(best.unprobed),
            "left": found.comparison.discrepancies(best.simulated.features)},
        "best_pair": found.pair,
        # what to record to tell the two undecided fits apart, or to confirm the
        # training runs' lead (next_command; next_command_purpose says which)
        "next_commands": found.next_commands,
        "next_command_purpose": found.next_command_purpose,
        "ranking": [_ranked(f) for f in found.fits],
        "gain": {
            "metric": "held-out RMS z-score of the spectral features (start-up and steady "
                      "band powers per axis, centripetal mean) against "
                      f"{found.comparison.scale_label}, "
                      f"the median over {STARTS} simulated starts; "
                      "relative_reduction is the fraction of its square in excess of the "
                      "trial noise (noise_error^2) that the extended model removes",
            "baseline_error": found.base_held,
            "extended_error": reference.held_out_error if reference else found.base_held,
            "noise_error": found.noise,
            "relative_reduction": (gain(found.base_held, reference.held_out_error,
                                        found.noise) if reference else 0.0),
            "rms_reduction": (1 - reference.held_out_error / found.base_held
                              if reference else 0.0),
            "extended_cause": reference.cause if reference else None,
        },
        "baseline_error_all_runs": found.base_error,
        "baseline_error_training": found.base_train,
        "training_runs": int(len(found.train)),
        "discrepancies": found.comparison.discrepancies(found.base.features),
        "remaining_discrepancies": (found.comparison.discrepancies(named.simulated.features)
                                    if named else None),
        "skipped_runs": found.observed.skipped,
        "not_applicable": found.not_applicable,
        "dataset": {"runs": len(found.observed.run_files),
                    "groups": [g.label for g in groups],
                    "held_out_groups": sorted({groups[i].label
                                               for i in found.observed.run_group[found.held]}),
                    "held_out_given": found.held_out_given,
                    # what split() chose the held-out groups by
                    "base_error_by_group": (None if found.group_errors is None else
                                            {g.label: float(e) for g, e in
                                             zip(groups, found.group_errors)}),
                    "duration_s": found.observed.duration_s},
    }


def _ranked(f) -> dict:
    """One fit of the ranking."""
    return {"cause": f.cause, "held_out_error": f.held_out_error,
            "train_error": f.train_error, "score": f.score, "removed": f.removed,
            "parameters": f.parameters, "fitted": f.fitted,
            "interval": {k: list(v) for k, v in f.intervals.items()},
            # what the intervals are read against (intervals.interval_bound)
            "train_errors_over_starts": f.train_errors_over_starts,
            # interval sides open for want of a probe (intervals.unprobed_sides)
            "unprobed": f.unprobed,
            "realisation": f.realisation,
            "realisation_errors": f.realisation_errors,
            # the training error along the main parameter through the fit:
            # the grid's and Brent's points, [value, error], by value
            "profile": [[float(v), float(e)] for v, e in f.evaluations]}
