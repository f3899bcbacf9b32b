"""Appendix A / Sec. 3.2 / Sec. 5.2 analysis on synthetic signals of known content."""

from __future__ import annotations

import json

import numpy as np
import pytest

from skidsteer.features import signals
from skidsteer.features.extract import free_response_features, swivel_features
from skidsteer.reports.analysis import analyze_file, analyze_paths

FS = 1000.0
T = np.arange(20000) / FS  # 20 s at 1 kHz, as the thesis's runs
F_LOW, F_HIGH, F_HUM = 4.3, 31.0, 60.0
A_LOW = np.array([1.0, 0.5, 0.8])  # per axis x, y, z (m/s^2)
A_HIGH = np.array([0.4, 0.6, 0.2])  # y: high band dominates, x and z: low band
A_HUM = 0.8
NOISE = 0.02  # white, rms over 0-500 Hz
GRAVITY = np.array([0.0, 0.0, 9.81])
BIN_2_14 = FS / 2**14  # 0.061 Hz, the central-2^14 FFT's bins


def swivel_signal(t=T, noise=NOISE, seed=0):
    """Per axis A_LOW sin(4.3 Hz) + A_HIGH sin(31 Hz) + 60 Hz hum + noise + gravity."""
    rng = np.random.default_rng(seed)
    phase = np.array([0.0, 1.0, 2.0])
    low = A_LOW * np.sin(2 * np.pi * F_LOW * t[:, None] + phase)
    high = A_HIGH * np.sin(2 * np.pi * F_HIGH * t[:, None] + 2 * phase)
    hum = A_HUM * np.sin(2 * np.pi * F_HUM * t[:, None] + 3 * phase)
    return low + high + hum + noise * rng.standard_normal((len(t), 3)) + GRAVITY, low, high


def damped(t, lam, f):
    return np.exp(-lam * t) * np.sin(2 * np.pi * f * t)


@pytest.fixture(scope="module")
def swivel():
    accel, low, high = swivel_signal()
    return accel, low, high, swivel_features(T, accel)


def test_top_peaks_finds_the_two_sines_not_the_hum():
    accel, _, _ = swivel_signal()
    freqs, heights = signals.top_peaks(signals.lowpass(accel, FS), FS)
    assert freqs.shape == heights.shape == (3, 3)
    for k in range(3):
        # highest first; within one 0.061 Hz bin (4.3 Hz lies 0.45 bin off the grid)
        order = [F_LOW, F_HIGH] if A_LOW[k] > A_HIGH[k] else [F_HIGH, F_LOW]
        np.testing.assert_allclose(freqs[:2, k], order, atol=BIN_2_14)
        assert np.all(np.abs(freqs[:, k] - F_HUM) > 5)  # 60 Hz hum: outside 1-50 Hz, low-passed
        # 31 Hz sits 0.1 bin off the grid: the rectangular window reads A sinc(0.1)
        # (2|X|/L of computeFFT); 2 % leaves room for the noise in a bin (2 sigma/sqrt(L) = 0.0003)
        offset = F_HIGH / BIN_2_14 - round(F_HIGH / BIN_2_14)
        i = 0 if A_HIGH[k] > A_LOW[k] else 1
        assert heights[i, k] == pytest.approx(A_HIGH[k] * np.sinc(offset), rel=0.02)


def test_top_peaks_pads_with_nan():
    accel, _, _ = swivel_signal()
    # a 1 Hz band holds one peak at the 1 Hz minimum separation
    freqs, heights = signals.top_peaks(accel[:, 0], FS, n=3, band=(30.5, 31.5))
    assert freqs[0] == pytest.approx(F_HIGH, abs=BIN_2_14)
    assert np.isnan(freqs[1:]).all() and np.isnan(heights[1:]).all()


def test_band_peaks_and_powers(swivel):
    accel, _, _, _ = swivel
    f, psd = signals.welch_spectrum(signals.central(accel), FS)
    assert f[1] == pytest.approx(0.244, abs=1e-3)  # nperseg 4096 at 1 kHz
    # an isolated sine's Hann-window lobe peaks on the bin nearest to it: within half a bin
    np.testing.assert_allclose(signals.band_peak_hz(f, psd, signals.LOW_BAND_HZ), F_LOW,
                               atol=f[1] / 2)
    np.testing.assert_allclose(signals.band_peak_hz(f, psd, signals.HIGH_BAND_HZ), F_HIGH,
                               atol=f[1] / 2)
    # The density-scaled Welch PSD integrates to the mean square, A^2/2 for a sine.  5 %
    # covers the white noise in the band (sigma^2 * 30 Hz / 500 Hz = 2.4e-5 m^2/s^4, 0.1 %
    # of the smallest A^2/2 = 0.02), the Hann main lobe spilling past a band edge (none
    # here: 4.3 and 31 Hz are >= 3 Hz inside) and the estimate's scatter over 7 segments
    # of a deterministic sine (well under 1 %).
    np.testing.assert_allclose(signals.band_power(f, psd, signals.LOW_BAND_HZ), A_LOW**2 / 2,
                               rtol=0.05)
    np.testing.assert_allclose(signals.band_power(f, psd, signals.HIGH_BAND_HZ), A_HIGH**2 / 2,
                               rtol=0.05)


