"""The Sec. 3.2 feature checks of the reproduction report, on synthetic feature rows."""

from __future__ import annotations

from skidsteer.diagnosis.thesis_features import VIBRATION_FLOOR_M_S2, sec_3_2_features


def _run(omega, floor, low_hz, high_hz, dominant, rms, amp, build="extended"):
    per_axis = lambda v: {"x": v, "y": v, "z": v}  # noqa: E731
    return {"omega_deg_s": float(omega), "floor": floor, "build": build, "mount": "platform",
            "top_peaks_hz": per_axis([high_hz, low_hz, 15.0] if dominant == "high"
                                     else [low_hz, high_hz, 15.0]),
            "dominant_band": per_axis(dominant), "rms_m_s2": per_axis(rms),
            "high_band_peak_hz": per_axis(high_hz), "low_band_peak_hz": per_axis(low_hz),
            "low_band_power": per_axis(1.0 if dominant == "low" else 0.1),
            "high_band_power": per_axis(1.0 if dominant == "high" else 0.1),
            "steady_amplitude_m_s2": per_axis(amp)}


def _thesis_like(rms):
    """Concrete runs shaped as Sec. 3.2 describes, at a given vibration level."""
    runs = [_run(w, "concrete", 6.0, 20.5 + w / 3, "high", rms, 0.3) for w in range(2, 30, 4)]
    runs += [_run(w, "concrete", 6.0, 8.5, "low", rms, 3.0) for w in range(34, 65, 4)]
    return {"runs": runs}


def _verdicts(analysis):
    return {r["feature"]: r["reproduced"] for r in sec_3_2_features(analysis, ("concrete",))}


def test_features_as_the_thesis_describes_them_are_recognised():
    verdicts = _verdicts(_thesis_like(rms=0.5))
    for key in ("low_and_high_below_30_concrete", "dominance_switch_concrete",
                "high_rises_concrete", "amplitude_jump_concrete"):
        assert verdicts[key] is True, key


def test_runs_below_the_vibration_floor_show_no_spectral_feature():
    # the same spectra at residue level are not a vibration: no peak-based feature may
    # be credited to them
    verdicts = _verdicts(_thesis_like(rms=0.5 * VIBRATION_FLOOR_M_S2))
    for key in ("low_and_high_below_30_concrete", "both_low_above_30_concrete",
                "dominance_switch_concrete", "high_rises_concrete"):
        assert verdicts[key] is False, key
