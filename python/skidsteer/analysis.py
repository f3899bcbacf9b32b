"""Features of accelerometer runs: the thesis's Appendix A analysis, and Sec. 5.2's.

swivel_features() is the main program of Appendix A for one run (Sec. 3.2),
plus the Welch band measures behind Sec. 3.2's "low" (< 10 Hz) and "high"
(> 20 Hz) vibrations; free_response_features() is the Sec. 5.2 analysis of a
released tilt (Table 5.2 and the A e^{-lambda t} envelope).  analyze_file() and
analyze_paths() read run files with skidsteer.measured and write figures.

Every value returned is a plain float, str, list or dict (NaN as None), ready
for json.dumps(..., allow_nan=False).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from skidsteer import signals
from skidsteer.datafiles import write_atomically

AXES = "xyz"
FREE_RESPONSE_SAMPLES = 2**11  # Sec. 5.2: first 2^11 of 2^12 samples, tRange = 'beginning'
FREE_RESPONSE_LOWPASS_HZ = 20.0  # Sec. 5.2: fRange = [1, 20]
EDGE_S = 0.1  # swivel_features: low-pass edge transient left out of the amplitude
SUMMARY_KEYS = ("amplitude_m_s2", "steady_amplitude_m_s2", "main_peak_hz", "low_band_peak_hz", "high_band_peak_hz",
                "low_band_power", "high_band_power")


def _num(value) -> float | None:
    value = float(value)
    return value if np.isfinite(value) else None


def _plain(value):
    """A RunInfo field as a JSON value (numpy scalars and paths included)."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return _num(value)
    return str(value) if isinstance(value, Path) else value


def _per_axis(values) -> dict:
    """{"x": .., "y": .., "z": ..} of one value (or one list) per axis."""
    values = np.asarray(values, dtype=float)
    if values.ndim == 1:
        return {a: _num(v) for a, v in zip(AXES, values)}
    return {a: [_num(v) for v in column] for a, column in zip(AXES, values.T)}


def swivel_features(time_s: np.ndarray, accel: np.ndarray) -> dict:
    """Appendix A's per-run results for an (n, 3) accelerometer record, plus Welch bands.

    amplitude_m_s2: (max - min) / 2 of the 50 Hz low-passed record, over the
      WHOLE record as Appendix A line 43 does (only the FFT, computeFFT
      'middle', uses the central 2^14 samples) -- less its first and last
      EDGE_S = 0.1 s, where the zero-phase 10th-order filter's start-up
      transient rings (for ~50 ms; with a 0.8 m/s^2 60 Hz hum it added up to
      0.5 m/s^2 at the last sample, which max - min would take as amplitude).
    top_peaks_hz / top_peak_heights: findPeakFreq's three highest FFT peaks in
      1-50 Hz, >= 1 Hz apart, of the low-passed central 2^14 samples; heights are
      the one-sided amplitude spectrum 2|X|/L of computeFFT (m/s^2).
    steady_amplitude_m_s2: the same (max - min) / 2 over the central 2^14
      samples only (the edge-trimmed record when it is not longer than that): the vibration of steady motion, without the start and stop
      of the run (a simulated run starts from rest with the recording).
    main_peak_hz: the first of them (Appendix A's fMax).
    low/high_band_peak_hz, low/high_band_power (m^2/s^4), dominant_band and
      rms_m_s2 (1-50 Hz): from the Welch PSD of the raw central 2^14 samples,
      bands Sec. 3.2's LOW_BAND_HZ and HIGH_BAND_HZ.  Raw, not low-passed: the
      bands already exclude the 60 Hz hum, and the 50 Hz low-pass would take
      up to 21 % of the power near 45 Hz.
    """
    time_s = np.asarray(time_s, dtype=float)
    accel = np.asarray(accel, dtype=float)
    fs = signals.sample_rate(time_s)
    low = signals.lowpass(accel, fs)
    edge = int(round(EDGE_S * fs))
    freqs, heights = signals.top_peaks(low, fs, n=3, band=signals.BAND_HZ)
    f, psd = signals.welch_spectrum(signals.central(accel), fs)
    low_power = signals.band_power(f, psd, signals.LOW_BAND_HZ)
    high_power = signals.band_power(f, psd, signals.HIGH_BAND_HZ)
    return {
        "sample_rate_hz": fs,
        "samples": int(len(time_s)),
        "amplitude_m_s2": _per_axis(signals.amplitude(low[edge:len(low) - edge])),
        "steady_amplitude_m_s2": _per_axis(signals.amplitude(
            signals.central(low) if len(low) >= signals.FFT_SAMPLES + 2 * edge
            else low[edge:len(low) - edge])),
        "top_peaks_hz": _per_axis(freqs),
        "top_peak_heights": _per_axis(heights),
        "main_peak_hz": _per_axis(freqs[0]),
        "low_band_peak_hz": _per_axis(signals.band_peak_hz(f, psd, signals.LOW_BAND_HZ)),
        "high_band_peak_hz": _per_axis(signals.band_peak_hz(f, psd, signals.HIGH_BAND_HZ)),
        "low_band_power": _per_axis(low_power),
        "high_band_power": _per_axis(high_power),
        "dominant_band": {a: "low" if lo >= hi else "high"
                          for a, lo, hi in zip(AXES, low_power, high_power)},
        "rms_m_s2": _per_axis(np.sqrt(signals.band_power(f, psd, signals.BAND_HZ))),
    }


