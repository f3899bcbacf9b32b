"""Per command, the measured steady features against each model's: the table compare and
diagnose write (comparison.json's and diagnosis.json's "groups", report.md's "Per command")."""

from __future__ import annotations

import numpy as np

from skidsteer.diagnosis.comparison import SIGNIFICANT_Z, Comparison, Observed, Simulated
from skidsteer.features import signals
from skidsteer.features.extract import N_POWER, steady_summary


def credible_spread(key: str, value: float) -> float:
    """The smallest credible spread of a readable feature: a Welch bin for the peaks, the
    log-power resolution (comparison.LOG_POWER_RESOLUTION = 0.1 decade, i.e. 12 % in
    amplitude) for the RMS."""
    if key.endswith("_hz"):
        return signals.WELCH_RESOLUTION_HZ
    return 0.12 * abs(value)


def significant(z: float | None) -> bool:
    """Whether a feature's z against the trial spread marks a disagreement (SIGNIFICANT_Z)."""
    return z is not None and abs(z) > SIGNIFICANT_Z


def group_table(observed: Observed, comparison: Comparison, models: dict[str, Simulated]
                ) -> list[dict]:
    """Per group and readable feature: measured mean and trial spread, each model's
    value and its z against the spread; plus each model's spectral distance (RMS z
    of the band powers) and yaw rate."""
    rows = []
    runs = np.arange(len(observed.run_group))
    zs = {name: comparison.z_scores(sim.features, runs) for name, sim in models.items()}
    base = next(iter(models.values()))
    bias = np.median(base.features[observed.run_group, -1] - observed.features[:, -1])
    for gi, g in enumerate(observed.groups):
        members = np.flatnonzero(observed.run_group == gi)
        measured = [steady_summary(*observed.records[i]) for i in members]
        simulated = {name: steady_summary(sim.time_s[gi], sim.accel[gi])
                     for name, sim in models.items()}
        # the mean a_x less the sensor's offset (bias) and the static a_x of the robot at
        # rest (gravity along a tilted cube, read from the simulation's first sample)
        centripetal = observed.features[members, -1] + bias - base.accel[gi][0, 0]
        # yaw rate from the centripetal mean, scaled on the base simulation's (the
        # turning centre is not the CoM: in a swivel it sits ahead of the cube by
        # ~0.3 m, not 0.2 m, so a_x = omega^2 * 0.2 would overestimate omega)
        sim_centripetal = base.features[gi, -1] - base.accel[gi][0, 0]
        ratio = max(centripetal.mean(), 0.0) / sim_centripetal if sim_centripetal > 0 else np.nan
        row = {"group": g.label, "omega_deg_s": g.omega_deg_s, "trials": len(members),
               "measured_yaw_rate_from_centripetal_deg_s": float(
                   base.mean_yaw_rate_deg_s[gi] * np.sqrt(ratio)),
               "features": {}}
        for name, sim in models.items():
            row[f"{name}_yaw_rate_deg_s"] = sim.mean_yaw_rate_deg_s[gi]
            row[f"{name}_spectral_distance"] = float(np.sqrt(np.nanmean(
                zs[name][members, :N_POWER] ** 2)))
        for key in measured[0]:
            values = np.array([m[key] for m in measured])
            mean = float(np.nanmean(values))
            spread = float(np.nanstd(values, ddof=1)) if len(values) > 1 else 0.0
            spread = max(spread, credible_spread(key, mean))
            entry = {"measured": mean, "trial_spread": spread}
            for name in models:
                v = simulated[name][key]
                entry[name] = v
                entry[f"{name}_z"] = (v - mean) / spread if spread > 0 else None
            row["features"][key] = entry
        rows.append(row)
    return rows
