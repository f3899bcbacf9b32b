"""Measured runs against simulated ones: the features, their noise, the discrepancies.

Data flow: a dataset's runs are grouped by command and setup (repeated trials
form one group, data.group); each group is simulated once (``simulate_groups``)
and passed through the sensor's bandwidth (simulation.sensor_chain); both sides
are reduced to the same comparison vector (features.comparison_features);
``Comparison`` scores a simulation against the measurements in units of the
trials' spread.
"""

from __future__ import annotations

import dataclasses
import warnings
from typing import Callable, Sequence

import mujoco
import numpy as np

from skidsteer.data.dataset import Dataset, Group, group_runs
from skidsteer.features.extract import (N_POWER, STEADY_FROM_S, comparison_feature_names,
                                        comparison_features)
from skidsteer.robot import Setup, load_model, roles
from skidsteer.simulation.backends import LocalBackend
from skidsteer.simulation.cache import model_digest
from skidsteer.simulation.drive import DriveGeometry
from skidsteer.simulation.run import perturbed, run_from_settled, settle, trial_start
from skidsteer.simulation.sensor_chain import SensorChain

# The smallest spread a log10 band power is credited with: a Welch estimate of a
# band of b bins from K segments scatters by ~0.434/sqrt(K b) decades; the
# narrowest bands of the start window (b ~ 1, K ~ 5) give 0.2, the wider ones
# less: 0.1 decade (26 % in power) is the resolution of the estimator.
LOG_POWER_RESOLUTION = 0.1
# The smallest spread of the centripetal mean: +-1 deg/s at 30 deg/s moves it by
# 2 omega d_omega |x_a| = 0.004 m/s^2; a smaller difference is not a yaw-rate finding.
CENTRIPETAL_RESOLUTION_M_S2 = 0.004
SIGNIFICANT_Z = 3.0  # a group's feature disagrees when its trial-mean z exceeds this
# The degrees of freedom the trials' spread needs (Observed.spread_dof: each command's
# trials beyond its first, pooled) before a z-score against it is judged: against a
# spread on nu degrees of freedom it is Student's t, whose variance nu / (nu - 2) is
# infinite for nu <= 2 (the theory's limit, not fitted; measured: docs/diagnose.md)
MIN_SPREAD_DOF = 3
START_SEED = 7  # the simulated starts' draws (start_state), apart from synth's trials (1)


def _side_speeds(m: mujoco.MjModel, v_mps: float, omega_deg_s: float) -> np.ndarray:
    """|wheel speed| (rad/s) the command asks of each side (left, right)."""
    return np.abs(DriveGeometry.from_model(m).wheel_speeds(v_mps, np.deg2rad(omega_deg_s)))


def _distinct_rates_hz(side_speeds) -> tuple[float, ...]:
    return tuple(sorted({round(float(w) / (2 * np.pi), 12) for w in side_speeds if w > 0}))


def wheel_rates_hz(m: mujoco.MjModel, v_mps: float, omega_deg_s: float) -> tuple[float, ...]:
    """The wheels' rotation rates (Hz, > 0) the command (v_x*, omega_z*) asks for
    (Sec. 6.1's feed-forward).  One rate per side, merged when the sides turn equally
    fast.  The servos droop under the tires' torque (~9 % slower at 30 deg/s on
    concrete): actual_wheel_rates_hz reads the simulated wheels instead."""
    return _distinct_rates_hz(_side_speeds(m, v_mps, omega_deg_s))


def actual_wheel_rates_hz(m: mujoco.MjModel, run, v_mps: float, omega_deg_s: float
                          ) -> tuple[float, ...]:
    """The wheels' rotation rates (Hz) over a simulated run's steady window (from
    STEADY_FROM_S), as the wheel-order features need them: one per side where the
    command turns the sides at different rates (wheel_rates_hz), else one for all."""
    sides = _side_speeds(m, v_mps, omega_deg_s)
    commanded = _distinct_rates_hz(sides)
    steady = np.abs(run.wheel_speed[run.time_s - run.time_s[0] >= STEADY_FROM_S])
    if not commanded or not len(steady):
        return commanded
    left = roles.roles_of(m).wheel_position_m[:, 1] > 0
    turning = [(w, wheels) for w, wheels in zip(sides, (left, ~left)) if w > 0]
    if len(commanded) == 1:  # the turning sides at one commanded rate: one line per order
        return (float(np.mean([steady[:, wheels].mean() for _, wheels in turning]))
                / (2 * np.pi),)
    return tuple(float(steady[:, wheels].mean()) / (2 * np.pi)
                 for _, wheels in sorted(turning, key=lambda t: t[0]))


