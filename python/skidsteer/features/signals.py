"""Accelerometer signal analysis of the thesis's Appendix A, on scipy.signal.

Pure functions on arrays: axis 0 is time, columns the axes x, y, z (1-D arrays
are one axis).  The first block is what the main job prints (amplitude and main
peak per axis); then findPeakFreq's peaks and band-pass, the Welch bands of
Sec. 3.2, and the sub-bin peak and envelope fit for the free responses of
Sec. 5.2, decimation and the one band-power definition.  skidsteer.features.extract
assembles them into every feature the package computes.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

LOWPASS_HZ = 50.0  # Appendix A: cuts the 60 Hz mains hum
LOWPASS_ORDER = 10  # Appendix A: 10th-order Butterworth
BAND_HZ = (1.0, 50.0)  # Appendix A fRange
FFT_SAMPLES = 2**14  # Appendix A: central 2^14 of 20000 samples


def sample_rate(time_s: np.ndarray) -> float:
    return float((len(time_s) - 1) / (time_s[-1] - time_s[0]))


def lowpass(x: np.ndarray, fs: float, cutoff_hz: float = LOWPASS_HZ,
            order: int = LOWPASS_ORDER) -> np.ndarray:
    """Zero-phase Butterworth low-pass along axis 0 (filtfilt of Appendix A, as sos)."""
    sos = signal.butter(order, cutoff_hz, btype="lowpass", fs=fs, output="sos")
    return signal.sosfiltfilt(sos, x, axis=0)


def central(x: np.ndarray, n: int = FFT_SAMPLES) -> np.ndarray:
    """The central n samples (Appendix A, computeFFT 'middle'); all if shorter."""
    if len(x) <= n:
        return x
    start = len(x) // 2 - n // 2
    return x[start:start + n]


def amplitude(x_lowpassed: np.ndarray) -> np.ndarray:
    """(max - min) / 2 per axis (Appendix A, main program line 43)."""
    return (x_lowpassed.max(axis=0) - x_lowpassed.min(axis=0)) / 2


def main_peak_hz(x: np.ndarray, fs: float, band=BAND_HZ) -> np.ndarray:
    """Frequency of the highest one-sided FFT peak in band, per axis."""
    x = central(x)
    spectrum = np.abs(np.fft.rfft(x - x.mean(axis=0), axis=0))
    freq = np.fft.rfftfreq(len(x), 1 / fs)
    inside = (freq >= band[0]) & (freq <= band[1])
    return freq[inside][np.argmax(spectrum[inside], axis=0)]


# --- Sec. 3.2 bands and the rest of Appendix A ---------------------------------

LOW_BAND_HZ = (1.0, 10.0)  # Sec. 3.2 "low" (< 10 Hz); 1 Hz = Appendix A fRange(1)
HIGH_BAND_HZ = (20.0, 50.0)  # Sec. 3.2 "high" (> 20 Hz); 50 Hz = Appendix A low-pass
PEAK_SEPARATION_HZ = 1.0  # Appendix A findPeakFreq: 'minpeakdistance', ceil(1/fStep)
BANDPASS_WIDTH_HZ = 2.0  # Sec. 3.2 "a narrow band, generally 2 Hz" (see bandpass_around)
BANDPASS_ORDER = 5  # scipy band-pass of order 2*5 = MATLAB fdesign.bandpass N = 10
WELCH_RESOLUTION_HZ = 0.25  # target bin spacing of welch_spectrum (see there)
ZERO_PAD = 16  # refined_peak_hz: FFT length = 16 x the record


def _columns(x: np.ndarray) -> tuple[np.ndarray, bool]:
    """x as a float (n, k) array, and whether it was 1-D (to squeeze results back)."""
    x = np.asarray(x, dtype=float)
    return (x[:, None], True) if x.ndim == 1 else (x, False)


def _in_band(freq: np.ndarray, band) -> np.ndarray:
    return (freq >= band[0]) & (freq <= band[1])


def amplitude_spectrum(x: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """One-sided amplitude spectrum 2|X|/L of the central 2^14 samples, mean removed.

    Appendix A computeFFT ('middle'): a sinusoid of amplitude A centred on a bin
    reads A.  Shorter records are used whole (central() returns them as they are).
    """
    x = central(np.asarray(x, dtype=float))
    x = x - x.mean(axis=0)
    return np.fft.rfftfreq(len(x), 1 / fs), 2 * np.abs(np.fft.rfft(x, axis=0)) / len(x)


def top_peaks(x: np.ndarray, fs: float, n: int = 3, band=BAND_HZ,
              min_separation_hz: float = PEAK_SEPARATION_HZ):
    """The n highest peaks of amplitude_spectrum(x) in band, per axis (findPeakFreq).

    As Appendix A: the spectrum is cut to band first, then local maxima at least
    ceil(min_separation_hz / bin) bins apart are kept, highest first (scipy's
    find_peaks keeps the higher of two close peaks, like MATLAB's
    'minpeakdistance'; MATLAB's band starts one bin lower, ceil(1/fStep) being
    1-based).  Returns (freqs, heights), each (n, axes) -- or (n,) for 1-D x --
    NaN-padded when an axis has fewer than n peaks; heights in units of x.
    """
    freq, spec = amplitude_spectrum(x, fs)
    inside = _in_band(freq, band)
    f_in, spec_in = freq[inside], spec[inside]
    spec_in, one_d = _columns(spec_in)
    distance = max(1, int(np.ceil(min_separation_hz / freq[1])))
    freqs = np.full((n, spec_in.shape[1]), np.nan)
    heights = np.full_like(freqs, np.nan)
    for k, column in enumerate(spec_in.T):
        idx, _ = signal.find_peaks(column, distance=distance)
        idx = idx[np.argsort(-column[idx], kind="stable")][:n]
        freqs[:len(idx), k] = f_in[idx]
        heights[:len(idx), k] = column[idx]
    return (freqs[:, 0], heights[:, 0]) if one_d else (freqs, heights)


def bandpass_around(x: np.ndarray, fs: float, center_hz, width_hz: float = BANDPASS_WIDTH_HZ,
                    order: int = BANDPASS_ORDER) -> np.ndarray:
    """Zero-phase Butterworth band-pass of width_hz around center_hz, per axis.

    Appendix A findPeakFreq band-passes the low-passed data around the main peak
    to check it by eye.  Sec. 3.2 says the band is "generally 2 Hz"; the listed
    code has bandWd = 0.5, i.e. +-0.5 Hz (1 Hz wide): width_hz chooses.  order 5
    gives a 10th-order band-pass, MATLAB's fdesign.bandpass('N,F3dB1,F3dB2', 10)
    (its N is the band-pass order); sosfiltfilt squares the magnitude, so the
    band edges are at -6 dB and the centre passes with gain 1.  center_hz is a
    scalar or one value per axis; a NaN centre gives a NaN column.
    """
    cols, one_d = _columns(x)
    centers = np.broadcast_to(np.asarray(center_hz, dtype=float), (cols.shape[1],))
    out = np.full_like(cols, np.nan)
    for k, center in enumerate(centers):
        if np.isfinite(center):
            edges = (center - width_hz / 2, center + width_hz / 2)
            sos = signal.butter(order, edges, btype="bandpass", fs=fs, output="sos")
            out[:, k] = signal.sosfiltfilt(sos, cols[:, k])
    return out[:, 0] if one_d else out


def welch_spectrum(x: np.ndarray, fs: float, nperseg: int | None = None):
    """Welch power spectral density per axis: (freq, psd), psd in (units of x)^2/Hz.

    nperseg defaults to the power of two nearest fs / 0.25 Hz: 4096 at 1 kHz, so
    bins are 0.244 Hz apart.  That is fine enough to place the Sec. 3.2 band
    peaks (a few Hz to a few tens of Hz, compared at 10 %) and, on the central
    2^14 samples of a 20 s run, still averages 7 half-overlapping Hann segments,
    which the single 2^14 FFT (0.061 Hz, no averaging) does not.  Records shorter
    than nperseg are taken as a single segment.
    """
    x = np.asarray(x, dtype=float)
    if nperseg is None:
        nperseg = 2 ** int(np.round(np.log2(fs / WELCH_RESOLUTION_HZ)))
    return signal.welch(x, fs=fs, nperseg=min(nperseg, len(x)), axis=0)


def band_peak_hz(freq: np.ndarray, psd: np.ndarray, band) -> np.ndarray:
    """Per axis, the frequency of the PSD maximum inside band (NaN if band is empty)."""
    inside = _in_band(freq, band)
    if not inside.any():
        return np.full(psd.shape[1:], np.nan)
    return freq[inside][np.argmax(psd[inside], axis=0)]


def band_power(freq: np.ndarray, psd: np.ndarray, band) -> np.ndarray:
    """Per axis, the mean-square content of band = [low, high): the PSD of the bins with
    low <= f < high times the bin width, (m/s^2)^2 = m^2/s^4.

    The one band-power definition of the package.  Each Welch bin stands for the power
    in a bin width around it, so the sum times the width is Parseval's: adjacent bands
    [a, b) and [b, c) share no bin and add up to [a, c), and the bands of a partition
    add up to the record's variance.  NaN per axis when no bin lies in the band.
    """
    inside = (freq >= band[0]) & (freq < band[1])
    if not inside.any():
        return np.full(np.shape(psd)[1:], np.nan)
    return psd[inside].sum(axis=0) * (freq[1] - freq[0])


def band_powers(freq: np.ndarray, psd: np.ndarray, edges) -> np.ndarray:
    """band_power of each band [edges[i], edges[i+1]): (len(edges) - 1, axes)."""
    return np.array([band_power(freq, psd, band) for band in zip(edges[:-1], edges[1:])])


def decimate(x: np.ndarray, factor: int) -> np.ndarray:
    """Every factor-th sample after a zero-phase anti-aliasing FIR low-pass (axis 0).

    The filter pads the record with zeros: the line through the first and last
    samples (gravity, a centripetal mean) is taken out first and put back after,
    so that the filter sees no step at the record's edges and does not ring there.
    """
    if factor == 1:
        return x
    x = np.asarray(x, dtype=float)
    ramp = np.linspace(0.0, 1.0, len(x)).reshape((-1,) + (1,) * (x.ndim - 1))
    line = x[0] + ramp * (x[-1] - x[0])
    return signal.decimate(x - line, factor, ftype="fir", axis=0, zero_phase=True) \
        + line[::factor]


def refined_peak_hz(x: np.ndarray, fs: float, band) -> np.ndarray:
    """Frequency of the largest spectral peak in band, per axis, below the bin spacing.

    For the free responses (Sec. 5.2) the thesis's 2^11-sample FFT has
    0.49 Hz bins, 8 % of the 6 Hz roll frequency: too coarse for a 10 %
    comparison.  The record (central 2^14 samples at most, mean removed) is
    zero-padded to 16x its length, which samples the same spectrum exactly on a
    16x finer grid (0.03 Hz for 2^11 samples at 1 kHz) without assuming a peak
    shape; a parabola through the log-magnitude of the three grid points around
    the maximum then removes what is left of the grid quantisation (near a
    16x-oversampled maximum the log-magnitude is very nearly a parabola).

    For a damped sine e^{-lambda t} sin(2 pi f t) the magnitude peak sits at
    sqrt((2 pi f)^2 - lambda^2) / 2 pi, slightly below f (6.04 Hz, lambda = 2:
    by 0.008 Hz); this is the FFT-peak definition the thesis uses.
    """
    cols, one_d = _columns(central(np.asarray(x, dtype=float)))
    cols = cols - cols.mean(axis=0)
    n_fft = ZERO_PAD * len(cols)
    freq = np.fft.rfftfreq(n_fft, 1 / fs)
    log_mag = np.log(np.abs(np.fft.rfft(cols, n=n_fft, axis=0)) + np.finfo(float).tiny)
    inside = np.flatnonzero(_in_band(freq, band))
    out = np.full(cols.shape[1], np.nan)
    for k in range(cols.shape[1]):
        i = inside[np.argmax(log_mag[inside, k])]
        offset = 0.0
        if 0 < i < len(freq) - 1:
            left, mid, right = log_mag[i - 1:i + 2, k]
            curvature = left - 2 * mid + right
            if curvature < 0:
                offset = 0.5 * (left - right) / curvature
        out[k] = freq[i] + offset * freq[1]
    return out[0] if one_d else out


def envelope(x: np.ndarray, fs: float, method: str = "peaks") -> tuple[np.ndarray, np.ndarray]:
    """Samples (t, e) of the envelope of one zero-mean axis x, t = 0 at its first sample.

    method="peaks": the local maxima of |x|, at least a quarter of the dominant
    period apart (refined_peak_hz), i.e. the oscillation's extremes, which for
    A e^{-lambda t} sin(...) lie exactly on a curve proportional to e^{-lambda t}.
    method="hilbert": |hilbert(x)| at every sample, computed on x zero-padded to
    4x its length so the FFT does not wrap the end of the record onto its start.
    """
    x = np.asarray(x, dtype=float)
    t = np.arange(len(x)) / fs
    if method == "hilbert":
        return t, np.abs(signal.hilbert(x, N=4 * len(x))[:len(x)])
    if method != "peaks":
        raise ValueError(f"method must be 'peaks' or 'hilbert', not {method!r}")
    f = refined_peak_hz(x, fs, (0.5, fs / 2))
    distance = max(1, int(fs / (4 * f))) if np.isfinite(f) and f > 0 else 1
    idx, _ = signal.find_peaks(np.abs(x), distance=distance)
    return t[idx], np.abs(x[idx])


def envelope_fit(x: np.ndarray, fs: float, fit_window=None, *, method: str = "peaks",
                 trim: float = 0.1, min_fraction: float = 0.1) -> tuple[float, float]:
    """(A, lambda) of the least-squares line log e = log A - lambda t through envelope().

    Sec. 5.2 matches A e^{-lambda t} to the low-passed free response by eye; this
    fits it.  x is one zero-mean axis, t = 0 at its first sample.  By default the
    first and last `trim` (10 %) of the record are left out (the release and the
    zero-phase filter's edges; the Hilbert envelope's own edge ringing), and so
    are envelope values below min_fraction (10 %) of the largest one left: there
    the sensor noise floor flattens the log-envelope and would bias lambda low
    (with white noise of 3 % of A, low-passed at 20 Hz, a 5 % floor read the
    yaw lambda 18 % low on average, 10 % only 4 %).  fit_window=(t0, t1) seconds
    replaces both rules.

    Why "peaks" by default: the Hilbert transform of a damped oscillation that
    starts at t = 0 has a 1/t tail, (1/pi t) times the record's integral, which
    swamps the true envelope once it has decayed; on 2^11 samples of the pitch
    response (3.05 Hz, lambda = 3.5) the Hilbert fit reads lambda 9-14 % low,
    the fit through the extremes within 0.1 %.
    """
    t, env = envelope(x, fs, method)
    duration = len(x) / fs
    if fit_window is not None:
        use = (t >= fit_window[0]) & (t <= fit_window[1])
    else:
        use = (t >= trim * duration) & (t < (1 - trim) * duration)
        if use.any():
            use &= env >= min_fraction * env[use].max()
    use &= env > 0
    if use.sum() < 2:
        return float("nan"), float("nan")
    slope, intercept = np.polyfit(t[use], np.log(env[use]), 1)
    return float(np.exp(intercept)), float(-slope)


def envelope_decay_rate(x: np.ndarray, fs: float, fit_window=None, *,
                        method: str = "peaks") -> float:
    """Decay rate lambda (1/s) of A e^{-lambda t} enveloping x (Sec. 5.2); see envelope_fit."""
    return envelope_fit(x, fs, fit_window, method=method)[1]
