"""The thesis's Sec. 3.2 swivel features decided on a model's simulated runs (as
reports.analysis summarises them): each decider takes the runs it is decided on and a
floor and returns (value, reproduced, evidence), or None when there are no runs to decide
it on.  Which feature uses which decider, its source and thresholds:
data/thesis_measurements.toml."""

from __future__ import annotations

import numpy as np
from scipy import stats

from skidsteer.diagnosis.thesis_targets import MEASURED


def _fmt(x) -> str:
    """A fraction for a feature's description; "n/a" for None and non-finite."""
    return "n/a" if x is None or not np.isfinite(x) else format(x, ".3g")

# Sec. 3.2 (each threshold's reason is in the measurements file)
LOW_HZ = MEASURED.threshold("low_hz")
HIGH_HZ = MEASURED.threshold("high_hz")
OMEGA_SPLIT = MEASURED.threshold("omega_split_deg_s")
LARGE_AMPLITUDE_M_S2 = MEASURED.threshold("large_amplitude_m_s2")
VIBRATION_FLOOR_M_S2 = MEASURED.threshold("vibration_floor_m_s2")
MIN_TREND_RUNS = int(MEASURED.threshold("min_trend_runs"))
LIFT_OMEGAS = tuple(MEASURED.threshold("lift_omegas_deg_s"))


def _runs(analysis: dict, build: str = "extended", floor: str | None = None,
          lo: float = -np.inf, hi: float = np.inf) -> list[dict]:
    return sorted([r for r in analysis["runs"] if r["build"] == build
                   and (floor is None or r["floor"] == floor)
                   and lo < r["omega_deg_s"] < hi], key=lambda r: r["omega_deg_s"])


def _vibrates(run: dict, axis: str = "y") -> bool:
    rms = run["rms_m_s2"][axis]
    return rms is not None and rms >= VIBRATION_FLOOR_M_S2


def _top2(run: dict) -> list[float]:
    """The two highest peaks of a_y; none when the run does not vibrate."""
    if not _vibrates(run):
        return []
    return [f for f in run["top_peaks_hz"]["y"][:2] if f is not None]


def _frac(runs: list[dict], test) -> float | None:
    return float(np.mean([bool(test(r)) for r in runs])) if runs else None


def steady_amplitude(run: dict) -> float:
    """The run's steady a_y amplitude (m/s^2)."""
    return run["steady_amplitude_m_s2"]["y"]


def _th(name: str):
    return MEASURED.threshold(name)


def _slow(analysis, floor):
    return _runs(analysis, floor=floor, hi=OMEGA_SPLIT)


def _fast(analysis, floor):
    return _runs(analysis, floor=floor, lo=OMEGA_SPLIT)


def _low_and_high_below_30(analysis, floor):
    f = _frac(_slow(analysis, floor), lambda r: len(_top2(r)) == 2 and min(_top2(r)) < LOW_HZ
              and max(_top2(r)) > HIGH_HZ)
    return f, f is not None and f >= _th("usually_fraction"), f"fraction of runs: {_fmt(f)}"


def _both_low_above_30(analysis, floor):
    f = _frac(_fast(analysis, floor), lambda r: len(_top2(r)) == 2 and max(_top2(r)) < LOW_HZ)
    return f, f is not None and f >= _th("usually_fraction"), f"fraction of runs: {_fmt(f)}"


def _low_dominant(analysis, floor):
    f = _frac(_slow(analysis, floor) + _fast(analysis, floor),
              lambda r: _vibrates(r) and r["dominant_band"]["y"] == "low")
    return (f, f is not None and f >= _th("always_fraction"),
            f"fraction of runs low-dominant: {_fmt(f)}")