# --------------------------------------------------------------------- measured

@dataclasses.dataclass
class Observed:
    """The measured side: features of every usable run, grouped."""

    groups: list[Group]
    run_group: np.ndarray  # (n_runs,) index into groups
    run_files: list[str]
    features: np.ndarray  # (n_runs, n_features)
    duration_s: float  # the records' common length (the shortest)
    skipped: list[dict]
    records: list[tuple[np.ndarray, np.ndarray]]  # (time_s, accel) per run

    @classmethod
    def from_dataset(cls, dataset: Dataset,
                     wheel_rates: Callable[[Group], Sequence[float]] | None = None
                     ) -> "Observed":
        """wheel_rates: a group's wheel rotation rates in Hz (wheel_rates_hz on the model
        that will simulate it); None leaves the wheel-order features unscored."""
        infos, files, feats, durations, records = [], [], [], [], []
        skipped = list(dataset.skipped)
        for info, rec in dataset.runs:
            if rec is None:
                continue
            try:
                f = comparison_features(rec.time_s, rec.accel,
                                        wheel_rates(info.group) if wheel_rates else ())
            except ValueError as err:
                skipped.append({"file": info.file, "reason": f"{rec.path}: {err}"})
                continue
            infos.append(info)
            files.append(info.file)
            feats.append(f)
            durations.append(float(rec.time_s[-1] - rec.time_s[0]))
            records.append((rec.time_s, rec.accel))
        if not feats:
            raise ValueError(f"{dataset.root}: no usable runs; each file, with the reason:\n"
                             + "\n".join(f"  skipped {s['file']}: {s['reason']}"
                                         for s in skipped))
        groups = [g for g, _ in group_runs(infos)]  # the package's one grouping
        index = {g: i for i, g in enumerate(groups)}
        return cls(groups, np.array([index[i.group] for i in infos]), files, np.array(feats),
                   min(durations), skipped, records)

    def with_wheel_rates(self, rates: Sequence[Sequence[float]]) -> "Observed":
        """The same runs with their wheel-order features read at other wheel rates (one
        entry per group; e.g. the base simulation's actual rates, for records without
        wheel speeds: the command corrected by the simulated servos' droop)."""
        features = np.array([comparison_features(t, a, rates[gi]) for (t, a), gi
                             in zip(self.records, self.run_group)])
        return dataclasses.replace(self, features=features)

    def trials_per_command(self) -> np.ndarray:
        """The usable runs of each group."""
        return np.bincount(self.run_group, minlength=len(self.groups))

    def spread_dof(self) -> int:
        """The degrees of freedom of the trials' spread: each command's runs beyond its
        first, pooled (trial_spread's, for a feature every run scores)."""
        return int(np.sum(np.maximum(self.trials_per_command() - 1, 0)))

    def noise_floor(self) -> np.ndarray:
        """Per band power, the quietest run's: the sensor chain's floor wherever at least
        one run carries no vibration in that band (NaN for a feature no run scores)."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN: unscored everywhere
            return np.nanmin(self.features[:, :N_POWER], axis=0)

    def log_features(self) -> np.ndarray:
        out = self.features.copy()
        out[:, :N_POWER] = np.log10(np.maximum(out[:, :N_POWER], 1e-30))
        return out

    def trial_spread(self) -> np.ndarray:
        """Per feature, the trials' spread: the standard deviation within groups, pooled
        (ddof 1); zero without repeated trials."""
        logf = self.log_features()
        var, dof = np.zeros(logf.shape[1]), np.zeros(logf.shape[1])
        for gi in range(len(self.groups)):
            rows = logf[self.run_group == gi]
            counted = (~np.isnan(rows)).sum(axis=0)  # a feature unscored in a group (NaN)
            usable = counted > 1  # does not count there
            if usable.any():
                dev = rows[:, usable] - np.nanmean(rows[:, usable], axis=0)
                var[usable] += np.nansum(dev ** 2, axis=0)
                dof[usable] += counted[usable] - 1
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.nan_to_num(np.sqrt(var / dof))

    def scales(self) -> np.ndarray:
        """Per feature, the scale a discrepancy is measured in: the trials' spread, at
        least the estimator's resolution."""
        floor = np.full(self.features.shape[1], LOG_POWER_RESOLUTION)
        floor[-1] = CENTRIPETAL_RESOLUTION_M_S2
        return np.maximum(self.trial_spread(), floor)


