"""The thesis's measured targets and whether a model meets them: the free responses
against Table 5.2 and the pulls against Sec. 3.3 (`skidsteer reproduce`'s "met" or
"missed").  The numbers and their sources live in data/thesis_measurements.toml;
these names are views of it."""

from __future__ import annotations

from skidsteer.data import thesis_measurements

MEASURED = thesis_measurements.load()
TABLE_5_2 = {axis: {k: MEASURED.free_response[axis][k] for k in ("peak_hz", "std_hz",
                                                                 "decay_per_s")}
             for axis in thesis_measurements.AXES}
FREQUENCY_TARGET = MEASURED.free_response["targets"]["frequency_relative_error"]
DECAY_TARGET_FACTOR = MEASURED.free_response["targets"]["decay_factor"]

# Sec. 3.3
PULL_FIRST_PEAK_N = {floor: tuple(v) for floor, v in
                     MEASURED.pull["lateral_first_peak_N"].items() if isinstance(v, list)}
PULL_SLOPE_OVER_K = tuple(MEASURED.pull["lateral_slope_over_stiffness"]["range"])
SPIN_STEADY_N = tuple(MEASURED.pull["spinning_steady_N"]["range"])
SPIN_THRESHOLD_MPS = MEASURED.pull["spinning_steady_N"]["above_slip_mps"]
LONGITUDINAL_SLOPE_N_PER_M = tuple(MEASURED.pull["longitudinal_slope_N_per_m"]["range"])
FIRST_PEAK_TOLERANCE = MEASURED.pull["targets"]["first_peak_relative_to_mu_s_N"]


def against_table_5_2(axis: str, response: dict) -> dict:
    """A free response (refined_peak_hz, decay_per_s) against Table 5.2's axis:
    frequency_error (relative, signed), decay_factor (>= 1) and whether each meets
    its target."""
    measured = TABLE_5_2[axis]
    frequency_error = response["refined_peak_hz"] / measured["peak_hz"] - 1
    decay_factor = _factor(response["decay_per_s"], measured["decay_per_s"])
    return {"frequency_error": frequency_error, "decay_factor": decay_factor,
            "frequency_ok": abs(frequency_error) <= FREQUENCY_TARGET,
            "decay_ok": decay_factor <= DECAY_TARGET_FACTOR}


def _factor(a: float, b: float) -> float:
    return float(max(a / b, b / a)) if a > 0 and b > 0 else float("inf")


def first_peak_met(lateral: dict) -> bool:
    """Whether a lateral pull's first peak is within FIRST_PEAK_TOLERANCE of mu_s N."""
    return abs(lateral["first_peak_over_mu_s_N"] - 1) <= FIRST_PEAK_TOLERANCE


def slope_met(lateral: dict) -> bool:
    """Whether a lateral pull's ramp slope over K_y is in Sec. 3.3's range."""
    return (lateral["slope_over_K"] is not None
            and PULL_SLOPE_OVER_K[0] <= lateral["slope_over_K"] <= PULL_SLOPE_OVER_K[1])


def spin_force_met(spinning: dict) -> bool:
    """Whether the steady lateral force with the wheels spinning is in Sec. 3.3's range."""
    return SPIN_STEADY_N[0] <= spinning["steady_force_N"] <= SPIN_STEADY_N[1]
