"""The accelerometer's measurement chain: what lies between the cube's motion and a file.

The thesis's chain (Sec. 3.2, Appendix A): three SCA620 accelerometers in a
wood cube, an analog output around a 2.6 V zero-g level read by LabVIEW at
1 kHz, 60 Hz mains hum on the lines (Appendix A low-passes at 50 Hz to cut
it).  ``respond`` is the sensor's own bandwidth, applied to every simulated
signal the diagnosis compares with measurements; ``record`` adds what a real
recording has on top (noise, hum, zero-g offset errors, volts), to generate
"measured" data from a simulation.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import signal

from skidsteer.data.recording import m_s2_to_volts, volts_to_m_s2
from skidsteer.simulation.run import LOG_RATE_HZ, Run


@dataclasses.dataclass(frozen=True)
class SensorChain:
    # SCA620 output bandwidth: ~80 Hz (assumed from its datasheet class: a
    # capacitive MEMS sensor with an on-chip low-pass); a 2nd-order Butterworth
    bandwidth_hz: float = 80.0
    bandwidth_order: int = 2
    # assumed: output noise of the sensor and the DAQ, white over 0-500 Hz
    noise_rms_m_s2: float = 0.005
    # assumed amplitude; frequency: the North American mains of the thesis's lab
    hum_hz: float = 60.0
    hum_rms_m_s2: float = 0.01
    # zero-g output differs from the nominal 2.6 V per channel (assumed spread;
    # the reader converts with 2.6 V, so this is a constant bias per axis)
    offset_sd_volts: float = 0.01
    rate_hz: float = LOG_RATE_HZ

    def respond(self, accel: np.ndarray, fs: float) -> np.ndarray:
        """The sensor's bandwidth applied to accelerations sampled at fs (causal, axis 0),
        started in steady state on the first sample (the sensor was on before the run)."""
        sos = signal.butter(self.bandwidth_order, self.bandwidth_hz, fs=fs, output="sos")
        accel = np.asarray(accel, dtype=float)
        zi = signal.sosfilt_zi(sos)[:, :, None] * accel[0][None, None, :]
        return signal.sosfilt(sos, accel, axis=0, zi=zi)[0]

    def log(self, run: Run) -> tuple[np.ndarray, np.ndarray]:
        """(time_s, accel) of a simulated run as the sensor sees it, at rate_hz, noiseless."""
        filtered = dataclasses.replace(run, accel=self.respond(run.accel, run.sample_rate_hz))
        return filtered.accelerometer_log(self.rate_hz)

    def record(self, run: Run, rng: np.random.Generator,
               offset_volts: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(time_s, accel (n, 3)) as read back from the DAQ's volts with the nominal
        2.6 V zero-g level.  offset_volts: the sensor's zero-g errors (3,), the same
        for every run of one sensor."""
        time_s, accel = self.log(run)
        n = len(time_s)
        noisy = accel + rng.normal(0.0, self.noise_rms_m_s2, (n, 3))
        phase = rng.uniform(0, 2 * np.pi)
        noisy += self.hum_rms_m_s2 * np.sqrt(2) * np.sin(2 * np.pi * self.hum_hz * time_s
                                                         + phase)[:, None]
        volts = m_s2_to_volts(noisy)
        if offset_volts is not None:
            volts = volts + np.asarray(offset_volts)[None, :]
        return time_s, volts_to_m_s2(volts)

    def draw_offsets(self, rng: np.random.Generator) -> np.ndarray:
        return rng.normal(0.0, self.offset_sd_volts, 3)
