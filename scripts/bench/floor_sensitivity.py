"""How much the base model's swivel features move when its flat floor gets the roughness of
the smoothest real floor: per floor and swivel rate, the steady band powers of the base
model and of ground_roughness at RMS --height-rms (default the prior's low end, 20 um,
"polished concrete") and 5 cm correlation, each the median over --starts starts.

Issue 21's draw 1201 (a run-out on carpet, 20 deg/s held out) is what it was written for:
a floor of 20 um removed most of its held-out discrepancy (3.74 to 2.17), so the
diagnosis could not tell the run-out from a floor (docs/diagnose.md, "A run-out or a
rough floor?").  Where the model's swivel answers a floor that smooth, its flat plane is
an idealisation its features depend on, or the rough floor's own discretisation is what
they answer (the same page: with 4 samples per correlation length, the shipped grid, a
line at v / (grid spacing) that finer grids do not have).  Printed as JSON lines per (floor, rate): over
the steady bands above the sensor's noise floor (regime_map.NOISE_FLOOR_LOG10) on either
floor, the largest and the median shift of the median log10 power from the flat floor
(counted from the noise floor where a median is below it), over the floor's realisations
(0 to --realisations - 1, the largest shift of each band over them), the band of the
largest shift with its medians on each floor, and the flat floor's own start-to-start
standard deviation in that band (a shift within it is the model's scatter, not the
floor's).

    python scripts/bench/floor_sensitivity.py --floors carpet concrete --rates 10 20 30
    python scripts/bench/floor_sensitivity.py --height-rms 0.00035 --floor-normal surface \
        --reference vertical    # what the floor's own contact normal moves

Costs floors x rates x (1 + realisations) x starts simulations of 20 s.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from regime_map import (NOISE_FLOOR_LOG10, log10_power, steady_bands,  # noqa: E402
                        steady_powers)
from skidsteer.diagnosis import causes  # noqa: E402
from skidsteer.diagnosis.causes import ground_roughness  # noqa: E402
from skidsteer.diagnosis.causes.ground_roughness import (CORRELATION_LENGTH,  # noqa: E402
                                                         GRID_PER_CORRELATION, HEIGHT_RMS)
from skidsteer.robot import tire  # noqa: E402
from skidsteer.simulation.backends import LocalBackend  # noqa: E402
from skidsteer.simulation.cache import SimulationCache  # noqa: E402

def log_powers(floor: str, omega_deg_s: float, edit, starts: int, threads: int,
               timestep: float | None, cache: SimulationCache | None = None) -> np.ndarray:
    """(starts, steady bands): log10 of the steady band powers of one swivel from the
    diagnosis's starts 0..starts-1 (NaN where a band has no power)."""
    return log10_power(steady_powers(floor, omega_deg_s, starts, timestep=timestep, edit=edit,
                                     backend=LocalBackend(threads), cache=cache))


def rough_floor(values: dict, realisation: int, samples_per_correlation: int,
                interpolation: str | None, normal: str | None = None):
    """The edit that lays ground_roughness's floor of these parameters and realisation,
    sampled samples_per_correlation times per correlation length, under a tire plugin
    whose floor_interpolation is `interpolation` and floor_normal `normal` (None: the
    plugin's default)."""
    def edit(spec):
        ground_roughness.apply(spec, values, realisation,
                               samples_per_correlation=samples_per_correlation,
                               floor_normal=normal)
        if interpolation is not None:
            tire.configure(spec, {"floor_interpolation": interpolation})
    return edit