def test_swivel_features(swivel):
    accel, low, high, feats = swivel
    json.dumps(feats, allow_nan=False)  # JSON-ready
    assert feats["samples"] == 20000 and feats["sample_rate_hz"] == pytest.approx(FS)
    assert set(feats) == {"sample_rate_hz", "samples", "amplitude_m_s2",
                          "steady_amplitude_m_s2", "top_peaks_hz",
                          "top_peak_heights", "main_peak_hz", "low_band_peak_hz",
                          "high_band_peak_hz", "low_band_power", "high_band_power",
                          "dominant_band", "rms_m_s2"}
    assert feats["dominant_band"] == {"x": "low", "y": "high", "z": "low"}
    for k, a in enumerate("xyz"):
        assert len(feats["top_peaks_hz"][a]) == 3
        assert feats["main_peak_hz"][a] == feats["top_peaks_hz"][a][0]
        # Amplitude (max - min)/2 of the low-passed record = that of the clean two-sine sum,
        # to within what the 10th-order 50 Hz Butterworth, run forward and back, lets by:
        # 31 Hz passes with gain 1 - 1e-4, the 60 Hz hum with 1/(1 + 1.2^20) = 2.5 %
        # (0.02 m/s^2), the noise at sigma sqrt(50/500) = 0.0063 m/s^2 rms (4 of those
        # bound what it adds to an extremum).
        clean = low[:, k] + high[:, k]
        hum_left = A_HUM / (1 + (F_HUM / signals.LOWPASS_HZ) ** 20)
        assert feats["amplitude_m_s2"][a] == pytest.approx(
            (clean.max() - clean.min()) / 2, abs=hum_left + 4 * NOISE * np.sqrt(50 / 500))
        # the steady amplitude: the same over the central 2^14 samples only
        mid = signals.central(clean)
        assert feats["steady_amplitude_m_s2"][a] == pytest.approx(
            (mid.max() - mid.min()) / 2, abs=hum_left + 4 * NOISE * np.sqrt(50 / 500))
        # rms of 1-50 Hz: sqrt of the two sines' mean squares, 5 % as the band powers
        assert feats["rms_m_s2"][a] == pytest.approx(
            np.sqrt((A_LOW[k]**2 + A_HIGH[k]**2) / 2), rel=0.05)
    # without the low-pass the hum would add its 0.8 m/s^2: the filter matters
    raw = signals.amplitude(accel - accel.mean(axis=0))
    assert np.all(raw > np.array(list(feats["amplitude_m_s2"].values())) + 0.5)


def test_bandpass_keeps_the_main_peak_and_removes_the_rest():
    accel, _, high = swivel_signal(noise=0.0)
    low_passed = signals.lowpass(accel, FS)
    freqs = signals.top_peaks(low_passed, FS)[0]  # the detected 31 Hz peak, per axis
    center = freqs[np.nanargmin(np.abs(freqs - F_HIGH), axis=0), range(3)]
    band = signals.bandpass_around(low_passed, FS, center)
    # Away from the zero-phase filter's edge transients (first/last 5 s), the band-pass
    # output is the 31 Hz component itself: its Butterworth gain at the centre is 1 and
    # +-0.03 Hz off it (the bin of the detected peak) still 1 - 1e-12.  2 % of A_HIGH bounds
    # amplitude and phase error together, and the leak of the 4.3 Hz (1 m/s^2, > 60 dB down).
    mid = slice(5000, 15000)
    err = np.abs(band[mid] - high[mid]).max(axis=0)
    assert np.all(err < 0.02 * A_HIGH)
    # nothing at 4.3 Hz left: lock-in amplitude below 0.1 % of A_LOW
    ref = np.exp(-2j * np.pi * F_LOW * T[mid])
    assert np.all(2 * np.abs(ref @ band[mid]) / len(ref) < 1e-3 * A_LOW)


def test_refined_peak_beats_the_bin():
    t = np.arange(2**11) / FS
    x = damped(t, 2.0, 6.04)  # Sec. 5.2 roll: f = 6.04 Hz, lambda = 2
    bin_peak = signals.top_peaks(x, FS, n=1, band=(1, 20))[0][0]
    # Table 5.2's values are multiples of fs/2^11 = 0.488 Hz: 5.8594 = 12 bins
    assert bin_peak == pytest.approx(12 * FS / 2**11)
    assert abs(bin_peak - 6.04) > 0.15
    # 0.05 Hz: the magnitude peak of a damped sine is at sqrt((2 pi f)^2 - lambda^2)/2 pi,
    # 6.032 Hz, and the 16x zero-padded grid plus parabola leaves < 0.01 Hz of its own
    assert signals.refined_peak_hz(x, FS, (1, 20)) == pytest.approx(6.04, abs=0.05)


@pytest.mark.parametrize("lam,f,method", [(2.0, 6.04, "peaks"), (2.0, 6.04, "hilbert"),
                                          (3.5, 3.05, "peaks"), (4.5, 7.51, "peaks")])
