"""PNG figures: the thesis's Appendix B/C and Sec. 5.2 figures, and the reports'.

matplotlib is imported when the first figure is drawn (``pyplot()``), with the
headless Agg backend.  Every figure is written atomically
(data.files.write_atomically) and closed after.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from skidsteer.data.files import write_atomically
from skidsteer.features import signals
from skidsteer.features.extract import free_response_window

DPI = 110
AXES = "xyz"
PEAK_KEYS = ("main_peak_hz", "low_band_peak_hz", "high_band_peak_hz")


@functools.lru_cache(maxsize=None)
def pyplot():
    """matplotlib.pyplot on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig, path) -> Path:
    plt = pyplot()
    try:
        return write_atomically(Path(path), lambda tmp: fig.savefig(tmp, format="png", dpi=DPI))
    finally:
        plt.close(fig)


def _nan(value) -> float:
    return np.nan if value is None else float(value)


def plot_run(time_s: np.ndarray, accel: np.ndarray, features: dict, path) -> Path:
    """Per axis: the central 2^14 samples raw, 50 Hz low-passed and 2 Hz band-passed
    around the main peak (Appendix A lines 54-67: the band-pass drawn on the mean),
    and the low-passed FFT with its top peaks and the Sec. 3.2 bands (Appendix B)."""
    time_s = np.asarray(time_s, dtype=float)
    accel = np.asarray(accel, dtype=float)
    fs = signals.sample_rate(time_s)
    low = signals.lowpass(accel, fs)
    centers = [_nan(features["main_peak_hz"][a]) for a in AXES]
    band = signals.bandpass_around(low, fs, centers)
    t, raw_c, low_c, band_c = (signals.central(v) for v in (time_s, accel, low, band))
    freq, spec = signals.amplitude_spectrum(low, fs)

    plt = pyplot()
    fig, axs = plt.subplots(3, 2, figsize=(13, 9), gridspec_kw={"width_ratios": (3, 2)})
    for k, a in enumerate(AXES):
        ax = axs[k, 0]
        ax.plot(t, raw_c[:, k], color="0.7", lw=0.5, label="raw")
        ax.plot(t, low_c[:, k], color="g", lw=0.8, label="low-pass 50 Hz")
        ax.plot(t, band_c[:, k] + low_c[:, k].mean(), color="r", lw=1.0,
                label=f"band-pass {signals.BANDPASS_WIDTH_HZ:g} Hz at {centers[k]:.2f} Hz")
        ax.set_ylabel(f"a_{a} (m/s^2)")
        ax.set_title(f"a_{a}: amplitude {_nan(features['amplitude_m_s2'][a]):.3f} m/s^2",
                     fontsize=9)
        ax.legend(fontsize=7, loc="upper right")
        ax.grid(True, lw=0.3)

        ax = axs[k, 1]
        shown = freq <= 60.0
        ax.plot(freq[shown], spec[shown, k], lw=0.7)
        for lo, hi in (signals.LOW_BAND_HZ, signals.HIGH_BAND_HZ):
            ax.axvspan(lo, hi, color="0.9", zorder=0)
        peaks = np.array([_nan(v) for v in features["top_peaks_hz"][a]])
        heights = np.array([_nan(v) for v in features["top_peak_heights"][a]])
        ax.plot(peaks, heights, "rv", ms=6)
        for rank, (f, h) in enumerate(zip(peaks, heights), 1):
            if np.isfinite(f):
                ax.annotate(f"{rank}: {f:.2f} Hz", (f, h), fontsize=7,
                            xytext=(3, 3), textcoords="offset points")
        ax.set_ylabel("|FFT| (m/s^2)")
        ax.grid(True, lw=0.3)
    axs[-1, 0].set_xlabel("time (s)")
    axs[-1, 1].set_xlabel("frequency (Hz)")
    fig.tight_layout()
    return save(fig, path)


def _mean_std(row: dict, key: str, axis: str) -> tuple[float, float]:
    """A summary row's {"mean", "std"} per axis, or a run row's plain per-axis value."""
    value = row.get(key)
    if value is None:
        return np.nan, np.nan
    if "mean" in value:
        return _nan(value["mean"][axis]), _nan(value["std"][axis])
    return _nan(value[axis]), np.nan


