"""The features stage: signal primitives (``signals``) and every feature computed from a
record (``extract``): Appendix A's swivel features, Sec. 5.2's free-response features,
the comparison vector of compare/diagnose and its readable summary."""

from skidsteer.features import signals
from skidsteer.features.extract import (AXES, N_POWER, comparison_feature_names,
                                        comparison_features, free_response_features,
                                        free_response_window, steady_summary, steady_window,
                                        swivel_features)

__all__ = ["AXES", "N_POWER", "comparison_feature_names", "comparison_features",
           "free_response_features", "free_response_window", "signals", "steady_summary",
           "steady_window", "swivel_features"]
