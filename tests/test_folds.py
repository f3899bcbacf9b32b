"""Every command judged (diagnosis.folds): leave-one-command-out folds read together."""

import numpy as np
import pytest

from skidsteer.diagnosis.verdict import penalised_score, verdict
from skidsteer.diagnosis.folds import every_command_verdict

COMMANDS = ["v0-w20 tile extended", "v0-w40 tile extended", "v0-w60 tile extended"]


def _fold(held_out, base_held, fits, base_error=3.0, noise=1.0, base_train=3.2, n_train=6):
    """A diagnosis summary (summary.summary_of's fields the folds read)."""
    return {"dataset": {"groups": COMMANDS, "held_out_groups": [held_out]},
            "baseline_error_all_runs": base_error, "baseline_error_training": base_train,
            "training_runs": n_train, "gain": {"baseline_error": base_held, "noise_error": noise},
            "ranking": [{"cause": c, "held_out_error": held, "train_error": train,
                         "score": penalised_score(held, len(fitted), n_train),
                         "fitted": fitted, "parameters": {p: 1.0 for p in fitted}}
                        for c, held, train, fitted in fits]}


def test_a_command_quiet_alone_does_not_hide_the_cause_the_others_show():
    # the first fold's held-out command is quiet (base 1.6 there): alone it confirms
    # nothing; the other two show the discrepancy and the fits predict it
    folds = [_fold(COMMANDS[0], 1.6, [("loose_payload", 1.3, 1.4, ["frequency_hz"]),
                                      ("friction_levels", 1.5, 2.9, ["mu_static"])]),
             _fold(COMMANDS[1], 4.0, [("loose_payload", 1.4, 1.3, ["frequency_hz"]),
                                      ("friction_levels", 3.8, 2.8, ["mu_static"])]),
             _fold(COMMANDS[2], 3.5, [("friction_levels", 3.0, 2.7, ["mu_static"]),
                                      ("loose_payload", 1.2, 1.5, ["frequency_hz"])])]
    alone = folds[0]
    single = verdict(alone["baseline_error_all_runs"], 1.6,
                             [type("F", (), f) for f in alone["ranking"]], 1.0,
                             base_train=3.2, n_train=6)
    assert single[0] == "unexplained" and "no discrepancy of their own" in single[2]
    found = every_command_verdict(folds)
    assert found.verdict == "explained" and found.named.cause == "loose_payload"
    best = found.fits[0]
    assert best.held_out_errors == (1.3, 1.4, 1.2)
    assert best.held_out_error == pytest.approx(np.sqrt((1.3 ** 2 + 1.4 ** 2 + 1.2 ** 2) / 3))
    assert found.base_held == pytest.approx(np.sqrt((1.6 ** 2 + 4.0 ** 2 + 3.5 ** 2) / 3))
    assert found.held_out == COMMANDS
    assert "every command held out once" in found.reason


def test_two_causes_each_best_on_some_command_are_left_undecided():
    # each cause predicts two commands well and misses the third: over every command
    # neither is told from the other, where one fold alone would name its winner
    folds = [_fold(COMMANDS[0], 4.0, [("a", 1.2, 1.3, ["x"]), ("b", 2.6, 1.3, ["y"])]),
             _fold(COMMANDS[1], 4.0, [("b", 1.2, 1.3, ["y"]), ("a", 2.6, 1.3, ["x"])]),
             _fold(COMMANDS[2], 4.0, [("a", 1.6, 1.3, ["x"]), ("b", 1.7, 1.3, ["y"])])]
    found = every_command_verdict(folds)
    assert found.verdict == "unexplained" and found.named is None
    assert "about equally well" in found.reason


def test_a_cause_not_fitted_in_every_fold_is_not_read():
    folds = [_fold(c, 4.0, [("a", 1.2, 1.3, ["x"])] + ([("b", 1.0, 1.0, ["y"])] if i else []))
             for i, c in enumerate(COMMANDS)]
    assert [f.cause for f in every_command_verdict(folds).fits] == ["a"]


def test_folds_that_do_not_cover_every_command_once_are_refused_by_name():
    fits = [("a", 1.2, 1.3, ["x"])]
    with pytest.raises(ValueError, match="2 folds"):
        every_command_verdict([_fold(c, 4.0, fits) for c in COMMANDS[:2]])
    with pytest.raises(ValueError, match="must be held out once"):
        every_command_verdict([_fold(c, 4.0, fits) for c in COMMANDS[:2] + COMMANDS[:1]])
    twice = _fold(COMMANDS[0], 4.0, fits)
    twice["dataset"]["held_out_groups"] = COMMANDS[:2]
    with pytest.raises(ValueError, match="fold 0: a fold holds out one command; it holds out 2"):
        every_command_verdict([twice] + [_fold(c, 4.0, fits) for c in COMMANDS[1:]])
    other = [_fold(c, 4.0, fits) for c in COMMANDS]
    other[2]["baseline_error_all_runs"] = 2.5
    with pytest.raises(ValueError, match=r"holding out v0-w60 tile extended: "
                                         r"baseline_error_all_runs 2.5"):
        every_command_verdict(other)