def _dominance_switch(analysis, floor):
    f1 = _frac(_slow(analysis, floor),
               lambda r: _vibrates(r) and r["dominant_band"]["y"] == "high")
    f2 = _frac(_fast(analysis, floor),
               lambda r: _vibrates(r) and r["dominant_band"]["y"] == "low")
    usually = _th("usually_fraction")
    return ([f1, f2], f1 is not None and f2 is not None and f1 >= usually and f2 >= usually,
            f"high-dominant below: {_fmt(f1)}; low-dominant above: {_fmt(f2)}")


def _high_rises(analysis, floor):
    hi_peaks = [(r["omega_deg_s"], r["high_band_peak_hz"]["y"]) for r in
                _runs(analysis, floor=floor, hi=OMEGA_SPLIT + 0.1)
                if r["high_band_peak_hz"]["y"] is not None and _vibrates(r)]
    rho = (stats.spearmanr(*zip(*hi_peaks)).statistic
           if len(hi_peaks) >= MIN_TREND_RUNS else None)
    return (_num(rho), rho is not None and rho >= _th("trend_rank_correlation"),
            f"Spearman rho(high-band peak, omega <= 30) = {_fmt(rho)} over {len(hi_peaks)} "
            "vibrating runs")


def _amplitude_linear(analysis, floor):
    amps = [(r["omega_deg_s"], steady_amplitude(r)) for r in _slow(analysis, floor) + _fast(analysis, floor)]
    r_lin = stats.pearsonr(*zip(*amps)) if len(amps) >= 3 else None
    slope = np.polyfit(*zip(*amps), 1)[0] if len(amps) >= 3 else None
    return (_num(r_lin.statistic) if r_lin else None,
            r_lin is not None and r_lin.statistic >= _th("linear_correlation") and slope > 0,
            f"Pearson r = {_fmt(r_lin.statistic if r_lin else None)}, slope "
            f"{_fmt(slope)} m/s^2 per deg/s")


def _amplitude_jump(analysis, floor):
    low = np.array([steady_amplitude(r) for r in _slow(analysis, floor)])
    high = np.array([steady_amplitude(r) for r in _fast(analysis, floor)])
    ratio = float(np.median(high) / np.median(low)) if len(low) and len(high) else None
    cv = float(low.std() / low.mean()) if len(low) > 1 else None
    return (ratio, ratio is not None and ratio >= _th("jump_ratio") and cv is not None
            and cv <= _th("constant_cv"),
            f"median amplitude above/below = {_fmt(ratio)}, spread below (CV) {_fmt(cv)}")


def _large_only_with_frame(analysis, floor):
    plat, ext = _runs(analysis, "platform", floor), _runs(analysis, "extended", floor)
    if not plat:
        return None
    pmax = max(steady_amplitude(r) for r in plat)
    emax = max(steady_amplitude(r) for r in ext) if ext else None
    return ([pmax, emax], emax is not None and emax >= LARGE_AMPLITUDE_M_S2 > pmax,
            f"largest steady amplitude without frame {_fmt(pmax)}, with frame {_fmt(emax)} m/s^2")


def _no_low_without_frame(analysis, floor):
    plat = _runs(analysis, "platform", floor)
    if not plat:
        return None
    frac = [r["low_band_power"]["y"] / (r["low_band_power"]["y"] + r["high_band_power"]["y"])
            for r in plat if _vibrates(r) and r["low_band_power"]["y"] is not None
            and r["high_band_power"]["y"] is not None
            and r["low_band_power"]["y"] + r["high_band_power"]["y"] > 0]
    med = float(np.median(frac)) if frac else None
    return (med, med is not None and med < _th("low_share_vanishes"),
            f"median low-band share of 1-50 Hz power: {_fmt(med)} over {len(frac)} vibrating "
            f"runs of {len(plat)}")


