"""The diagnosis stage: what the simulation gets wrong on measured runs, and why.

``comparison``: measured and simulated runs reduced to one feature vector and
scored against the trials' spread; ``causes``: candidate physical extensions of
the model, one module each; ``diagnose``: the whole diagnosis (``diagnose_observed``),
which reads ``split`` (training and held-out runs), ``evaluate`` (a model's errors over
simulated starts), ``search`` (each candidate fitted), ``intervals`` (each fitted
parameter's interval) and ``verdict`` (the rules that name a cause, or none);
``summary``: a diagnosis as diagnosis.json's data; ``next_command``: the swivel to
record when the data cannot decide; ``folds``: one verdict read over
leave-one-command-out diagnoses (scripts/bench/bench_every_command.py);
``thesis_features``: the thesis's Sec. 3.2 features and targets decided on
simulated runs; ``synth``: datasets with a hidden effect, for tests.
reports.diagnosis reads a dataset through these and writes the outputs.
"""

from skidsteer.diagnosis.comparison import (CENTRIPETAL_RESOLUTION_M_S2, LOG_POWER_RESOLUTION,
                                            Comparison, Observed, Simulated, model_factory,
                                            simulate_groups)
from skidsteer.diagnosis.diagnose import Diagnosis, diagnose_observed
from skidsteer.diagnosis.search import Fit
from skidsteer.diagnosis.split import split
from skidsteer.diagnosis.verdict import (MIN_GAIN, SEPARATION, Z_CONSISTENT, Z_EXPLAINED, gain,
                                         verdict)

__all__ = ["CENTRIPETAL_RESOLUTION_M_S2", "LOG_POWER_RESOLUTION", "MIN_GAIN", "SEPARATION",
           "Z_CONSISTENT", "Z_EXPLAINED", "Comparison", "Diagnosis", "Fit", "Observed",
           "Simulated", "diagnose_observed", "gain", "model_factory", "simulate_groups",
           "split", "verdict"]
