"""ground_roughness: the floor is not flat (the thesis's own suspect, Sec. 6.2).

The cause replaces the floor plane by a heightfield under the tire law (the
plugin reads heightfields, plugin/tire/README.md): a Gaussian random surface
of the given RMS height and correlation length (a Gaussian-filtered white
field), its realisation picked by the seed: one seed is one floor at every
correlation length (surface).  It covers the square the robot swivels and drives
in.
"""

import contextlib

import mujoco
import numpy as np
from scipy import ndimage

from skidsteer.diagnosis.causes import Cause, NotApplicable, Parameter
from skidsteer.robot import tire

HEIGHT_RMS = Parameter(
    "height_rms_m", 2e-5, 2e-3, 2e-4, log=True,
    source="assumed: indoor floors at the scale of a tire, from polished concrete (~0.02 mm) "
           "to worn tiles with joints and carpet seams (~2 mm); value: the geometric middle")
CORRELATION_LENGTH = Parameter(
    "correlation_length_m", 0.02, 0.2, 0.05, log=True,
    source="assumed: undulations of a few tile or tread widths; the lower bound is the tire's "
           "contact patch (the plugin samples the floor at one point)")
HALF_SIZE_M = 1.5  # the swivel stays within 0.3 m of the start; straight runs need the command
# How far the robot's centre may go from its start and keep every wheel on the floor
# (Cause.reach_m): the half side less the swivel's drift (0.3 m, above) and a wheel's
# reach from the centre (assumed 0.45 m: the largest robot here, the Husky A200, has its
# wheels 0.38 m from its centre).  Beyond it the wheels leave the heightfield, find no
# floor and the robot falls (a straight run at 0.15 m/s did at about 9 s of 20).
REACH_M = HALF_SIZE_M - 0.3 - 0.45
GRID_PER_CORRELATION = 4  # samples per correlation length (at least)
# The white noise is drawn once per seed on the grid the shortest correlation length
# needs (the prior's low end / GRID_PER_CORRELATION = 5 mm) and filtered to each
# correlation length there, so one seed is one floor at every correlation length (the
# same bumps, smoothed more or less), and the fit's probes and profile in the correlation
# length compare one floor, not unrelated ones (until a86cf90 the noise was drawn on a
# grid of correlation length / 4, so every correlation length was another floor).
FINE_STEP_M = CORRELATION_LENGTH.low / GRID_PER_CORRELATION
# The tire plugin's floor_normal on this floor: None leaves the plugin's default
# ("vertical": a bump loads a wheel but never pushes it back); "surface" makes the
# floor's own slope tilt the contact normal (plugin/tire/README.md).  Every committed
# row of the benchmarks is on the default; bench_diagnose_generalisation.py
# --rough-floor-normal sets it for a run (contact_normal), the data's floor and the
# fits' alike.
FLOOR_NORMAL: str | None = None


@contextlib.contextmanager
def contact_normal(normal: str | None):
    """FLOOR_NORMAL set to `normal` inside the block (every floor this cause lays, the
    data's and the fits'), back to the plugin's default after it."""
    global FLOOR_NORMAL
    FLOOR_NORMAL = normal
    try:
        yield
    finally:
        FLOOR_NORMAL = None


def fine_intervals(half_size_m: float) -> int:
    """The fine grid's steps across a floor's side (at most FINE_STEP_M each)."""
    return int(np.ceil(2 * half_size_m / FINE_STEP_M))


def surface(height_rms_m: float, correlation_length_m: float, half_size_m: float,
            seed: int, samples_per_correlation: int = GRID_PER_CORRELATION) -> np.ndarray:
    """Heights (n, n) in m on a square of side 2 half_size_m: zero-mean, RMS height_rms_m,
    a Gaussian filter of width correlation_length_m / sqrt(2) over white noise drawn
    from the seed on a FINE_STEP_M grid, kept at every k-th sample (k the largest
    whole number of fine steps that divides the side and keeps samples_per_correlation
    samples per correlation length; more than the fine grid holds keeps every sample:
    the same floor, sampled as finely as it was drawn)."""
    intervals = fine_intervals(half_size_m)
    if intervals + 1 > 2001:
        raise NotApplicable(f"ground_roughness: a {2 * half_size_m:g} m floor at "
                            f"{FINE_STEP_M * 1e3:.1f} mm needs {intervals + 1}^2 samples "
                            "(more than 2001^2)")
    fine_step_m = 2 * half_size_m / intervals
    white = np.random.default_rng(seed).standard_normal((intervals + 1, intervals + 1))
    field = ndimage.gaussian_filter(white, correlation_length_m / np.sqrt(2) / fine_step_m,
                                    mode="wrap")
    widest = max(1, int(correlation_length_m / samples_per_correlation / fine_step_m))
    stride = max(k for k in range(1, widest + 1) if intervals % k == 0)
    field = field[::stride, ::stride]
    field = field - field.mean()
    return field * (height_rms_m / field.std())


def apply(spec: mujoco.MjSpec, params, seed: int = 0, half_size_m: float = HALF_SIZE_M,
          samples_per_correlation: int = GRID_PER_CORRELATION,
          floor_normal: str | None = None) -> None:
    """Lays the floor; floor_normal: the tire plugin's on it (None: FLOOR_NORMAL, whose
    None leaves the plugin's default)."""
    planes = [g for g in spec.worldbody.geoms if g.type == mujoco.mjtGeom.mjGEOM_PLANE]
    if len(planes) != 1:
        raise NotApplicable(f"ground_roughness needs one floor plane in the world body, the "
                            f"model has {len(planes)}")
    floor = planes[0]
    heights = surface(params["height_rms_m"], params["correlation_length_m"], half_size_m,
                      seed, samples_per_correlation)
    low, span = float(heights.min()), float(np.ptp(heights))
    n = heights.shape[0]
    spec.add_hfield(name="rough_floor", size=[half_size_m, half_size_m, span, 0.05],
                    nrow=n, ncol=n, userdata=((heights - low) / span).ravel().tolist())
    floor.type = mujoco.mjtGeom.mjGEOM_HFIELD
    floor.hfieldname = "rough_floor"
    floor.pos = [floor.pos[0], floor.pos[1], floor.pos[2] + low]
    normal = floor_normal or FLOOR_NORMAL
    if normal is not None:
        tire.configure(spec, {"floor_normal": normal})


# assumed: 4 levels per parameter (16 start points, the frame's design budget), at the
# middles of four equal log-slices of each prior: RMS 0.036-1.1 mm, correlation length
# 27-150 mm, whose undulations pass under a wheel at frequencies 1.8x apart
DESIGN_LEVELS = 4


def roughness_design() -> list[dict[str, float]]:
    """Start points over the RMS height and the correlation length (Cause.design).  An
    undulation of wavelength L passes under a wheel at v/L: the correlation length sets
    the band the floor excites, the RMS its power, and the main fit varies the RMS at
    the prior's 0.05 m only: a floor of long undulations would then be fitted as a
    nearly flat one."""
    return [{HEIGHT_RMS.name: float(rms), CORRELATION_LENGTH.name: float(length)}
            for rms in HEIGHT_RMS.levels(DESIGN_LEVELS)
            for length in CORRELATION_LENGTH.levels(DESIGN_LEVELS)]


CAUSE = Cause("ground_roughness", "the floor is uneven (a random heightfield)",
              HEIGHT_RMS, (CORRELATION_LENGTH,), apply, recovery_factor=1.5, null_value=2e-5,
              random_realisation=True, design=roughness_design, reach_m=REACH_M)
