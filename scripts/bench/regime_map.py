"""The base model's start-to-start spread of its steady band powers, per floor, swivel
rate and time step: where a step's simulated starts split into regimes.

A diagnosis scores features against the trials' spread and reads the model as the
median over 5 simulated starts (diagnosis.comparison.start_state); where the model's
own starts split into regimes, a dataset whose trials all fell in one regime scores a
discrepancy the model itself makes (issue 21's null draw 1211: 30 deg/s on carpet).
For each (step, floor, rate) the extended build swivels 20 s from N starts; per steady
band above the sensor's noise floor (median power above 1e-8 (m/s^2)^2, a quiet run's
level being ~1e-7.5) the standard deviation of log10 power across the starts; printed
as JSON lines: the largest and the median over bands, and the worst band's values.

    python scripts/bench/regime_map.py --steps 1e-4 5e-5 --starts 6

Tile is concrete's friction set (plugin/tire/README.md, floors), so it is not
repeated.  Costs steps x 2 floors x rates x starts simulations of 20 s.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

from skidsteer.data.dataset import Group
from skidsteer.diagnosis.comparison import model_factory, simulate_groups
from skidsteer.features.extract import comparison_feature_names
from skidsteer.robot import Setup
from skidsteer.simulation.backends import LocalBackend

DURATION_S = 20.0  # a swivel's record, as the generalisation benchmark's
NOISE_FLOOR_LOG10 = -8.0  # a band below it reads the sensor's noise, not the robot


def steady_bands() -> list[str]:
    """The steady window's band-power features (not the wheel-order lines)."""
    return [n for n in comparison_feature_names() if n.startswith("steady_") and "wheel" not in n]


def log10_power(power: np.ndarray) -> np.ndarray:
    """log10 of band powers, NaN where a band has no power at all."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log10(np.where(power > 0, power, np.nan))


def steady_powers(floor: str, omega_deg_s: float, starts: int, *, timestep: float | None,
                  edit=None, backend, cache=None) -> np.ndarray:
    """(starts, steady_bands()): the steady band powers of the extended robot swivelling
    DURATION_S at omega_deg_s on `floor` from diagnose's starts 0..starts-1, simulated and
    reduced as diagnose does a command (edit: an MjSpec edit of the model; timestep None:
    the model's own; cache: a SimulationCache or None)."""
    names = list(comparison_feature_names())
    steady = [names.index(n) for n in steady_bands()]
    group = Group(0.0, omega_deg_s, Setup(build="extended", floor=floor))
    sims = simulate_groups([(model_factory(edit, timestep=timestep), [group])] * starts,
                           DURATION_S, backend=backend, starts=list(range(starts)),
                           signals=False, cache=cache)
    return np.array([s.features[0][steady] for s in sims])


def band_spread(power: np.ndarray, bands: list[str]) -> dict:
    """The spread over starts (axis 0) of each band's (axis 1, named `bands`) log10
    power: the bands above the sensor's noise floor, the largest and the median
    standard deviation, and the worst band's values; no bands (a quiet command) gives
    None and no values."""
    log_power = log10_power(power)
    with warnings.catch_warnings():  # bands with no power at all: NaN, left out
        warnings.simplefilter("ignore", RuntimeWarning)
        log_power[:, ~(np.nanmedian(log_power, axis=0) > NOISE_FLOOR_LOG10)] = np.nan
        sd = np.nanstd(log_power, axis=0, ddof=1)
    row = {"bands": int(np.sum(np.isfinite(sd)))}
    if not row["bands"]:  # every band at the sensor's floor: no spread to read
        return {**row, "max_sd": None, "median_sd": None, "worst": None, "worst_values": []}
    worst = int(np.nanargmax(sd))
    return {**row, "max_sd": float(sd[worst]), "median_sd": float(np.nanmedian(sd)),
            "worst": bands[worst],
            "worst_values": [round(float(v), 2) for v in log_power[:, worst]]}


def spread(step_s: float, floor: str, omega_deg_s: float, starts: int, threads: int,
           band: str | None = None, edit=None) -> dict:
    """band_spread of the base model's steady bands over `starts` starts of one command
    (edit: an MjSpec edit of the model, e.g. belt_coupling_study.rigid_belts)."""
    bands = steady_bands()
    power = steady_powers(floor, omega_deg_s, starts, timestep=step_s, edit=edit,
                          backend=LocalBackend(threads))
    row = {"step_s": step_s, "floor": floor, "omega_deg_s": omega_deg_s, "starts": starts,
           **band_spread(power, bands)}
    if band is not None:  # one band's values from every start, whatever its level
        with np.errstate(divide="ignore"):
            row[band] = [round(float(v), 2) for v in np.log10(power[:, bands.index(band)])]
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=float, nargs="+", default=[1e-4, 5e-5])
    ap.add_argument("--floors", nargs="+", default=["concrete", "carpet"])
    ap.add_argument("--rates", type=float, nargs="+", default=[10, 20, 30, 40, 50, 60])
    ap.add_argument("--starts", type=int, default=6)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--band", help="also print this steady band's log10 power from every "
                    "start (a feature name, e.g. steady_ay_9-12.5Hz)")
    ap.add_argument("--rigid-belts", action="store_true", help="the belt couplings at their "
                    "rigid limit (scripts/belt_coupling_study.py), not the shipped soft ones")
    args = ap.parse_args(argv)
    edit = None
    if args.rigid_belts:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
        from belt_coupling_study import rigid_belts as edit
    if args.starts < 2:
        ap.error(f"--starts {args.starts}: a spread needs at least 2 starts")
    if args.band is not None and args.band not in steady_bands():
        ap.error(f"--band {args.band!r} is not a steady band: use one of "
                 f"{steady_bands()[:4]}...")
    for step_s in args.steps:
        for floor in args.floors:
            for omega in args.rates:
                row = spread(step_s, floor, float(omega), args.starts, args.threads,
                             args.band, edit)
                print(json.dumps({**row, "belts": "rigid" if edit else "shipped"}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
