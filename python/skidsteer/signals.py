"""Accelerometer signal analysis of the thesis's Appendix A, on scipy.signal.

Issue 2 needs only what the main job prints (amplitude and main peak per axis);
the full Appendix A analysis builds on these functions.
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