def require_spread(observed: Observed, where: str = "the dataset") -> None:
    """A clear error when the trials' spread rests on fewer than MIN_SPREAD_DOF degrees
    of freedom: what the dataset has, and what to record."""
    dof = observed.spread_dof()
    if dof >= MIN_SPREAD_DOF:
        return
    held = ", ".join(f"{g.label} x {n}"
                     for g, n in zip(observed.groups, observed.trials_per_command()))
    raise ValueError(
        f"{where}: the trials' spread rests on {dof} repeated trial(s) ({held}; the "
        f"runs beyond the first of each command, pooled), and a discrepancy is judged "
        f"against it from {MIN_SPREAD_DOF} on (with fewer, a z-score against it has no "
        "finite variance: the model itself scored 2.0-6.1 on such datasets, above the "
        "no-discrepancy limit); record more trials of a command, e.g. 3 commands x 2 "
        "trials or 1 command x 4")


# ------------------------------------------------------------------ simulation

@dataclasses.dataclass
class Simulated:
    """One simulated record per group, as the sensor sees it."""

    time_s: list[np.ndarray]
    accel: list[np.ndarray]
    mean_yaw_rate_deg_s: list[float]
    features: np.ndarray  # (n_groups, n_features)
    # per group, the wheels' rates over the steady window (actual_wheel_rates_hz)
    wheel_rates_hz: list[tuple[float, ...]] = dataclasses.field(default_factory=list)


ModelFactory = Callable[[Setup], mujoco.MjModel]


def start_state(m: mujoco.MjModel, start: int, settle_s: float = 2.0) -> np.ndarray:
    """A simulation's settled start: 0, the robot at rest as built; k > 0, a repeat
    trial's start drawn as synth draws a dataset's trials: trial_start's draw k (another
    yaw and wheel angle) with perturbed's residual tire deflections (seeded apart from
    any dataset's trials by START_SEED).

    The deflections matter: on a flat floor with round wheels the yaw and wheel angle
    change nothing physical, so starts without them are copies of one simulation up to
    roundoff; with them the starts are independent draws of the model's run-to-run
    scatter, as the trials they are compared with are."""
    if start == 0:
        return settle(m, mujoco.MjData(m), settle_s)
    turned = trial_start(m, np.random.default_rng([START_SEED, int(start)]), settle_s)
    return perturbed(m, turned, [START_SEED, int(start), 2])


def simulate_groups(jobs: list[tuple[ModelFactory, list[Group]]], duration_s: float,
                    chain: SensorChain = SensorChain(), settle_s: float = 2.0,
                    nthread: int = 2, progress: Callable[[int], None] | None = None,
                    backend=None, cache=None, signals: bool = True,
                    starts: Sequence[int] | None = None) -> list[Simulated]:
    """For each (model factory, groups) job, each group simulated once from a settled
    start: the job's entry of starts (start_state; default 0, at rest).

    Models are built once per (factory, setup) and settled once per start here; the
    (model, group) runs are `simulate_group` tasks on the backend (default: nthread
    threads).

    cache: a simulation.cache.SimulationCache; every finished run is stored in it.
    signals=False lets a stored run stand in for a simulation: its features and
    yaw rate come back with time_s and accel None (a fit reads only those).
    """
    backend = backend or LocalBackend(nthread)
    results = [Simulated([None] * len(g), [None] * len(g), [0.0] * len(g),
                         np.zeros((len(g), N_POWER + 1)), [()] * len(g)) for _, g in jobs]
    starts = [0] * len(jobs) if starts is None else [int(s) for s in starts]
    if len(starts) != len(jobs):
        raise ValueError(f"simulate_groups: {len(starts)} starts for {len(jobs)} jobs")
    # (factory, setup) -> (model, its digest); (factory, setup, start) -> (model, state)
    built: dict[tuple[int, Setup], tuple] = {}
    shared: dict[tuple[int, Setup, int], tuple] = {}
    tasks, where, keys = [], [], []
    for j, ((factory, groups), start) in enumerate(zip(jobs, starts)):
        for k, g in enumerate(groups):
            key = (id(factory), g.setup)
            if key not in built:
                m = factory(g.setup)
                built[key] = (m, model_digest(m) if cache is not None else None)
            m, digest = built[key]
            entry_key = None
            if cache is not None:
                entry_key = cache.key(digest, settle_s, g.v_mps, g.omega_deg_s, duration_s,
                                      chain, start)
                stored = None if signals else cache.get(entry_key)
                if stored is not None:
                    (results[j].features[k], results[j].mean_yaw_rate_deg_s[k],
                     results[j].wheel_rates_hz[k]) = stored
                    if progress:
                        progress(1)
                    continue
            if (*key, start) not in shared:
                shared[(*key, start)] = (backend.share(m),
                                         backend.share(start_state(m, start, settle_s)))
            tasks.append((*shared[(*key, start)], g.v_mps, g.omega_deg_s, duration_s, chain))
            where.append((j, k))
            keys.append(entry_key)
    for (j, k), entry_key, (time_s, accel, yaw, rates) in zip(
            where, keys, backend.map(simulate_group, tasks)):
        r = results[j]
        r.time_s[k], r.accel[k], r.mean_yaw_rate_deg_s[k] = time_s, accel, yaw
        r.features[k], r.wheel_rates_hz[k] = comparison_features(time_s, accel, rates), rates
        if cache is not None:
            cache.put(entry_key, r.features[k], yaw, rates)
        if progress:
            progress(1)
    return results