def plot_features_vs_omega(summary_rows: list[dict], path, quantity: str = "peak") -> Path:
    """quantity "peak": main, low- and high-band peak frequencies vs omega (Figs. 6.13-6.15);
    "amplitude": amplitude vs omega (Fig. 6.16).  One line per floor/build (and mount,
    when rows differ in it), error bars = std over trials when the rows have it."""
    if quantity == "peak":
        keys = [k for k in PEAK_KEYS if any(k in r for r in summary_rows)]
    elif quantity == "amplitude":
        keys = [k for k in ("amplitude_m_s2", "steady_amplitude_m_s2")
                if any(k in r for r in summary_rows)]
    else:
        raise ValueError(f"quantity must be 'peak' or 'amplitude', not {quantity!r}")
    with_mount = len({r.get("mount") for r in summary_rows}) > 1
    lines: dict[str, list[dict]] = {}
    for r in summary_rows:
        label = f"{r.get('floor')}, {r.get('build')}"
        label += f", {r.get('mount')}" if with_mount else ""
        lines.setdefault(label, []).append(r)

    plt = pyplot()
    fig, axs = plt.subplots(3, len(keys), figsize=(4.5 * len(keys) + 1, 8), squeeze=False)
    for j, key in enumerate(keys):
        for k, a in enumerate(AXES):
            ax = axs[k, j]
            for label, rows in lines.items():
                rows = sorted(rows, key=lambda r: r["omega_deg_s"])
                omega = [r["omega_deg_s"] for r in rows]
                mean, std = np.array([_mean_std(r, key, a) for r in rows]).T
                ax.errorbar(omega, mean, yerr=np.nan_to_num(std), marker="o", ms=4,
                            capsize=2, label=label)
            ax.set_title(f"a_{a}: {key}", fontsize=9)
            ax.set_ylabel("Hz" if key.endswith("_hz") else "m/s^2")
            ax.grid(True, lw=0.3)
        axs[-1, j].set_xlabel("omega_z (deg/s)")
    axs[0, 0].legend(fontsize=7)
    fig.tight_layout()
    return save(fig, path)


def plot_free_response(time_s: np.ndarray, signal: np.ndarray, features: dict, path,
                       label: str) -> Path:
    """Sec. 5.2 (Figs. 5.4-5.6): the low-passed window with +-A e^{-lambda t}, and its FFT
    with the bin peak (Table 5.2) and the refined peak marked."""
    plt = pyplot()
    t, x, _, fs = free_response_window(time_s, signal, samples=features["samples"],
                                       lowpass_hz=features["lowpass_hz"])
    amp, decay = _nan(features["envelope_amplitude"]), _nan(features["decay_per_s"])
    freq, spec = signals.amplitude_spectrum(x, fs)

    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 4))
    ax0.plot(t, x, lw=0.8, label=f"low-pass {features['lowpass_hz']:g} Hz")
    env = amp * np.exp(-decay * t)
    ax0.plot(t, env, "r--", lw=1, label=f"A e^(-{decay:.2f} t)")
    ax0.plot(t, -env, "r--", lw=1)
    ax0.set_xlabel("time (s)")
    ax0.set_ylabel("acceleration (m/s^2)")
    ax0.set_title(label, fontsize=9)
    ax0.legend(fontsize=7)
    ax0.grid(True, lw=0.3)

    shown = freq <= 2 * features["lowpass_hz"]
    ax1.plot(freq[shown], spec[shown], ".-", lw=0.7, ms=3)
    ax1.axvline(_nan(features["peak_hz"]), color="k", ls=":",
                label=f"bin peak {_nan(features['peak_hz']):.3f} Hz")
    ax1.axvline(_nan(features["refined_peak_hz"]), color="r", ls="--",
                label=f"refined {_nan(features['refined_peak_hz']):.3f} Hz")
    ax1.set_xlabel("frequency (Hz)")
    ax1.set_ylabel("|FFT| (m/s^2)")
    ax1.legend(fontsize=7)
    ax1.grid(True, lw=0.3)
    fig.tight_layout()
    return save(fig, path)
