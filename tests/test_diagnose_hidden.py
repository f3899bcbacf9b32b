"""diagnose names hidden effects (tests/hidden_effects.py): the second half of them,
in their own module so that the two pytest workers share the hidden-effect
diagnoses with tests/test_diagnose.py; among them the wheels' run-out, whose
once-per-revolution line needs 20 s records.

The run-out's diagnosis alone took 634 s of a worker (of a 19.7 min suite, here,
alone): a third of what CI's 30-min budget allows on a machine twice as slow.  It
runs with SKIDSTEER_SLOW_TESTS=1 (10-11 min on 2 cores):

    SKIDSTEER_SLOW_TESTS=1 .venv/bin/python -m pytest tests/test_diagnose_hidden.py

and the generalisation benchmark (scripts/bench/bench_diagnose_generalisation.py)
draws run-outs with fresh seeds; CI skips it and says so (pytest -ra)."""

from __future__ import annotations

import os

import pytest

from hidden_effects import SECOND_MODULE, check_named, check_not_wrong, hidden_diagnoses

ONLY_WHEN_ASKED = pytest.mark.skipif(
    os.environ.get("SKIDSTEER_SLOW_TESTS") != "1",
    reason="the hidden run-out's diagnosis (20 s records, ~10 min) runs with "
           "SKIDSTEER_SLOW_TESTS=1 (CI's 30-min budget)")
EFFECTS = [pytest.param(e, marks=ONLY_WHEN_ASKED) if e == "wheel_eccentricity" else e
           for e in SECOND_MODULE]


@pytest.fixture(scope="module")
def hidden(tmp_path_factory):
    return hidden_diagnoses(tmp_path_factory)


@pytest.mark.parametrize("effect", EFFECTS)
def test_diagnose_names_the_hidden_cause(hidden, effect):
    check_named(*hidden(effect)[:2], effect)


@pytest.mark.parametrize("effect", EFFECTS)
def test_diagnose_never_names_a_wrong_cause(hidden, effect):
    check_not_wrong(hidden(effect)[1], effect)
