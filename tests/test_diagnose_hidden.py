"""diagnose names hidden effects (tests/hidden_effects.py): the second half of them,
in their own module so that the two pytest workers share the hidden-effect
diagnoses with tests/test_diagnose.py, each against its rival (hidden_effects.rivals);
among them the wheels' run-out, whose once-per-revolution line needs longer records
(RECORD_S)."""

from __future__ import annotations

import pytest

from hidden_effects import SECOND_MODULE, check_named, check_not_wrong, hidden_diagnoses


@pytest.fixture(scope="module")
def hidden(tmp_path_factory):
    return hidden_diagnoses(tmp_path_factory)


@pytest.mark.parametrize("effect", SECOND_MODULE)
def test_diagnose_names_the_hidden_cause(hidden, effect):
    check_named(*hidden(effect)[:2], effect)


@pytest.mark.parametrize("effect", SECOND_MODULE)
def test_diagnose_never_names_a_wrong_cause(hidden, effect):
    check_not_wrong(hidden(effect)[1], effect)