def _wheel_components_linear(analysis, floor):
    runs = sorted([r for r in analysis["runs"] if r["floor"] == floor and r["mount"] == "wheel"],
                  key=lambda r: r["omega_deg_s"])
    if not runs:
        reasons = [k["reason"] for k in analysis.get("skipped", [])][:1]
        return None, None, "no readable run: " + "; ".join(reasons)
    best, best_axis = None, None
    for axis in "xyz":
        for k in range(3):
            pts = [(r["omega_deg_s"], r["top_peaks_hz"][axis][k]) for r in runs
                   if r["top_peaks_hz"][axis][k] is not None and _vibrates(r, axis)]
            # a peak at one frequency whatever the speed (or runs at one speed) has no
            # correlation to read: it is not a line moving with omega, so it is skipped
            # (pearsonr would return NaN with a ConstantInputWarning)
            if len(pts) >= max(MIN_TREND_RUNS, len(runs) // 2) and all(
                    len(set(values)) > 1 for values in zip(*pts)):
                rr = stats.pearsonr(*zip(*pts)).statistic
                if best is None or rr > best:
                    best, best_axis = rr, axis
    return (_num(best), bool(best is not None and best >= _th("linear_correlation")),
            f"best Pearson r of a top-3 peak vs omega over vibrating runs: {_fmt(best)}"
            + (f" (a_{best_axis})" if best_axis else "") + f", {len(runs)} runs")


def _wheels_lift_above(lift: dict, floor):
    """lift: omega (deg/s) -> lift fraction, of one variant's runs."""
    split, threshold = _th("lift_split_deg_s"), _th("lift_fraction")
    below = max(v for w, v in lift.items() if w <= split)
    above = max(v for w, v in lift.items() if w > split)
    return ([below, above], below < threshold <= above,
            "lift fraction " + ", ".join(f"{w:g}: {v:.3f}" for w, v in sorted(lift.items())))


DECIDERS = {
    "low_and_high_below_30": _low_and_high_below_30,
    "both_low_above_30": _both_low_above_30,
    "low_dominant": _low_dominant,
    "dominance_switch": _dominance_switch,
    "high_rises": _high_rises,
    "amplitude_linear": _amplitude_linear,
    "amplitude_jump": _amplitude_jump,
    "large_only_with_frame": _large_only_with_frame,
    "no_low_without_frame": _no_low_without_frame,
    "wheel_components_linear": _wheel_components_linear,
    "wheels_lift_above": _wheels_lift_above,
}


def _decide(features, data, floors=None) -> list[dict]:
    out = []
    for feature in features:
        for key, floor in feature.keys():
            if floors is not None and floor not in floors:
                continue
            decided = DECIDERS[feature.decider](data, floor)
            if decided is None:
                continue
            value, ok, evidence = decided
            out.append({"feature": key, "statement": feature.statement_for(floor),
                        "value": value, "reproduced": None if ok is None else bool(ok),
                        "evidence": evidence, "source": feature.source,
                        "set": "fitted" if MEASURED.fitted(key) else "predicted"})
    return out


def _swivel_features():
    return [f for f in MEASURED.features if f.mount == "platform"
            and f.decider != "wheels_lift_above"]


def sec_3_2_features(analysis: dict, floors=("concrete", "tile", "carpet")) -> list[dict]:
    """Each feature of Sec. 3.2 decided on a_y of one model's swivel runs with the
    accelerometers on the platform (roll, sway and yaw all show in a_y, eq. 3.7)."""
    return _decide(_swivel_features(), analysis, floors)


def wheel_mount_features(analysis: dict) -> list[dict]:
    """The on-wheel features of Sec. 3.2, on the runs with the accelerometers on a wheel."""
    return _decide([f for f in MEASURED.features if f.mount == "wheel"], analysis)


def lift_feature(rows: list[dict], variant: str) -> dict:
    """The lift-off onset of Sec. 3.2 on one variant's wheel-lift runs."""
    lift = {r["omega_deg_s"]: r["wheel_lift_fraction"] for r in rows if r["variant"] == variant}
    (out,) = _decide([f for f in MEASURED.features if f.decider == "wheels_lift_above"], lift)
    return out


def _num(x):
    return None if x is None or not np.isfinite(x) else float(x)
