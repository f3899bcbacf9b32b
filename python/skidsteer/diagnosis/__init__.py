"""The diagnosis stage: what the simulation gets wrong on measured runs, and why.

``comparison``: measured and simulated runs reduced to one feature vector and
scored against the trials' spread; ``causes``: candidate physical extensions of
the model, one module each; ``fit``: each candidate fitted, ranked and judged
(``diagnose_observed``); ``next_command``: the swivel to record when two fits are
undecided; ``synth``: datasets with a hidden effect, for tests.
reports.diagnosis reads a dataset through these and writes the outputs.
"""

from skidsteer.diagnosis.comparison import (CENTRIPETAL_RESOLUTION_M_S2, LOG_POWER_RESOLUTION,
                                            Comparison, Observed, Simulated, model_factory,
                                            simulate_groups)
from skidsteer.diagnosis.fit import (MIN_GAIN, SEPARATION, Z_CONSISTENT, Z_EXPLAINED,
                                     Diagnosis, Fit, diagnose_observed, gain, split, verdict)

__all__ = ["CENTRIPETAL_RESOLUTION_M_S2", "LOG_POWER_RESOLUTION", "MIN_GAIN", "SEPARATION",
           "Z_CONSISTENT", "Z_EXPLAINED", "Comparison", "Diagnosis", "Fit", "Observed",
           "Simulated", "diagnose_observed", "gain", "model_factory", "simulate_groups",
           "split", "verdict"]