def free_response_window(time_s: np.ndarray, signal_1d: np.ndarray, *,
                         samples: int = FREE_RESPONSE_SAMPLES,
                         lowpass_hz: float = FREE_RESPONSE_LOWPASS_HZ):
    """(t, x, static, fs): the first `samples` of the low-passed, static-free signal.

    static is the gravity/equilibrium level removed before filtering: the median
    of the samples after the window when there are at least samples/4 of them
    (Sec. 5.2: the end of the 2^12-sample record is at equilibrium), else the
    mean of the window (which for a decaying oscillation is off by its own
    mean, about A / (2 pi f T), 1-3 % of A for the thesis's responses).  As
    Appendix A, the whole record is low-passed (10th-order Butterworth,
    zero-phase) and the first `samples` then cut out; t starts at 0.
    """
    y = np.asarray(signal_1d, dtype=float)
    fs = signals.sample_rate(np.asarray(time_s, dtype=float))
    rest = y[samples:]
    static = float(np.median(rest) if len(rest) >= samples // 4 else y[:samples].mean())
    x = signals.lowpass(y - static, fs, lowpass_hz)[:samples]
    return np.arange(len(x)) / fs, x, static, fs


def free_response_features(time_s: np.ndarray, signal_1d: np.ndarray, *,
                           samples: int = FREE_RESPONSE_SAMPLES,
                           lowpass_hz: float = FREE_RESPONSE_LOWPASS_HZ,
                           fit_window=None) -> dict:
    """Sec. 5.2 analysis of one accelerometer axis after a released tilt.

    peak_hz: the thesis's value (Table 5.2), findPeakFreq's highest FFT peak in
      [1, lowpass_hz] Hz of the first 2^11 low-passed samples, on bins of
      bin_hz = fs / samples (0.49 Hz at 1 kHz).
    refined_peak_hz: the same peak below the bin spacing (signals.refined_peak_hz).
    decay_per_s, envelope_amplitude: lambda and A of A e^{-lambda t} fitted to the
      low-passed window (signals.envelope_fit; t = 0 at the first sample).
    lowpass_hz: the low-pass used (also the band's upper edge).
    static_level: what was removed as gravity/equilibrium (free_response_window).
    """
    t, x, static, fs = free_response_window(time_s, signal_1d, samples=samples,
                                            lowpass_hz=lowpass_hz)
    band = (signals.BAND_HZ[0], lowpass_hz)
    peak, _ = signals.top_peaks(x, fs, n=1, band=band)
    amp, decay = signals.envelope_fit(x, fs, fit_window)
    return {
        "sample_rate_hz": fs,
        "samples": int(len(x)),
        "lowpass_hz": float(lowpass_hz),
        "bin_hz": fs / len(x),
        "peak_hz": _num(peak[0]),
        "refined_peak_hz": _num(signals.refined_peak_hz(x, fs, band)),
        "decay_per_s": _num(decay),
        "envelope_amplitude": _num(amp),
        "static_level": static,
    }


def _write_json(path: Path, data: dict) -> Path:
    text = json.dumps(data, indent=2, allow_nan=False) + "\n"
    return write_atomically(path, lambda tmp: tmp.write_text(text))


def analyze_file(path, out_dir=None, figures: bool = True) -> dict:
    """swivel_features() of one run file (skidsteer.measured.read_run).

    With out_dir, writes <stem>.json (the returned dict) and, if figures,
    <stem>.png (figures.plot_run), whose path is returned under "figure".
    """
    from skidsteer.measured import read_run

    rec = read_run(path)
    result = {"file": str(path), **swivel_features(rec.time_s, rec.accel)}
    if out_dir is not None:
        out_dir = Path(out_dir)
        stem = Path(path).stem
        if figures:
            from skidsteer.figures import plot_run

            result["figure"] = str(plot_run(rec.time_s, rec.accel, result,
                                            out_dir / f"{stem}.png"))
        _write_json(out_dir / f"{stem}.json", result)
    return result


def _stats(values: list[dict]) -> dict:
    """Mean and sample std (ddof = 1, MATLAB's std, as Table 5.2) per axis over trials."""
    out = {"mean": {}, "std": {}}
    for a in AXES:
        v = np.array([np.nan if d[a] is None else d[a] for d in values], dtype=float)
        v = v[np.isfinite(v)]
        out["mean"][a] = _num(v.mean()) if len(v) else None
        out["std"][a] = _num(v.std(ddof=1)) if len(v) > 1 else None
    return out


def summarize(runs: list[dict]) -> list[dict]:
    """Per (surface, config, mount, v_mps, omega_deg_s): trials, mean and std of SUMMARY_KEYS.

    v_mps is part of the key so that runs at different speeds never average.
    """
    groups: dict[tuple, list[dict]] = {}
    for run in runs:
        key = tuple(run.get(k) for k in ("surface", "config", "mount", "v_mps", "omega_deg_s"))
        groups.setdefault(key, []).append(run)
    rows = []
    for key in sorted(groups, key=lambda k: (*map(str, k[:3]), k[3] or 0.0, k[4] or 0.0)):
        members = groups[key]
        row = dict(zip(("surface", "config", "mount", "v_mps", "omega_deg_s"), key))
        row["trials"] = len(members)
        row["files"] = [m["file"] for m in members]
        row.update({k: _stats([m[k] for m in members]) for k in SUMMARY_KEYS})
        rows.append(row)
    return rows


def _figure_name(rec_path: Path, root: Path | None) -> str:
    try:
        rel = Path(rec_path).relative_to(root) if root is not None else Path(Path(rec_path).name)
    except ValueError:
        rel = Path(Path(rec_path).name)
    return "__".join(rel.with_suffix("").parts) + ".png"


def analyze_paths(paths_or_dir, out_dir, figures: bool = True) -> dict:
    """Features of every run under the given directories/files, a summary and figures.

    A directory is read with skidsteer.measured.read_dataset (its RunInfo gives
    v_mps, omega_deg_s, surface, config, mount, trial; unreadable files come back
    under "skipped"); a file with read_run (no RunInfo: it is not summarised).
    Writes out_dir/analysis.json (the returned dict) and, if figures,
    out_dir/runs/*.png per run and out_dir/peak_vs_omega.png,
    out_dir/amplitude_vs_omega.png from the summary.
    """
    from skidsteer.measured import DataError, read_dataset, read_run

    items = [paths_or_dir] if isinstance(paths_or_dir, (str, Path)) else list(paths_or_dir)
    out_dir = Path(out_dir)
    loaded, skipped = [], []  # (info or None, recording, root or None)
    for item in map(Path, items):
        if item.is_dir():
            dataset = read_dataset(item)
            loaded += [(info, rec, item) for info, rec in dataset.runs]
            skipped += list(dataset.skipped)
        else:
            try:
                loaded.append((None, read_run(item), None))
            except DataError as err:
                skipped.append({"file": str(item), "reason": str(err)})

    if figures:
        from skidsteer.figures import plot_features_vs_omega, plot_run

    runs, figure_paths = [], []
    for info, rec, root in loaded:
        run = {"file": str(info.file if info is not None else rec.path)}
        if info is not None:
            run.update({k: _plain(getattr(info, k)) for k in
                        ("v_mps", "omega_deg_s", "surface", "config", "mount", "trial")})
        run.update(swivel_features(rec.time_s, rec.accel))
        if figures:
            png = out_dir / "runs" / _figure_name(rec.path, root)
            run["figure"] = str(plot_run(rec.time_s, rec.accel, run, png))
            figure_paths.append(run["figure"])
        runs.append(run)

    summary = summarize([r for r in runs if "omega_deg_s" in r])
    if figures and summary:
        for quantity in ("peak", "amplitude"):
            png = out_dir / f"{quantity}_vs_omega.png"
            figure_paths.append(str(plot_features_vs_omega(summary, png, quantity=quantity)))
    result = {"runs": runs, "summary": summary, "skipped": skipped, "figures": figure_paths}
    _write_json(out_dir / "analysis.json", result)
    return result
