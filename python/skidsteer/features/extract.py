"""Every feature the package computes from an accelerometer record, on signals' primitives.

One record is time (n,) in s and the accelerometer (n, 3) in m/s^2 (gravity in).
From it:

- ``swivel_features``: the main program of the thesis's Appendix A for one run
  (Sec. 3.2), plus the Welch band measures behind Sec. 3.2's "low" (< 10 Hz)
  and "high" (> 20 Hz) vibrations: what ``analyze`` and ``reproduce`` report;
- ``free_response_features``: the Sec. 5.2 analysis of a released tilt
  (Table 5.2 and the A e^{-lambda t} envelope);
- ``comparison_features``: the vector ``compare`` and ``diagnose`` score
  measurement against simulation with (``comparison_feature_names``): band
  powers of the start-up and steady windows, wheel-order line powers, the
  centripetal mean;
- ``steady_summary``: per axis the steady window's RMS and Sec. 3.2 band peaks,
  the readable side of a comparison report.

Every band power is ``signals.band_power`` (one definition); dict results are
plain floats, strs, lists and dicts (NaN as None), ready for
json.dumps(..., allow_nan=False).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from skidsteer.features import signals

AXES = "xyz"
FREE_RESPONSE_SAMPLES = 2**11  # Sec. 5.2: first 2^11 of 2^12 samples, tRange = 'beginning'
FREE_RESPONSE_LOWPASS_HZ = 20.0  # Sec. 5.2: fRange = [1, 20]
EDGE_S = 0.1  # swivel_features: low-pass edge transient left out of the amplitude


def _num(value) -> float | None:
    value = float(value)
    return value if np.isfinite(value) else None


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


# ------------------------------------------------------------------ comparison vector
#
# Per axis of the accelerometer:
# - log10 band powers of the start-up window (the first seconds after the
#   command, which ring the robot's modes the way the thesis's free responses
#   do, Sec. 5.2) and of the steady window (Sec. 3.2's swivel vibration);
# - the steady powers of the lines at the wheels' rotation rate and twice it
#   (wheel orders): an out-of-round wheel lifts and drops its corner once per
#   revolution, tilting the robot, so gravity projects onto a_x and a_y as a
#   line at exactly the wheel rate (Sec. 3.2's components rising with omega); a
#   rough floor spreads its power over a band instead;
# - the steady mean of a_x, the centripetal acceleration of a cube 0.2 m behind
#   the yaw axis, which carries the achieved yaw rate (the recordings have no gyro).

START_WINDOW_S = 3.0  # ramp (<= 0.64 s at 64 deg/s) plus ~2 decay times of the slowest mode
STEADY_FROM_S = 4.0  # the steady window runs from here to the end of the record
BAND_EDGES_HZ = (1.0, 2.0, 3.0, 4.5, 6.5, 9.0, 12.5, 17.0, 23.0, 31.0, 42.0, 55.0)
STEADY_LOW_EDGES_HZ = (0.25, 0.5)  # steady window only: wheel-rotation rates (0.05-0.5 Hz)
START_NPERSEG = 1024  # ~1 Hz bins
STEADY_NPERSEG = 4096  # 0.24 Hz bins (at most the steady window)
# Wheel orders: multiples of a wheel's rotation rate whose line power is a feature.
# 1: the run-out's fundamental; 2: its first harmonic, where a rough floor (broad
# band) still has power and a near-sinusoidal run-out has little.
WHEEL_ORDERS = (1, 2)


def _edges(window: str) -> tuple[float, ...]:
    return (STEADY_LOW_EDGES_HZ + BAND_EDGES_HZ) if window == "steady" else BAND_EDGES_HZ


def comparison_feature_names() -> list[str]:
    names = []
    for window in ("start", "steady"):
        edges = _edges(window)
        for axis in AXES:
            names += [f"{window}_a{axis}_{lo:g}-{hi:g}Hz" for lo, hi in zip(edges[:-1], edges[1:])]
    for axis in AXES:
        names += [f"steady_a{axis}_wheel_{k}x" for k in WHEEL_ORDERS]
    return names + ["centripetal_ax_m_s2"]


N_POWER = len(comparison_feature_names()) - 1  # every feature but the last is a power


def _window_band_powers(x: np.ndarray, fs: float, nperseg: int, edges) -> np.ndarray:
    freq, psd = signals.welch_spectrum(x, fs, nperseg)
    return signals.band_powers(freq, psd, edges).T.ravel()  # axis-major: x, y, z bands


def _line_powers(t: np.ndarray, x: np.ndarray, rates_hz: Sequence[float]) -> np.ndarray:
    """Per order k in WHEEL_ORDERS and axis: the summed power (amplitude^2 / 2) of the
    sinusoids at k * rates_hz, all orders fitted together by least squares (so that one
    line does not leak into another's estimate) with an offset and a linear drift over
    the window.  NaN for an order whose slowest line has less than one period in the
    window, or whose lines lie closer than the window's resolution (1 / T) to each other
    or to another order's: a fit there cannot tell a line from the drift or its
    neighbour."""
    span = float(t[-1] - t[0])
    tc = t - t.mean()
    out = np.full((len(WHEEL_ORDERS), x.shape[1]), np.nan)
    fitted: list[tuple[int, np.ndarray]] = []  # (order index, its frequencies)
    for i, k in enumerate(WHEEL_ORDERS):
        freqs = np.array([k * f for f in rates_hz])
        if len(freqs) and freqs.min() * span >= 1.0:
            fitted.append((i, freqs))
    every = np.sort(np.concatenate([f for _, f in fitted])) if fitted else np.array([])
    if len(every) > 1 and np.diff(every).min() * span < 1.0:
        return out.T.ravel()
    if fitted:
        columns = [np.ones_like(tc), tc / span]
        for _, freqs in fitted:
            for f in freqs:
                columns += [np.cos(2 * np.pi * f * tc), np.sin(2 * np.pi * f * tc)]
        coef, *_ = np.linalg.lstsq(np.column_stack(columns), x, rcond=None)
        col = 2
        for i, freqs in fitted:
            n = 2 * len(freqs)
            out[i] = (coef[col:col + n] ** 2).sum(axis=0) / 2
            col += n
    return out.T.ravel()  # axis-major, like the bands


def comparison_features(time_s: np.ndarray, accel: np.ndarray,
                        wheel_rates: Sequence[float] = ()) -> np.ndarray:
    """The comparison vector of one record starting at the command: powers in
    (m/s^2)^2, then the centripetal mean in m/s^2.  wheel_rates: the wheels' rotation
    rates in Hz; without them the wheel-order features are NaN (not scored)."""
    fs = (len(time_s) - 1) / float(time_s[-1] - time_s[0])
    t = time_s - time_s[0]
    if t[-1] < STEADY_FROM_S + STEADY_NPERSEG / fs / 2:
        raise ValueError(f"record of {t[-1]:.1f} s is too short: the diagnosis needs at least "
                         f"{STEADY_FROM_S + STEADY_NPERSEG / fs / 2:.1f} s")
    start = accel[t < START_WINDOW_S]
    steady = accel[t >= STEADY_FROM_S]
    return np.concatenate([
        _window_band_powers(start, fs, START_NPERSEG, _edges("start")),
        _window_band_powers(steady, fs, STEADY_NPERSEG, _edges("steady")),
        _line_powers(t[t >= STEADY_FROM_S], steady, wheel_rates),
        [steady[:, 0].mean()],
    ])


def steady_window(time_s: np.ndarray, accel: np.ndarray) -> np.ndarray:
    """The samples of the steady window (from STEADY_FROM_S after the record's start)."""
    t = np.asarray(time_s) - time_s[0]
    return np.asarray(accel)[t >= STEADY_FROM_S]


def steady_summary(time_s: np.ndarray, accel: np.ndarray) -> dict:
    """Per axis, over the steady window: RMS 1-50 Hz and Sec. 3.2's low/high band peaks."""
    steady = steady_window(time_s, accel)
    fs = signals.sample_rate(time_s)
    f, psd = signals.welch_spectrum(steady, fs)
    rms = np.sqrt(signals.band_power(f, psd, signals.BAND_HZ))
    low = signals.band_peak_hz(f, psd, signals.LOW_BAND_HZ)
    high = signals.band_peak_hz(f, psd, signals.HIGH_BAND_HZ)
    out = {}
    for i, a in enumerate(AXES):
        out[f"rms_a{a}_m_s2"] = float(rms[i])
        out[f"low_peak_a{a}_hz"] = float(low[i])
        out[f"high_peak_a{a}_hz"] = float(high[i])
    return out