def shift(flat: np.ndarray, rough: list[np.ndarray]) -> dict:
    """The rough floors' shift of the median log10 power from the flat floor's (flat:
    (starts, bands); rough: one such array per realisation), over the bands whose median
    is above the sensor's noise floor on the flat floor or on one of the rough ones (a
    band the floor lifts out of the noise counts), each median held at the noise floor
    from below (a shift out of the noise is counted from it)."""
    bands = steady_bands()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # bands with no power: NaN
        flat_median = np.nanmedian(flat, axis=0)
        rough_medians = np.array([np.nanmedian(r, axis=0) for r in rough])
        loud = (flat_median > NOISE_FLOOR_LOG10) | np.any(rough_medians > NOISE_FLOOR_LOG10,
                                                          axis=0)
        floor = NOISE_FLOOR_LOG10
        moves = np.fmax(rough_medians, floor) - np.fmax(flat_median, floor)
        largest = np.nanmax(np.abs(moves), axis=0)
        largest[~loud] = np.nan
        flat_sd = np.nanstd(flat, axis=0, ddof=1)
    if not np.any(np.isfinite(largest)):
        return {"bands": 0, "max_shift": None, "median_shift": None, "worst": None}
    worst = int(np.nanargmax(largest))
    return {"bands": int(np.sum(np.isfinite(largest))),
            "max_shift": round(float(largest[worst]), 3),
            "median_shift": round(float(np.nanmedian(largest)), 3),
            "worst": bands[worst],
            "worst_flat": round(float(flat_median[worst]), 2),
            "worst_rough": [round(float(m[worst]), 2) for m in rough_medians],
            "flat_start_sd": round(float(flat_sd[worst]), 3)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--floors", nargs="+", default=["concrete", "carpet"])
    ap.add_argument("--rates", type=float, nargs="+", default=[10, 20, 30, 40, 50, 60])
    ap.add_argument("--height-rms", type=float, default=HEIGHT_RMS.low,
                    help="the rough floor's RMS height, m (default: the prior's low end)")
    ap.add_argument("--realisations", type=int, default=3)
    ap.add_argument("--starts", type=int, default=3)
    ap.add_argument("--timestep", type=float, help="the models' step, s (default: their own)")
    ap.add_argument("--samples-per-correlation", type=int, default=GRID_PER_CORRELATION,
                    help="the rough floor's grid: samples per correlation length (default: "
                    "the cause's; up to 10 at 5 cm samples the same floor more finely, "
                    "its 5 mm drawing grid)")
    ap.add_argument("--floor-interpolation",
                    choices=tire.attributes()["floor_interpolation"].choices,
                    help="the tire plugin's floor_interpolation on the rough floor "
                    "(default: the plugin's, cubic)")
    ap.add_argument("--floor-normal", choices=tire.attributes()["floor_normal"].choices,
                    help="the tire plugin's floor_normal on the rough floor (default: the "
                    "plugin's, vertical)")
    ap.add_argument("--reference", choices=("flat", "vertical"), default="flat",
                    help="what the rough floor is compared with: the flat floor (default) "
                    "or, realisation by realisation, the same rough floor under the "
                    "vertical normal (what --floor-normal surface moves; printed per "
                    "realisation)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--cache", type=Path, help="keep the simulations here (a rerun reuses "
                    "them)")
    args = ap.parse_args(argv)
    if args.starts < 2:
        ap.error(f"--starts {args.starts}: a start-to-start spread needs at least 2")
    if args.realisations < 1:
        ap.error(f"--realisations {args.realisations}: at least 1")
    cache = SimulationCache(args.cache) if args.cache else None
    if args.samples_per_correlation < 1:
        ap.error(f"--samples-per-correlation {args.samples_per_correlation}: at least 1")
    interpolation = (args.floor_interpolation
                     or tire.attributes()["floor_interpolation"].default)
    normal = args.floor_normal or tire.attributes()["floor_normal"].default
    if args.reference == "vertical" and normal == "vertical":
        ap.error("--reference vertical compares with the vertical normal: give "
                 "--floor-normal surface")
    rough = causes.get("ground_roughness")
    values = rough.parameters(args.height_rms,
                              {CORRELATION_LENGTH.name: CORRELATION_LENGTH.value})
    for floor in args.floors:
        for omega in args.rates:
            def powers(r, normal_of_floor):
                return log_powers(floor, float(omega),
                                  rough_floor(values, r, args.samples_per_correlation,
                                              args.floor_interpolation, normal_of_floor),
                                  args.starts, args.threads, args.timestep, cache)

            row = {"floor": floor, "omega_deg_s": float(omega),
                   "height_rms_m": args.height_rms, "timestep": args.timestep,
                   "starts": args.starts,
                   "samples_per_correlation": args.samples_per_correlation,
                   "floor_interpolation": interpolation, "floor_normal": normal,
                   "reference": args.reference}
            if args.reference == "vertical":
                for r in range(args.realisations):
                    print(json.dumps({**row, "realisation": r,
                                      **shift(powers(r, "vertical"), [powers(r, normal)])}),
                          flush=True)
                continue
            flat = log_powers(floor, float(omega), None, args.starts, args.threads,
                              args.timestep, cache)
            floors = [powers(r, args.floor_normal) for r in range(args.realisations)]
            print(json.dumps({**row, **shift(flat, floors)}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