def simulate_group(m: mujoco.MjModel, settled: np.ndarray, v_mps: float, omega_deg_s: float,
                   duration_s: float, chain: SensorChain):
    """One command from the settled state, as the sensor chain logs it: (time_s, accel,
    mean yaw rate in deg/s, the wheels' rotation rates in Hz).  A backend task."""
    run = run_from_settled(m, settled, v_mps, omega_deg_s, duration_s)
    time_s, accel = chain.log(run)
    return (time_s, accel, run.mean_yaw_rate_deg_s(),
            actual_wheel_rates_hz(m, run, v_mps, omega_deg_s))


# ------------------------------------------------------------------ comparison

TRIALS_SCALE = "the trials' spread"  # Comparison.scale_label without the model's spread


@dataclasses.dataclass
class Comparison:
    """Scores simulations against one set of measurements, in units of the trials' spread
    (and of the model's own start-to-start spread at each command, added in quadrature,
    where given: with_model_spread)."""

    observed: Observed
    # (n_groups, n_features): the model's start-to-start spread at each command
    # (start_spread); None: the trials' spread alone
    model_spread: np.ndarray | None = None

    def __post_init__(self):
        self.floor = self.observed.noise_floor()
        # per feature; per command and feature (n_groups, n_features) with model_spread
        self.scale = self.observed.scales()
        if self.model_spread is not None:
            self.scale = np.sqrt(self.scale ** 2 + np.nan_to_num(self.model_spread) ** 2)
        self.measured = self.observed.log_features()

    @property
    def scale_label(self) -> str:
        """What the scale is, in the words a verdict's reason and the gain's metric use."""
        return (TRIALS_SCALE if self.model_spread is None
                else "the trials' and the base model's start-to-start spread")

    def _scale_at(self, groups):
        """The scale of the commands `groups` (an index or an array of them): the per-
        feature scale itself, or its rows (with model_spread)."""
        return self.scale if self.scale.ndim == 1 else self.scale[groups]

    def start_spread(self, starts: Sequence["Simulated"]) -> np.ndarray:
        """(n_groups, n_features): the model's start-to-start spread at each command, the
        standard deviation (ddof 1) over `starts` (one model's simulations of every
        command, each from another start) as the measurement would show them
        (simulated_log).  Not pooled over the commands, as the trials' spread is: a
        regime split is a property of one command."""
        logs = np.stack([self.simulated_log(s.features) for s in starts])  # start, group, f
        with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a feature unscored: NaN
            return np.nan_to_num(np.nanstd(logs, axis=0, ddof=1))

    def with_model_spread(self, starts: Sequence["Simulated"]) -> "Comparison":
        """This comparison with the model's start-to-start spread at each command
        (start_spread of `starts`) added to every feature's scale in quadrature: a
        discrepancy is then measured against what the trials and the model's own scatter
        together leave open.  At the default step the base model's steady band powers can
        split into two regimes across starts, and a null dataset whose trials fell in one
        regime, the model's median in the other, would read as a discrepancy."""
        if len(starts) < 2:
            raise ValueError(f"the model's start-to-start spread needs 2 starts or more, "
                             f"not {len(starts)}")
        return Comparison(self.observed, self.start_spread(starts))

    def noise_error(self) -> float:
        """The error a simulation exactly at the trials' mean scores, on average, against
        single trials: the RMS over features (and commands, with the model's spread) of
        the trials' spread in units of the scale (<= 1, as the scale is the spread or its
        floor).  No model can score below it except by chance; it is the zero of a
        discrepancy."""
        spread = self.observed.trial_spread()
        return float(np.sqrt(np.mean((spread / self.scale) ** 2)))

    def simulated_log(self, sim_features: np.ndarray) -> np.ndarray:
        """Simulated features as the measurement would show them: the sensor chain's
        noise floor added to every band power."""
        out = np.array(sim_features, dtype=float)
        out[:, :N_POWER] = np.log10(out[:, :N_POWER] + self.floor)
        return out

    def z_scores(self, sim_features: np.ndarray, runs: np.ndarray,
                 bias_runs: np.ndarray | None = None) -> np.ndarray:
        """(len(runs), n_features): (simulated - measured) / spread per run.

        The centripetal mean carries the sensor's unknown zero-g error on a_x (a
        constant for the dataset); it is removed as the median difference over
        bias_runs (default: runs), the way a fit removes a nuisance offset.
        """
        sim = self.simulated_log(sim_features)[self.observed.run_group]
        diff = sim - self.measured
        bias_runs = runs if bias_runs is None else bias_runs
        diff[:, -1] -= np.median(diff[bias_runs, -1])
        return diff[runs] / self._scale_at(self.observed.run_group[runs])

    def error(self, sim_features: np.ndarray, runs: np.ndarray,
              bias_runs: np.ndarray | None = None) -> float:
        """RMS z-score over runs and features: ~1 for a simulation as close to the
        measurements as one trial is to the next."""
        z = self.z_scores(sim_features, runs, bias_runs)
        return float(np.sqrt(np.nanmean(z ** 2)))

    def run_errors(self, sim_features: np.ndarray, runs: np.ndarray,
                   bias_runs: np.ndarray | None = None) -> np.ndarray:
        z = self.z_scores(sim_features, runs, bias_runs)
        return np.sqrt(np.nanmean(z ** 2, axis=1))

    def discrepancies(self, sim_features: np.ndarray, limit: int = 20) -> list[dict]:
        """The group features whose trial-mean z exceeds SIGNIFICANT_Z, largest first."""
        runs = np.arange(len(self.observed.run_group))
        z = self.z_scores(sim_features, runs)
        names = comparison_feature_names()
        sim = self.simulated_log(sim_features)
        out = []
        for gi, g in enumerate(self.observed.groups):
            rows = self.observed.run_group == gi
            with np.errstate(invalid="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # unscored features: NaN
                zbar = np.nanmean(z[rows], axis=0)
            for f in np.flatnonzero(np.abs(zbar) > SIGNIFICANT_Z):
                kind = "centripetal" if f == N_POWER else "log10_band_power"
                out.append({"group": g.label, "feature": names[f], "kind": kind,
                            "measured": float(np.nanmean(self.measured[rows, f])),
                            "simulated": float(sim[gi, f]),
                            # the scale (with_model_spread: the model's spread too)
                            "trial_spread": float(self._scale_at(gi)[f]),
                            "z": float(zbar[f])})
        out.sort(key=lambda d: -abs(d["z"]))
        return out[:limit]


def model_factory(edit: Callable[[mujoco.MjSpec], None] | None = None,
                  timestep: float | None = None) -> ModelFactory:
    """Setup -> compiled model: load_model(setup) (the run's robot and build, its floor,
    the accelerometer where the run had it), then edit (a cause)."""
    def build(setup: Setup) -> mujoco.MjModel:
        return load_model(setup, timestep=timestep, edit=edit)

    return build


def group_wheel_rates(factory: ModelFactory) -> Callable[[Group], tuple[float, ...]]:
    """Group -> its wheels' rotation rates (Hz) on the models factory builds (one build
    per setup)."""
    models: dict[Setup, mujoco.MjModel] = {}

    def rates(g: Group) -> tuple[float, ...]:
        if g.setup not in models:
            models[g.setup] = factory(g.setup)
        return wheel_rates_hz(models[g.setup], g.v_mps, g.omega_deg_s)

    return rates