def test_envelope_decay_rate(lam, f, method):
    # Sec. 5.2's roll/pitch/yaw (f, lambda).  5 %: the thesis read lambda by eye in steps of
    # 0.5 (2, 3.5, 4.5: 10-25 %); noiseless, the fit itself is good to 0.1 % ("peaks").
    # The Hilbert envelope is only checked on the roll case: on the pitch case its 1/t
    # tail (see signals.envelope_fit) reads lambda 10 % low.
    t = np.arange(2**11) / FS
    assert signals.envelope_decay_rate(damped(t, lam, f), FS, method=method) == \
        pytest.approx(lam, rel=0.05)


def test_free_response_features():
    t = np.arange(2**12) / FS  # Sec. 5.2: 2^12 samples recorded, the first 2^11 analysed
    rng = np.random.default_rng(3)
    y = 9.81 + 1.5 * damped(t, 2.0, 6.04) + 0.01 * rng.standard_normal(len(t))
    feats = free_response_features(t, y)
    json.dumps(feats, allow_nan=False)
    assert feats["samples"] == 2**11 and feats["bin_hz"] == pytest.approx(FS / 2**11)
    assert feats["static_level"] == pytest.approx(9.81, abs=0.01)  # median of the quiet half
    assert feats["peak_hz"] == pytest.approx(12 * feats["bin_hz"])
    assert feats["refined_peak_hz"] == pytest.approx(6.04, abs=0.05)  # as test_refined_peak
    # 5 % as test_envelope_decay_rate; the noise (0.1 % of A after the 20 Hz low-pass)
    # moves lambda by < 1 %
    assert feats["decay_per_s"] == pytest.approx(2.0, rel=0.05)
    assert feats["envelope_amplitude"] == pytest.approx(1.5, rel=0.1)


def _is_png(path):
    import matplotlib.image

    image = matplotlib.image.imread(path)
    return path.stat().st_size > 1000 and image.ndim == 3 and min(image.shape[:2]) > 100


@pytest.mark.slow
def test_figures(tmp_path, swivel):
    from skidsteer.reports import figures

    accel, _, _, feats = swivel
    rows = [{"omega_deg_s": w, "floor": s, "build": "extended", **feats}
            for s in ("concrete", "tile") for w in (10.0, 30.0)]
    t = np.arange(2**12) / FS
    y = 9.81 + damped(t, 2.0, 6.04)
    written = [
        figures.plot_run(T, accel, feats, tmp_path / "run.png"),
        figures.plot_features_vs_omega(rows, tmp_path / "peak.png", quantity="peak"),
        figures.plot_features_vs_omega(rows, tmp_path / "amp.png", quantity="amplitude"),
        figures.plot_free_response(t, y, free_response_features(t, y), tmp_path / "free.png",
                                   "roll, a_y"),
    ]
    assert all(_is_png(p) for p in written)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["amp.png", "free.png", "peak.png",
                                                          "run.png"]  # no .part left


@pytest.mark.slow
def test_analyze_file_and_paths(tmp_path):
    from skidsteer.data import write_run

    t = np.arange(4000) / FS  # 4 s: enough for the features, quick to write and plot
    data = tmp_path / "data"
    for w, scale in ((10, 1.0), (30, 2.0)):
        for trial in (1, 2):
            accel, _, _ = swivel_signal(t, seed=trial)
            accel = (accel - GRAVITY) * scale * (1 + 0.1 * trial) + GRAVITY
            write_run(data / f"v0-w{w}-t4-concrete-{trial}.csv", t, accel)
    (data / "v0-w10-t4-concrete-3.csv").write_text("time_s,ax,ay,az\n0,1,2,3\n")  # too short

    one = analyze_file(data / "v0-w10-t4-concrete-1.csv", tmp_path / "one", figures=False)
    # a 4 s record is analysed whole: 0.25 Hz bins
    assert "figure" not in one and one["main_peak_hz"]["x"] == pytest.approx(F_LOW, abs=0.25)
    assert json.loads((tmp_path / "one" / "v0-w10-t4-concrete-1.json").read_text()) == one

    result = analyze_paths(data, tmp_path / "out")
    assert json.loads((tmp_path / "out" / "analysis.json").read_text()) == result
    assert len(result["runs"]) == 4
    assert [s["file"] for s in result["skipped"]] == ["v0-w10-t4-concrete-3.csv"]
    assert [(s["omega_deg_s"], s["trials"]) for s in result["summary"]] == [(10.0, 2), (30.0, 2)]
    row = result["summary"][0]
    amps = [r["amplitude_m_s2"]["x"] for r in result["runs"] if r["omega_deg_s"] == 10.0]
    assert row["amplitude_m_s2"]["mean"]["x"] == pytest.approx(np.mean(amps))
    assert row["amplitude_m_s2"]["std"]["x"] == pytest.approx(np.std(amps, ddof=1))
    assert row["low_band_peak_hz"]["std"]["x"] == pytest.approx(0.0)
    assert all(_is_png(tmp_path / "out" / p) for p in result["figures"])
    assert len(result["figures"]) == 4 + 2
