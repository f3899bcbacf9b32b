"""Results that must not depend on the time step (issue 6; README, Performance).

The full study is scripts/bench/bench_timestep.py (minutes); these are its
cheap, decisive cases.
"""

from __future__ import annotations

import pytest

from skidsteer.experiments import FREE_RESPONSE_TIMESTEP_S, free_response

pytestmark = pytest.mark.slow  # each a free response at 5e-6 s or 1e-5 s: 17-52 s here
DEFAULT_DT = 1e-4  # the models' step, models/pioneer3at/parts/setup.xml
# issue 6's criteria: frequencies within 1 Hz, amplitudes within 10 %; the decay rate,
# the free responses' other Table 5.2 number, is held to the same 10 %
FREQUENCY_TOL_HZ = 1.0
REL_TOL = 0.10


REFERENCE_DT = 5e-6  # bench_timestep's half step below its 1e-5 s reference


@pytest.mark.parametrize("axis", ["roll", "pitch"])
def test_the_free_responses_step_is_converged(axis):
    # what free_response reports agrees with a 5e-6 s run (measured at 1e-5 s: decay
    # and envelope within 2 %; at the models' 1e-4 s roll decays 2.19/s, not 2.83/s)
    result = free_response(axis)
    assert result["timestep_s"] == FREE_RESPONSE_TIMESTEP_S
    reference = free_response(axis, timestep=REFERENCE_DT)
    assert abs(result["refined_peak_hz"] - reference["refined_peak_hz"]) <= FREQUENCY_TOL_HZ
    for key in ("decay_per_s", "envelope_amplitude"):
        assert result[key] == pytest.approx(reference[key], rel=REL_TOL), key


def test_the_roll_frequency_converges_at_the_models_step():
    # the mode frequency needs no finer step than the models' (its decay does)
    coarse = free_response("roll", timestep=DEFAULT_DT)
    fine = free_response("roll", timestep=FREE_RESPONSE_TIMESTEP_S)
    assert abs(coarse["refined_peak_hz"] - fine["refined_peak_hz"]) <= FREQUENCY_TOL_HZ
