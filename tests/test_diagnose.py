"""diagnose: candidate causes, the measurement chain, features, verdicts, and hidden effects.

The hidden-effect tests build a "measured" dataset from a truth model (our model
plus one effect, seeded) through the sensor chain into LabVIEW xlsx files, and
require diagnose to find what was hidden.  They are the slow part of the suite
(1.5-3 min per effect of a worker under CI=true, sharing one simulation cache;
wheel eccentricity's longer records more);
the records are 8 s, the shortest the band features allow (3 s start-up window,
4 s onwards steady window with 4096-sample Welch segments), except for wheel
eccentricity, whose once-per-revolution line needs 14 s (RECORD_S).  Each effect's
diagnosis is one unit of work for pytest's workers (its own xdist_group), so that
scripts/test.sh's two workers share them (tests/hidden_effects.py).
"""

from __future__ import annotations

import dataclasses
import json
import signal
import subprocess
import sys
import time

import mujoco
import numpy as np
import pytest

import skidsteer  # noqa: F401
from skidsteer import diagnosis
from skidsteer.data.dataset import Group
from skidsteer.diagnosis import causes
from skidsteer.diagnosis.comparison import (CENTRIPETAL_RESOLUTION_M_S2, Comparison, Observed,
                                            Simulated, model_factory, simulate_group,
                                            wheel_rates_hz)
from skidsteer.diagnosis.causes.mast_compliance import exchanged_axes
from skidsteer.diagnosis.evaluate import STARTS, Evaluations, median_error, parameter_key
from skidsteer.diagnosis.intervals import interval, interval_bound, unprobed_sides
from skidsteer.diagnosis.search import (GRID_POINTS, PROFILE_MOVES, REFINE_CONTENDERS,
                                        REFINE_MAX_STEPS, REFINE_STEPS, Fit, contenders,
                                        fit_every_parameter, over_realisations,
                                        rechoose_realisation, refine_parameters)
from skidsteer.diagnosis.split import holds_out_commands
from skidsteer.diagnosis.synth import OUTSIDE_EFFECTS, make_dataset, truth_edit
from skidsteer.diagnosis.verdict import profile_factor
from skidsteer.features.extract import N_POWER
from skidsteer.features.extract import comparison_feature_names as feature_names
from skidsteer.features.extract import comparison_features as run_features
from skidsteer.reports.diagnosis import compare, diagnose
from skidsteer.robot import Setup, load_model, roles_of
from skidsteer.simulation.run import FULLPHYSICS, settle, trial_start
from skidsteer.simulation.sensor_chain import SensorChain

from hidden_effects import (DURATION_S, SEED, check_named, check_not_wrong, hidden_diagnoses,
                            rivals)

NAMED = ("mast_compliance", "loose_payload", "ground_roughness", "wheel_eccentricity",
         "slip_lambda_max", "friction_levels", "sensor_mount")


# ------------------------------------------------------------------ registry

def test_registry_holds_the_issue_candidates():
    assert set(NAMED) <= set(causes.CAUSES)
    for cause in causes.CAUSES.values():
        p = cause.main
        assert p.low < p.value < p.high and p.low <= cause.null_value <= p.high, cause.name
        assert p.source and all(h.source for h in cause.held), cause.name


@pytest.mark.parametrize("name", NAMED)
def test_each_cause_compiles_on_the_extended_robot_and_changes_it(name):
    cause = causes.get(name)
    base = load_model("extended", "concrete")
    m = load_model("extended", "concrete", edit=cause.edit(cause.parameters()))
    changed = (m.nq != base.nq or m.nhfield != base.nhfield
               or not np.array_equal(m.geom_pos, base.geom_pos)
               or m.plugin_attr.tobytes() != base.plugin_attr.tobytes())
    assert changed, f"{name} left the model as it was"


@pytest.mark.parametrize("name", ["mast_compliance", "loose_payload"])
def test_frame_causes_do_not_apply_to_the_bare_platform(name):
    cause = causes.get(name)
    with pytest.raises(causes.NotApplicable, match=name):
        load_model("platform", "concrete", edit=cause.edit(cause.parameters()))


def test_a_rough_floor_is_not_fitted_to_runs_that_drive_off_it():
    from skidsteer.diagnosis.search import fit_cause
    from skidsteer.simulation.run import run_batch

    rough = causes.get("ground_roughness")
    # the premise: past the heightfield's edge the wheels find no floor and carry no
    # load (before Cause.reach_m such runs were scored as data); 12 s at 0.15 m/s is
    # 1.8 m from the start, at 0.05 m/s 0.6 m, inside the reach
    m = load_model("extended", "concrete", edit=rough.edit(rough.parameters()))
    off, on = run_batch([m, m], [(0.15, 0.0), (0.05, 0.0)], 12.0)
    assert np.all(off.tire_forces[-1, :, 0] == 0)
    assert np.all(on.tire_forces[-1, :, 0] > 0)
    # turning in place, a slow straight run and a tight arc stay on it; a 20 s
    # straight run at 0.15 m/s (3 m) and a wide arc (2 v / omega = 1.15 m) do not
    rough.check_reach([(0.0, 60.0), (0.05, 0.0), (0.1, 30.0)], 12.0)
    for command, travel in (((0.15, 0.0), "3.00 m"), ((0.3, 30.0), "1.15 m")):
        with pytest.raises(causes.NotApplicable, match=f"ground_roughness.*{travel}"):
            rough.check_reach([(0.0, 30.0), command], 20.0)
    # a diagnosis lists it as not applicable before simulating anything (no comparison,
    # chain or backend is touched), and every other cause has no reach
    straight = Group(0.15, 0.0, Setup(build="extended", floor="concrete"))
    with pytest.raises(causes.NotApplicable, match="beyond the 0.75 m"):
        fit_cause(rough, None, [straight], 20.0, np.arange(3), np.arange(0), None, None,
                  None, None)
    assert [c.name for c in causes.CAUSES.values() if c.reach_m is not None] == [
        "ground_roughness"]


def test_the_rough_floor_leaves_the_contact_normal_to_the_plugin_unless_set():
    # ground_roughness.FLOOR_NORMAL (bench_diagnose_generalisation.py --rough-floor-normal,
    # through contact_normal) reaches the tire plugin of the model it edits; unset, the
    # cause leaves the plugin's default (every committed row), and contact_normal puts
    # it back after the block
    from skidsteer.diagnosis.causes import ground_roughness
    from skidsteer.robot import load_spec, tire

    rough = causes.get("ground_roughness")

    def normal_of_rough_floor():
        spec = load_spec("extended", "concrete")
        rough.edit(rough.parameters())(spec)
        spec.compile()  # the plugin accepts it
        return dict(tire.instance(spec).config).get("floor_normal")

    assert ground_roughness.FLOOR_NORMAL is None
    assert normal_of_rough_floor() is None
    with ground_roughness.contact_normal("surface"):
        assert normal_of_rough_floor() == "surface"
    assert ground_roughness.FLOOR_NORMAL is None
    assert normal_of_rough_floor() is None


def test_unknown_cause_and_parameter_are_named():
    with pytest.raises(ValueError, match="'nope'"):
        causes.get("nope")
    with pytest.raises(ValueError, match="'bogus'"):
        causes.get("mast_compliance").parameters(overrides={"bogus": 1.0})


@pytest.mark.parametrize("name", NAMED)
def test_clear_draws_stay_clear_of_the_base_model(name):
    cause = causes.get(name)
    rng = np.random.default_rng(0)
    u0 = cause.main.to_unit(cause.null_value)
    for _ in range(200):
        value = cause.strong_draw(rng)
        assert cause.main.low <= value <= cause.main.high
        assert abs(cause.main.to_unit(value) - u0) >= causes.STRONG_DISTANCE - 1e-9


# ------------------------------------------------------------------ chain and features

def test_sensor_bandwidth_is_minus_3_db_at_80_hz():
    fs = 10000.0
    t = np.arange(0, 2.0, 1 / fs)
    x = np.sin(2 * np.pi * 80.0 * t)[:, None]
    y = SensorChain().respond(x, fs)[int(fs):]  # after the filter's transient
    assert np.sqrt(2) * y.std() == pytest.approx(1 / np.sqrt(2), rel=0.01)


def _record(amplitude=0.0, freq=7.0, mean_ax=0.0, seconds=8.0, fs=1000.0):
    t = np.arange(0, seconds, 1 / fs)
    accel = np.zeros((len(t), 3))
    accel[:, 0] = mean_ax
    accel[:, 1] = amplitude * np.sin(2 * np.pi * freq * t)
    accel[:, 2] = 9.81
    return t, accel


def test_features_measure_band_power_and_centripetal_mean():
    t, a = _record(amplitude=0.3, freq=7.5, mean_ax=0.05)
    f = run_features(t, a)
    names = feature_names()
    # a sine of amplitude A carries A^2/2 of power, all of it in its band (Welch, Hann)
    assert f[names.index("steady_ay_6.5-9Hz")] == pytest.approx(0.3 ** 2 / 2, rel=0.02)
    assert f[names.index("start_ay_6.5-9Hz")] == pytest.approx(0.3 ** 2 / 2, rel=0.05)
    assert f[names.index("steady_ay_12.5-17Hz")] < 1e-6 * 0.3 ** 2
    assert f[-1] == pytest.approx(0.05)


def test_wheel_order_features_measure_the_line_at_the_wheel_rate():
    # a 6 mm/s^2 tilt line at 0.14 Hz (a wheel's rate at 30 deg/s) on a slow drift and
    # broadband noise: its power A^2/2 at 1x, next to nothing at 2x
    rng = np.random.default_rng(2)
    t, a = _record(seconds=20.0)
    amplitude, rate = 0.006, 0.14
    a[:, 0] += amplitude * np.sin(2 * np.pi * rate * t + 0.7) + 0.002 * t / 20.0
    a += rng.normal(0, 0.005, a.shape)
    f = run_features(t, a, wheel_rates=(rate,))
    names = feature_names()
    # noise: the fit's amplitude scatters by sigma sqrt(2 / N) = 0.06 mm/s^2 (1 %)
    assert f[names.index("steady_ax_wheel_1x")] == pytest.approx(amplitude ** 2 / 2, rel=0.05)
    assert f[names.index("steady_ax_wheel_2x")] < 0.01 * amplitude ** 2 / 2
    assert f[names.index("steady_ay_wheel_1x")] < 0.01 * amplitude ** 2 / 2
    # two sides at different rates: both lines, summed
    a[:, 1] += amplitude * np.sin(2 * np.pi * 0.3 * t) + amplitude * np.sin(2 * np.pi * 0.5 * t)
    f = run_features(t, a, wheel_rates=(0.3, 0.5))
    assert f[names.index("steady_ay_wheel_1x")] == pytest.approx(amplitude ** 2, rel=0.05)


def test_wheel_order_features_need_a_revolution_in_the_steady_window():
    t, a = _record(seconds=8.0)  # a 4 s steady window
    f = run_features(t, a, wheel_rates=(0.14,))  # a 7 s revolution
    names = feature_names()
    assert np.isnan(f[names.index("steady_ax_wheel_1x")])
    # twice the rate (0.28 Hz) holds 1.1 periods: scored, and near zero without a line
    assert 0 <= f[names.index("steady_ax_wheel_2x")] < 1e-8
    assert np.isnan(run_features(t, a)[names.index("steady_ay_wheel_1x")])


def test_too_short_records_are_refused_with_the_length():
    t, a = _record(seconds=5.0)
    with pytest.raises(ValueError, match="too short"):
        run_features(t, a)


def _observed(features, groups_of_runs):
    n = len(features)
    return Observed(groups=[object()] * (max(groups_of_runs) + 1),
                    run_group=np.array(groups_of_runs), run_files=[f"r{i}" for i in range(n)],
                    features=np.array(features), duration_s=8.0, skipped=[],
                    records=[None] * n)


def test_a_perfect_simulation_scores_zero_and_the_sensor_offset_is_a_nuisance():
    rng = np.random.default_rng(1)
    per_group = np.exp(rng.normal(-8, 1, (2, N_POWER + 1)))
    per_group[:, -1] = [0.01, 0.1]
    measured = per_group[[0, 0, 1, 1]].copy()
    measured[:, -1] += 0.07  # zero-g error of the a_x channel
    comp = Comparison(_observed(measured, [0, 0, 1, 1]))
    runs = np.arange(4)
    # simulated power plus the noise floor: exactly what was measured
    sim = per_group - np.r_[comp.floor, 0.0]
    sim[:, :N_POWER] = np.maximum(sim[:, :N_POWER], 0)
    z = comp.z_scores(sim, runs)
    assert np.abs(z).max() < 1e-9
    # the centripetal feature's scale is at least its resolution
    assert comp.scale[-1] >= CENTRIPETAL_RESOLUTION_M_S2


def test_the_models_own_start_spread_widens_the_scale_at_its_command():
    # two commands, two trials each, every band power 1e-6 (log -6) give or take 0.01
    # decade: the trials' spread is below the estimator's resolution (0.1 decade)
    measured = np.full((4, N_POWER + 1), 1e-6)
    measured[:, :N_POWER] *= 10 ** np.array([0.01, -0.01, 0.01, -0.01])[:, None]
    measured[:, -1] = 0.05
    comp = Comparison(_observed(measured, [0, 0, 1, 1]))
    assert np.allclose(comp.scale[:N_POWER], 0.1)
    # the model's starts: band 0 in two regimes at command 0 (1e-4 and 1e-2: 2 decades
    # apart, two starts each), every other band repeats itself
    def start(power0):
        f = np.full((2, N_POWER + 1), 1e-4)
        f[0, 0] = power0
        f[:, -1] = 0.05
        return Simulated([], [], [0.0, 0.0], f)
    starts = [start(1e-4), start(1e-2), start(1e-4), start(1e-2)]
    spread = comp.start_spread(starts)
    # band 0 at command 0: deviations of +-1 decade (the measurement's floor, 1e-6, added
    # to both takes 0.4 % off), sqrt(4 / 3) decades; nothing at command 1 or elsewhere
    assert spread.shape == (2, N_POWER + 1)
    assert spread[0, 0] == pytest.approx(np.sqrt(4 / 3), rel=5e-3)
    assert np.count_nonzero(spread) == 1
    wider = comp.with_model_spread(starts)
    assert wider.scale[0, 0] == pytest.approx(np.hypot(0.1, spread[0, 0]), rel=1e-9)
    assert np.array_equal(wider.scale[1], comp.scale) and np.array_equal(
        wider.scale[0, 1:], comp.scale[1:])
    # a simulation in either regime counts for that much less on band 0 at command 0
    # (runs 0 and 1), and as before everywhere else
    loud, runs = start(1e-2).features, np.arange(4)
    with np.errstate(invalid="ignore"):  # the centripetal mean: 0 / 0
        ratio = wider.z_scores(loud, runs) / comp.z_scores(loud, runs)
    assert np.allclose(ratio[:2, 0], 0.1 / np.hypot(0.1, spread[0, 0]), rtol=1e-9)
    assert np.allclose(ratio[2:, :N_POWER], 1.0) and np.allclose(ratio[:, 1:N_POWER], 1.0)
    # and the noise error is read against the wider scale (the trials' spread is 0.1)
    trial = comp.observed.trial_spread()
    assert wider.noise_error() == pytest.approx(
        np.sqrt(np.mean((trial / wider.scale) ** 2)), rel=1e-12)
    assert wider.noise_error() < comp.noise_error()
    with pytest.raises(ValueError, match="2 starts or more"):
        comp.with_model_spread(starts[:1])
    # the scale's name, as the gain's metric and the verdict's reason say it
    assert comp.scale_label == "the trials' spread"
    assert wider.scale_label == "the trials' and the base model's start-to-start spread"
    # a no-discrepancy reason says what the error was read against
    _, _, reason = diagnosis.verdict(1.5, 1.4, [], 0.8, base_train=1.5, n_train=6,
                                     scale="the trials' and the base model's spread")
    assert reason.endswith("(RMS z against the trials' and the base model's spread)")


def test_split_holds_out_the_middle_command():
    obs = _observed(np.ones((9, N_POWER + 1)), [0, 0, 0, 1, 1, 1, 2, 2, 2])
    train, held = diagnosis.split(obs)
    assert list(held) == [3, 4, 5] and list(train) == [0, 1, 2, 6, 7, 8]
    # the middle shows a discrepancy: it stays held out, whatever the others show
    assert list(diagnosis.split(obs, np.array([4.0, 2.1, 1.0]))[1]) == [3, 4, 5]


def test_split_holds_out_a_command_that_shows_the_discrepancy():
    obs = _observed(np.ones((9, N_POWER + 1)), [0, 0, 0, 1, 1, 1, 2, 2, 2])
    # the middle quiet, both others showing it: the weaker of them is held out, the
    # stronger trains (issue 21's draw 1041: 2.14, 1.78, 4.14)
    train, held = diagnosis.split(obs, np.array([2.14, 1.78, 4.14]))
    assert list(held) == [0, 1, 2] and list(train) == [3, 4, 5, 6, 7, 8]
    # one command alone shows it: holding it out would leave nothing to fit, so the
    # middle stays held out (and the verdict cannot confirm a cause)
    assert list(diagnosis.split(obs, np.array([1.5, 1.9, 4.2]))[1]) == [3, 4, 5]
    # nothing shows: the middle
    assert list(diagnosis.split(obs, np.array([1.0, 1.0, 1.0]))[1]) == [3, 4, 5]
    # six commands hold out two (1 and 4); both quiet, three others show it
    six = _observed(np.ones((6, N_POWER + 1)), [0, 1, 2, 3, 4, 5])
    assert list(diagnosis.split(six, np.array([3.0, 1.0, 2.5, 5.0, 1.5, 1.9]))[1]) == [0, 2]


def test_split_holds_out_the_commands_a_user_names():
    tile, concrete = (Setup(build="extended", floor=f) for f in ("tile", "concrete"))
    obs = _observed(np.ones((12, N_POWER + 1)), [0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3])
    obs.groups = [Group(0.0, w, tile) for w in (10.0, 20.0, 30.0)] + [
        Group(0.0, 60.0, concrete)]
    # by its label, or its command alone where one setup has it; neither rule applies,
    # not even where the held-out command is quiet and others show the discrepancy
    errors = np.array([3.0, 3.0, 3.0, 1.0])
    held = diagnosis.split(obs, errors, held_out=["v0-w60"])[1]
    assert list(held) == [9, 10, 11]
    both = diagnosis.split(obs, held_out=["v0-w10 tile extended", "v0-w60"])
    assert list(both[1]) == [0, 1, 2, 9, 10, 11] and list(both[0]) == [3, 4, 5, 6, 7, 8]
    # held out by the user, a command is a new one even with fewer than three
    assert holds_out_commands(obs, ["v0-w60"])
    with pytest.raises(ValueError, match=r"'v0-w45'.*no such command.*v0-w10 tile extended"):
        diagnosis.split(obs, held_out=["v0-w45"])
    with pytest.raises(ValueError, match="every command"):
        diagnosis.split(obs, held_out=[g.label for g in obs.groups])
    obs.groups[3] = Group(0.0, 10.0, concrete)  # two setups at 10 deg/s
    with pytest.raises(ValueError, match=r"'v0-w10' names 2 commands.*full label"):
        diagnosis.split(obs, held_out=["v0-w10"])


class _Surface:
    """A stand-in for a cause's simulations (what refine_parameters sees through
    evaluate.Evaluations): the training error is a known function of the parameters, and every
    point asked for is kept."""

    def __init__(self, error):
        self.error, self.seen = error, []

    def __call__(self, points):
        self.seen += [p for p, _ in points]
        return [self.error(p) for p, _ in points]

    def best(self, realisation):
        best = min(self.seen, key=self.error)
        return best, self.error(best), None


def test_every_parameter_is_fitted_from_the_main_fit():
    # issue 21: a frame softer in pitch than in roll; the main fit left the ratio and the
    # damping at their priors' values (1 and 0.03, 0.17 and 0.22 of their priors' log
    # ranges from the minimum at ratio 0.3, damping 0.05, stiffness 400): the search must
    # get each within its fine step (0.1 of the prior's log range: a factor 2 for the
    # 3-decade ratio, 1.26 for the others)
    mast = causes.get("mast_compliance")
    truth = {"stiffness_n_m_per_rad": 400.0, "pitch_stiffness_ratio": 0.3, "damping_ratio": 0.05}
    parameters = [mast.main, *mast.held]

    def error(values):
        return 1.0 + 40 * sum((p.to_unit(values[p.name]) - p.to_unit(truth[p.name])) ** 2
                              for p in parameters)

    surface = _Surface(error)
    refine_parameters(surface, parameters, mast.parameters(420.0), 0)
    best = min(surface.seen, key=error)
    for p in parameters:
        assert abs(p.to_unit(best[p.name]) - p.to_unit(truth[p.name])) <= REFINE_STEPS[-1] + 1e-9, \
            (p.name, best[p.name])
    # bounded: the start, per pass 2 probes a parameter and a combined move, the profile
    # and as many again per move of it
    assert len(surface.seen) <= 1 + len(REFINE_STEPS) * (2 * 3 + 1) + 2 * 3 * (1 + PROFILE_MOVES)


def test_the_profile_is_taken_around_the_best_point():
    # the minimum lies 0.45 of the prior from the start in frequency: the passes (0.25,
    # then 0.1) end 0.1 short of it and the profile's probe finds it; the profile is then
    # taken again around it, so the fit has a probe either side in every parameter
    mount = causes.get("sensor_mount")
    frequency, damping = mount.main, mount.held[0]
    start = mount.parameters(float(frequency.from_unit(0.3)))
    target = {frequency.name: 0.75, damping.name: damping.to_unit(start[damping.name])}

    def error(values):
        return 1.0 + 40 * sum((p.to_unit(values[p.name]) - target[p.name]) ** 2
                              for p in (frequency, damping))

    surface = _Surface(error)
    refine_parameters(surface, [frequency, damping], start, 0)
    best = min(surface.seen, key=error)
    assert frequency.to_unit(best[frequency.name]) == pytest.approx(0.75)
    for p in (frequency, damping):
        others = {q: v for q, v in best.items() if q != p.name}
        line = [v[p.name] for v in surface.seen
                if {q: x for q, x in v.items() if q != p.name} == others]
        assert min(line) < best[p.name] < max(line), p.name


def _unit_distance(values, centre, cause: str = "mast_compliance") -> float:
    """Squared distance of two of a cause's parameter sets (a frame's unless named) in
    prior coordinates."""
    c = causes.get(cause)
    return sum((p.to_unit(values[p.name]) - p.to_unit(centre[p.name])) ** 2
               for p in (c.main, *c.held))


def _assert_within_the_fine_step(found, truth, cause: str = "mast_compliance") -> None:
    c = causes.get(cause)
    for p in (c.main, *c.held):
        assert abs(p.to_unit(found[p.name]) - p.to_unit(truth[p.name])) <= REFINE_STEPS[-1] + 1e-9, \
            (p.name, found[p.name])


def test_a_frame_fit_is_searched_again_from_its_axes_exchanged():
    # issue 21's anisotropic frame: two basins, the truth's (roll 400 N m/rad, pitch
    # 0.5x), deeper and narrower, and its mirror image (roll 200, pitch 2x), around the
    # main fit (roll 161, pitch 1x).  The axes search alone stays in the mirror's basin;
    # the search from the exchanged axes of where it stopped must reach the truth's
    # within the fine step
    # (the design is left out: this tests the mirror)
    mast = dataclasses.replace(causes.get("mast_compliance"), design=None)
    truth = {"stiffness_n_m_per_rad": 400.0, "pitch_stiffness_ratio": 0.5, "damping_ratio": 0.03}
    image = exchanged_axes(truth)
    assert image["stiffness_n_m_per_rad"] == 200.0 and image["pitch_stiffness_ratio"] == 2.0

    def error(values):
        return min(1.0 + 100 * _unit_distance(values, truth),
                   1.2 + 40 * _unit_distance(values, image))

    start = mast.parameters(161.0)
    alone = _Surface(error)
    refine_parameters(alone, [mast.main, *mast.held], start, 0)
    stop = min(alone.seen, key=error)
    assert _unit_distance(stop, image) < _unit_distance(stop, truth)
    surface = _Surface(error)
    fit_every_parameter(surface, mast, start, 0)
    _assert_within_the_fine_step(min(surface.seen, key=error), truth)


def _fits_without_and_with_design(cause, error, start):
    """The best point fit_every_parameter reaches on the surface `error` from `start`,
    with the cause's design left out and with it."""
    ends = []
    for searched in (dataclasses.replace(cause, design=None), cause):
        surface = _Surface(error)
        fit_every_parameter(surface, searched, start, 0)
        ends.append(min(surface.seen, key=error))
    return tuple(ends)


def test_a_frame_fit_starts_from_the_best_of_a_stiffness_design():
    # issue 21's draw-1003: roll 169 N m/rad, pitch 9.6x; the main fit (ratio 1) ended
    # near the null, in a wide basin around roll 2244, pitch 0.5x (training error 1.72
    # there, 1.35 at the truth, measured).  Neither the search from the main fit nor
    # the one from its mirror reaches the truth's narrow basin; the design's points
    # over both stiffnesses do, and the search from the best of them must end within
    # the fine step
    mast = causes.get("mast_compliance")
    truth = {"stiffness_n_m_per_rad": 169.0, "pitch_stiffness_ratio": 9.6, "damping_ratio": 0.03}
    decoy = {"stiffness_n_m_per_rad": 2244.0, "pitch_stiffness_ratio": 0.5, "damping_ratio": 0.03}

    def error(values):
        return min(1.0 + 100 * _unit_distance(values, truth),
                   1.3 + 20 * _unit_distance(values, decoy))

    assert len(mast.design()) == 16
    without, found = _fits_without_and_with_design(mast, error, mast.parameters(2244.0))
    assert error(without) > 1.25  # stays with the decoy
    _assert_within_the_fine_step(found, truth)


def test_a_floor_fit_starts_from_the_best_of_a_roughness_design():
    # issue 21's draw-1041: a floor of long undulations (0.38 mm RMS, 0.153 m correlation
    # length) was fitted at the main fit's correlation length (0.05 m) as a nearly flat
    # floor (0.064 mm; training error 2.98, measured) and the search from there stayed;
    # at the truth's parameters the realisations tried score 1.4-2.3.  The design's points
    # over both parameters reach the truth's basin, and the search from the best of them
    # must end within the fine step.  (The design's levels are the frame's, 4 per
    # parameter; one of them lies near this truth, so the surface's truth is put between
    # levels: 0.6 mm, 0.11 m)
    rough = causes.get("ground_roughness")
    truth = {"height_rms_m": 6e-4, "correlation_length_m": 0.11}
    decoy = {"height_rms_m": 6.4e-5, "correlation_length_m": 0.05}

    def error(values):
        return min(1.4 + 20 * _unit_distance(values, truth, "ground_roughness"),
                   2.9 + 5 * _unit_distance(values, decoy, "ground_roughness"))

    assert len(rough.design()) == 16
    without, found = _fits_without_and_with_design(rough, error, decoy)
    assert error(without) > 2.5  # stays with the decoy
    _assert_within_the_fine_step(found, truth, "ground_roughness")


def test_one_seed_is_one_floor_at_every_correlation_length():
    # The fit probes the correlation length with its chosen realisation (seed) held, so
    # a seed must be the same bumps smoothed more or less, not another floor.  Gaussian
    # filters of widths s1, s2 over one white field correlate at 2 s1 s2 / (s1^2 + s2^2)
    # in two dimensions: 0.984 for 0.05 m against 0.06 m, 0.6 for 0.05 m against 0.15 m;
    # 0.95 and 0.5 leave room for the kernels' truncation and the subsampling.  Another
    # seed is another floor (independent fields: correlation ~0, |r| < 0.1 for 10^4
    # and more samples).
    from skidsteer.diagnosis.causes.ground_roughness import fine_intervals, surface

    half_m = 1.5  # a 3 m square
    fine_steps = fine_intervals(half_m)

    def shared(a, b):  # the two grids' common points (each keeps every
        # fine_steps / (n - 1)-th fine sample)
        strides = [fine_steps // (len(x) - 1) for x in (a, b)]
        common = int(np.lcm(*strides))
        return [x[::common // k, ::common // k].ravel() for x, k in zip((a, b), strides)]

    floor = surface(3e-4, 0.05, half_m, seed=3)
    assert floor.std() == pytest.approx(3e-4) and abs(floor.mean()) < 1e-12
    assert np.corrcoef(*shared(floor, surface(3e-4, 0.06, half_m, seed=3)))[0, 1] > 0.95
    assert np.corrcoef(*shared(floor, surface(3e-4, 0.15, half_m, seed=3)))[0, 1] > 0.5
    assert abs(np.corrcoef(floor.ravel(), surface(3e-4, 0.05, half_m, seed=4).ravel())[0, 1]) < 0.1


def test_a_cause_whose_design_beats_its_main_fit_is_refined_whatever_its_rank():
    fits = [_fit(name, held) for name, held in (("a", 1.5), ("b", 1.8), ("c", 2.0), ("d", 2.2))]
    assert contenders(fits) == list(range(REFINE_CONTENDERS))
    fits[3].design_better = True
    assert contenders(fits) == [*range(REFINE_CONTENDERS), 3]


def test_an_interval_open_on_one_side_reaches_the_prior():
    p = causes.get("mast_compliance").held[1]  # pitch_stiffness_ratio, 0.1-100
    # the error rises to the right only: the left side is not bounded by the data
    lo, hi = interval([(0.5, 1.0), (1.0, 1.0), (2.0, 3.0)], 6, p)
    assert lo == p.low and 1.0 < hi < 2.0
    # nothing was evaluated below 0.5: open for want of a probe, which the fit records
    assert unprobed_sides([(0.5, 1.0), (1.0, 1.0), (2.0, 3.0)], p, (lo, hi)) == ["below"]
    # probed down to the prior's bound and still inside: the data leave it open (the
    # bound as refine_parameters' clipped probes reach it, from_unit(0), which may differ
    # from p.low in its last digit)
    at_bound = [(float(p.from_unit(0.0)), 1.0), (0.5, 1.0), (1.0, 1.0), (2.0, 3.0)]
    assert interval(at_bound, 6, p)[0] == p.low
    assert unprobed_sides(at_bound, p, interval(at_bound, 6, p)) == []
    # and an interval open above for want of a probe (nothing evaluated past 2)
    rising_left = [(0.5, 3.0), (1.0, 1.0), (2.0, 1.0)]
    assert unprobed_sides(rising_left, p, interval(rising_left, 6, p)) == ["above"]
    # one point, inside the prior: open both ways, for want of any probe
    assert unprobed_sides([(1.0, 1.0)], p, interval([(1.0, 1.0)], 6, p)) == ["below", "above"]
    # the report says so after the interval
    from skidsteer.diagnosis.intervals import unprobed_note
    assert unprobed_note(["below", "above"]) == "; not probed below or above"
    assert unprobed_note([]) == unprobed_note(None) == ""


def test_an_interval_follows_a_quadratic_profile_between_the_probes():
    # E^2 = 1 + 50 u^2 around a fit at 0.3 of the damping prior's log range, probed a
    # tenth of the prior apart (refine_parameters' profile): with 9 training runs the
    # bound E^2 <= 10/9 lies at u = +-0.047, inside the probes; a straight line between
    # the fit and a probe (E^2 1.5) would put it at +-0.022 (issue 21's too-narrow
    # intervals).  Exact for a quadratic, to rounding.
    p = causes.get("mast_compliance").held[0]
    assert p.log
    points = [(p.from_unit(0.3 + du), float(np.sqrt(1 + 50 * du ** 2))) for du in (-0.1, 0, 0.1)]
    lo, hi = interval(points, 9, p)
    half = np.sqrt((1 / 9) / 50)
    assert p.to_unit(lo) == pytest.approx(0.3 - half, abs=1e-9)
    assert p.to_unit(hi) == pytest.approx(0.3 + half, abs=1e-9)


def test_an_interval_is_read_against_the_fits_own_start_to_start_scatter():
    p = causes.get("friction_levels").main  # mu_static, 0.4-1.2, linear
    # one evaluation per value (one start each) on a noisy plateau that rises steeply at
    # 0.56; the fit is the luckiest draw, 2.18 at 0.495 (issue 21's draw 1204: its
    # training errors at these values, from one start each, measured with a profile
    # study script since removed; the fit's five starts are below)
    profile = [(0.40, 2.80), (0.45, 2.89), (0.47, 2.41), (0.48, 2.48), (0.495, 2.18),
               (0.52, 2.45), (0.56, 4.59), (0.64, 4.94)]
    lucky = interval(profile, 6, p)
    assert lucky[0] > 0.48 and lucky[1] < 0.52  # only the lucky draw's neighbourhood
    starts = [2.18, 2.21, 2.10, 3.15, 3.08]  # the fit's training error from each start
    bound = interval_bound(starts, 2.18, 6)
    e2 = np.square(starts)
    assert bound == pytest.approx(np.median(e2) * 7 / 6 + np.std(e2, ddof=1))
    low, high = interval(profile, 6, p, bound)
    assert low == p.low and 0.52 < high < 0.56  # the plateau, open below: 0.4 is inside
    # a fit whose starts agree keeps the single-start bound, and the bound never falls
    # below it (a start-0 draw worse than the others' median)
    assert interval_bound([1.5] * 5, 1.5, 6) == pytest.approx(1.5 ** 2 * profile_factor(6))
    assert interval_bound([2.0, 1.2, 1.2, 1.2, 1.2], 2.0, 6) == pytest.approx(
        4.0 * profile_factor(6))
    # an evaluation that is a median over 4 starts scatters about half as much
    assert interval_bound(starts, 2.18, 6, search_starts=4) == pytest.approx(
        np.median(e2) * 7 / 6 + np.std(e2, ddof=1) / 2)


class _RealisedSurface:
    """A stand-in for evaluate.Evaluations over a random geometry: the training error a
    known function of the parameters and the realisation, every point asked for kept,
    what search._result reads answered from it."""

    def __init__(self, error, n_train: int = 6):
        self.error, self.train, self.done = error, np.arange(n_train), {}

    def __call__(self, points):
        for params, r in points:
            self.done[(parameter_key(params), int(r))] = (self.error(params, r), None)
        return [self.error(params, r) for params, r in points]

    best = Evaluations.best
    profile = Evaluations.profile

    def complete(self, params, realisation):
        return None

    def held_out_error(self, params, realisation, held):
        return self.error(params, realisation)

    def factory(self, params, realisation):
        return None


def _run_out_fit(surface, unit: float, realisation: int):
    """A wheel run-out's fit at `unit` of its prior and `realisation`, as fit_cause leaves
    it (the point evaluated on the surface)."""
    cause = causes.get("wheel_eccentricity")
    params = cause.parameters(float(cause.main.from_unit(unit)))
    error = surface([(params, realisation)])[0]
    return Fit(cause.name, params, cause.main.name, (0.0, 1.0), error, error, error, None, [],
               realisation=realisation, intervals={cause.main.name: (0.0, 1.0)},
               evaluator=surface)


def test_a_random_geometry_is_chosen_again_where_its_fit_ended():
    # fit_cause chose realisation 0 at the coarse grid's best value, where it fits best;
    # realisation 5 has a deeper minimum 0.12 of the prior above it (wheels at other
    # phases need a larger run-out), within the one fine step (0.1) either side the choice
    # reads plus Brent's bracket around it: the fit must move to realisation 5 and end
    # within Brent's tolerance (1 % of the prior) of its minimum, its training error the
    # deeper one
    main = causes.get("wheel_eccentricity").main
    minima = {0: (0.40, 1.30), 5: (0.52, 1.00)}  # realisation -> (unit, error there)

    def error(params, r):
        u0, e0 = minima.get(r, (0.40, 1.60))
        return e0 + 30 * (main.to_unit(params[main.name]) - u0) ** 2

    surface = _RealisedSurface(error)
    fit = rechoose_realisation(_run_out_fit(surface, 0.40, 0), np.arange(3))
    assert fit.realisation == 5
    assert abs(main.to_unit(fit.parameters[main.name]) - 0.52) <= 0.01
    assert fit.train_error < 1.01
    # where no other realisation fits better, the fit is kept as it was
    minima[5] = (0.52, 1.40)
    surface = _RealisedSurface(error)
    kept = _run_out_fit(surface, 0.40, 0)
    assert rechoose_realisation(kept, np.arange(3)) is kept


def test_a_random_geometrys_interval_holds_what_other_realisations_fit():
    # the data tell a run-out only as well as they tell the wheels' phases: a value
    # another realisation fits within the bound widens the interval; one above the bound,
    # or at other values of the other parameters (a floor's correlation length), does not
    main = causes.get("wheel_eccentricity").main
    surface = _RealisedSurface(lambda params, r: 0.0)
    fit = _run_out_fit(surface, 0.5, 0)
    surface.done = {
        ((("eccentricity_m", 5e-4),), 3): (1.1, None),   # inside a bound of 1.5 (E^2 1.21)
        ((("eccentricity_m", 9e-4),), 4): (1.3, None),   # outside (E^2 1.69)
        ((("eccentricity_m", 1e-4),), 0): (1.0, None),   # the fit's own realisation
    }
    assert over_realisations(surface, fit, 1.5, (2e-4, 3e-4)) == (2e-4, 5e-4)
    assert over_realisations(surface, fit, 1.8, (2e-4, 3e-4)) == (2e-4, 9e-4)
    roughness = causes.get("ground_roughness")
    floor = dataclasses.replace(fit, cause=roughness.name, main=roughness.main.name,
                                parameters=roughness.parameters(3e-4))
    surface.done = {((("correlation_length_m", 0.08), ("height_rms_m", 6e-4)), 2): (1.0, None),
                    ((("correlation_length_m", 0.05), ("height_rms_m", 1e-4)), 2): (1.0, None)}
    assert over_realisations(surface, floor, 1.5, (2e-4, 4e-4)) == (1e-4, 4e-4)


def test_generated_truths_draw_the_held_parameters_from_their_priors():
    mast = causes.get("mast_compliance")
    _, values = truth_edit("mast_compliance", None, np.random.default_rng(1), held="prior")
    assert all(p.low <= values[p.name] <= p.high for p in (mast.main, *mast.held))
    assert any(values[p.name] != p.value for p in mast.held)
    _, fixed = truth_edit("mast_compliance", None, np.random.default_rng(1))
    assert all(fixed[p.name] == p.value for p in mast.held)


def test_repeat_trials_start_where_a_swivel_left_the_robot():
    m = load_model(Setup(build="extended", floor="concrete"))
    parts = roles_of(m)
    base = m.jnt_qposadr[np.flatnonzero(m.jnt_type == mujoco.mjtJoint.mjJNT_FREE)[0]]
    wheel = {side: [m.jnt_qposadr[w.joint] for w, s in zip(parts.wheels, parts.wheel_side)
                    if s == sign] for side, sign in (("left", 1), ("right", -1))}
    assert len(wheel["left"]) == len(wheel["right"]) == 2
    starts = []
    for seed in (1, 2):
        d = mujoco.MjData(m)
        mujoco.mj_setState(m, d, trial_start(m, np.random.default_rng(seed), settle_s=1.0),
                           FULLPHYSICS)
        left, right = d.qpos[wheel["left"]], d.qpos[wheel["right"]]
        # a swivel turns the sides opposite ways and a side's wheels alike (within the
        # settling's creep: 0.01 rad is 1 mm at the rim, far above a settled wheel's)
        assert np.allclose(left, left[0], atol=0.01) and np.allclose(right, right[0], atol=0.01)
        assert abs(left[0] + right[0]) < 0.01
        assert np.abs(d.qvel).max() < 0.05  # settled: at rest on its tires
        w, z = d.qpos[base + 3], d.qpos[base + 6]  # the base's quaternion (nearly a yaw)
        starts.append((2 * np.arctan2(z, w), right[0]))  # (yaw, wheel angle)
    (yaw_a, wheel_a), (yaw_b, wheel_b) = starts
    assert abs(np.angle(np.exp(1j * (yaw_a - yaw_b)))) > 0.01  # drawn, not always 0
    assert abs(np.angle(np.exp(1j * (wheel_a - wheel_b)))) > 0.01


def test_simulated_starts_are_drawn_kept_apart_and_stored_apart(tmp_path):
    # the verdict's errors are medians over STARTS simulated starts: start 0 is the robot
    # at rest as built (what one simulation always was), start k > 0 a repeat-trial start
    # of its own, drawn as synth draws a dataset's trials (another yaw and wheel angle,
    # and the tires' residual deflections: without them the starts on a flat floor are
    # copies); the cache must not hand one start's run out for another's
    from skidsteer.data.dataset import Group
    from skidsteer.diagnosis.comparison import (START_SEED, simulate_groups,
                                                start_state)
    from skidsteer.robot import tire
    from skidsteer.simulation.cache import SimulationCache
    from skidsteer.simulation.run import TRIAL_DEFLECTION_M, trial_start

    m = load_model()

    def started(state):
        d = mujoco.MjData(m)
        mujoco.mj_setState(m, d, state, FULLPHYSICS)
        return d, tire.TireState(m, d.plugin_state, tire.instance_id(m))

    (turned, turned_tires), (at_rest, _) = (started(start_state(m, k, settle_s=0.5))
                                            for k in (1, 0))
    assert np.abs(turned.qpos[:7] - at_rest.qpos[:7]).max() > 0.01  # another yaw at least
    bare, bare_tires = started(trial_start(m, np.random.default_rng([START_SEED, 1]), 0.5))
    np.testing.assert_array_equal(bare.qpos, turned.qpos)  # that draw's yaw and wheel angle
    # one N(0, 0.1 mm) draw per wheel and direction: the largest of 8 is above 0.1 sigma
    # unless all 8 fall inside +-0.1 sigma (probability 0.08^8), and below 5 sigma
    moved = np.abs(turned_tires.deflection - bare_tires.deflection).max()
    assert 0.1 * TRIAL_DEFLECTION_M < moved < 5 * TRIAL_DEFLECTION_M
    np.testing.assert_array_equal(turned_tires.velocity, bare_tires.velocity)  # only the
    np.testing.assert_array_equal(turned_tires.stuck, bare_tires.stuck)  # deflections drawn
    again, _ = started(start_state(m, 1, settle_s=0.5))
    np.testing.assert_array_equal(again.plugin_state, turned.plugin_state)  # seeded
    factory, group = model_factory(), Group(0.0, 30.0, Setup())
    cache = SimulationCache(tmp_path)
    default, first = simulate_groups([(factory, [group])] * 2, 8.0, starts=[0, 1], cache=cache)
    alone = simulate_groups([(factory, [group])], 8.0)[0]
    # start 0 is the default
    assert np.array_equal(default.features, alone.features, equal_nan=True)
    assert not np.array_equal(default.features, first.features, equal_nan=True)
    stored = simulate_groups([(factory, [group])] * 2, 8.0, starts=[1, 0], cache=cache,
                             signals=False)
    assert cache.stores == 2 and cache.hits == 2
    assert np.array_equal(stored[0].features, first.features, equal_nan=True)
    assert np.array_equal(stored[1].features, default.features, equal_nan=True)
    with pytest.raises(ValueError, match="2 starts for 1 jobs"):
        simulate_groups([(factory, [group])], 8.0, starts=[0, 1])


@pytest.mark.slow
def test_the_search_reads_the_median_over_its_starts(tmp_path, monkeypatch):
    # diagnose --search-starts N: a fit's training error is the median over starts
    # 0..N-1 (as the held-out error is over STARTS), the simulation it keeps is start 0's;
    # N = 1 (the default) is the start from rest alone, the search as it always was
    from skidsteer.data.dataset import Group
    from skidsteer.diagnosis import comparison as comparison_module
    from skidsteer.diagnosis import evaluate as evaluate_module
    from skidsteer.diagnosis import search as search_module
    from skidsteer.diagnosis.comparison import simulate_groups
    from skidsteer.diagnosis.evaluate import Evaluations
    from skidsteer.diagnosis.search import FIT_SEED
    from skidsteer.simulation.backends import LocalBackend
    from skidsteer.simulation.cache import SimulationCache

    slip = causes.get("slip_lambda_max")
    groups = [Group(0.0, 30.0, Setup()), Group(0.0, 45.0, Setup())]
    params = slip.parameters(float(slip.main.from_unit(0.5)))
    factory = model_factory(slip.edit(params, FIT_SEED), None)
    starts = simulate_groups([(factory, groups)] * 3, 8.0, starts=[0, 1, 2])
    # "measured": two runs per command, the three starts' features scaled a little
    rng = np.random.default_rng(5)
    measured = np.concatenate([s.features * np.exp(rng.normal(0, 0.05, s.features.shape))
                               for s in starts[:2]])[[0, 2, 1, 3]]
    comp = Comparison(dataclasses.replace(_observed(measured, [0, 0, 1, 1]), groups=groups))
    train = np.arange(4)
    per_start = [comp.error(s.features, train) for s in starts]
    assert len(set(per_start)) == 3  # the starts differ, so the median is one of them
    cache = SimulationCache(tmp_path)
    for n in (1, 3):
        evaluate = Evaluations(slip, comp, groups, 8.0, train, None, SensorChain(),
                                LocalBackend(2), None, cache, n)
        assert evaluate([(params, FIT_SEED)]) == [float(np.median(per_start[:n]))]
        kept = evaluate.best(FIT_SEED)[2]
        assert np.array_equal(kept.features, starts[0].features, equal_nan=True)
    assert cache.stores == 3 * len(groups)  # start 0 simulated once, reused by N = 3
    # the fit's scatter (with_start_scatter) reads the search's 3 starts and simulates
    # only the other STARTS - 3, without the cache too
    evaluate.stored = None
    simulated = []
    monkeypatch.setattr(evaluate_module, "simulate_groups",
                        lambda jobs, *a, **k: simulated.extend(k["starts"])
                        or comparison_module.simulate_groups(jobs, *a, **k))
    fit = search_module.Fit("slip_lambda_max", params, "lambda_max", (0.0, 1.0),
                            evaluate.done[next(iter(evaluate.done))][0], 1.0, 1.0, kept, [],
                            factory=factory, evaluator=evaluate)
    scattered = search_module.with_start_scatter(fit)
    assert sorted(simulated) == list(range(3, STARTS))
    assert scattered.train_errors_over_starts[:3] == pytest.approx(per_start)
    assert len(scattered.train_errors_over_starts) == STARTS


def test_the_main_parameter_search_runs_to_its_tolerance(monkeypatch):
    # issue 21's draw 1166: the training error falls off a cliff just below the truth and
    # rises slowly above it, so the grid's best point sits on the valley's shoulder; Brent
    # stopped after 4 steps left the fit there (here 0.033 of the prior's range from the
    # floor), run to its tolerance it ends within REFINE_TOL_UNIT of it.  A made-up
    # surface stands in for the simulations (the slip cause's prior and search as they are)
    from skidsteer.diagnosis import evaluate as evaluate_module
    from skidsteer.diagnosis import search as search_module

    slip = causes.get("slip_lambda_max")
    floor_unit = 0.42  # between the grid's 0.3 and 0.5: no grid point lands in the valley

    def surface(unit: float) -> float:
        return 4.5 if unit < floor_unit - 0.01 else 1.4 + 2.5 * abs(unit - floor_unit) ** 0.7

    class Surface(evaluate_module.Evaluations):
        def __init__(self, cause, comparison, groups, duration_s, train, *rest):
            self.cause, self.train, self.done = cause, train, {}

        def __call__(self, points):
            keys = [(evaluate_module.parameter_key(p), int(r)) for p, r in points]
            for (params, _), key in zip(points, keys):
                unit = float(slip.main.to_unit(params[slip.main.name]))
                self.done.setdefault(key, (surface(unit), None))
            return [self.done[k][0] for k in keys]

        def complete(self, params, realisation):
            return None

        def held_out_error(self, params, realisation, held):
            return 1.0

        def factory(self, params, realisation):
            return None

    monkeypatch.setattr(search_module, "Evaluations", Surface)
    fitted = search_module.fit_cause(slip, None, [], 1.0, np.arange(6), np.arange(0), None,
                                     SensorChain(), None, None)
    unit = float(slip.main.to_unit(fitted.parameters[slip.main.name]))
    assert abs(unit - floor_unit) <= search_module.REFINE_TOL_UNIT
    assert len(fitted.evaluations) > search_module.GRID_POINTS + 4  # more than the old budget


def test_the_error_over_starts_is_not_moved_by_one_start_in_another_regime():
    # issue 21's draw-1071: from one of five starts a simulation lands in a rare regime
    # 14 trial spreads away in two bands; the error over starts is their median, so one
    # such start of STARTS (and, with 5, two) leaves it where the others put it
    from skidsteer.diagnosis.comparison import Simulated

    rng = np.random.default_rng(4)
    measured = np.exp(rng.normal(-8, 0.05, (6, N_POWER + 1)))
    measured[:, -1] = 0.01
    comp = Comparison(_observed(measured, [0, 0, 0, 1, 1, 1]))
    typical = measured[[0, 3]] - np.r_[comp.floor, 0.0]
    typical[:, :N_POWER] = np.maximum(typical[:, :N_POWER], 1e-12)
    runs = np.arange(6)

    def sim(features):
        return Simulated([None] * 2, [None] * 2, [0.0] * 2, features)

    rare = typical.copy()
    rare[:, :4] *= 10.0 ** 1.4  # 1.4 decades up in four bands: 14 trial spreads of 0.1
    usual = [sim(typical * (1 + 0.01 * k)) for k in range(STARTS - 2)]
    assert STARTS >= 5
    with_rare = median_error(comp, [sim(rare), sim(rare), *usual], runs)
    assert with_rare in [comp.error(u.features, runs) for u in usual]
    assert comp.error(rare, runs) > 3 * with_rare  # what one start alone would have said


def test_the_trials_spread_needs_three_degrees_of_freedom():
    # issue 21, stop 44: datasets the model itself simulated, with 1 or 2 degrees of
    # freedom in their trials' spread, scored 2.0-6.1, above the no-discrepancy limit
    from skidsteer.diagnosis.comparison import MIN_SPREAD_DOF, require_spread

    assert MIN_SPREAD_DOF == 3  # Student's t has a finite variance from 3 on
    setup = Setup(build="extended", floor="concrete")
    groups = [Group(0.0, w, setup) for w in (15.0, 30.0, 45.0)]

    def observed(groups_of_runs):
        obs = _observed(np.ones((len(groups_of_runs), N_POWER + 1)), groups_of_runs)
        return dataclasses.replace(obs, groups=groups[:max(groups_of_runs) + 1])

    for runs, dof in (([0, 0], 1), ([0, 0, 0], 2), ([0, 0, 1, 1], 2), ([0, 1, 2], 0)):
        assert observed(runs).spread_dof() == dof
        with pytest.raises(ValueError) as err:
            require_spread(observed(runs), "runs/")
        # the place, the count, each command's trials and what to record
        assert str(err.value).startswith(f"runs/: the trials' spread rests on {dof} ")
        assert "v0-w15 concrete extended x " in str(err.value)
        assert "1 command x 4" in str(err.value)
    for runs in ([0, 0, 0, 0], [0, 0, 1, 1, 2, 2], [0, 0, 1, 1, 1]):
        require_spread(observed(runs))  # 3 degrees of freedom or more: judged


def test_too_few_repeated_trials_is_a_clear_error_before_any_simulation(tmp_path, capsys):
    from skidsteer.cli import main

    data = tmp_path / "two-trials"
    make_dataset(data, None, seed=5, omegas=(30.0,), trials=2, duration_s=8.0,
                 file_format="csv")
    out = tmp_path / "out"
    assert main(["diagnose", str(data), "--out", str(out), "--no-progress"]) == 2
    error = capsys.readouterr().err
    assert str(data) in error and "rests on 1 repeated trial" in error
    cache = out / ".skidsteer-cache"
    assert not cache.exists() or not any(cache.iterdir())  # nothing was simulated


# ------------------------------------------------------------------ verdict rules

def _fit(name, held, score=None):
    return diagnosis.Fit(name, {"p": 1.0}, "p", (0.9, 1.1), held, held,
                         held ** 2 if score is None else score, None, [])


def _judge(base_error, base_held, fits, noise):
    """verdict with the base model's training error at its all-runs error: the training
    runs tell every fit below it apart (the rules other than told_from_base)."""
    return diagnosis.verdict(base_error, base_held, fits, noise, base_train=base_error,
                             n_train=6)


def test_verdict_rules():
    z = diagnosis.Z_CONSISTENT
    assert _judge(z - 0.1, 1.0, [], noise=1.0)[0] == "no-discrepancy"
    # the best candidate removes most of a large discrepancy but leaves more than
    # Z_EXPLAINED: named as the most likely cause, not failed by the absolute limit
    # ((8^2 - 3.5^2) / (8^2 - 1) = 82 %)
    result, named, reason = _judge(8.0, 8.0, [_fit("a", diagnosis.Z_EXPLAINED + 0.5)],
                                   noise=1.0)
    assert result == "partly-explained" and named.cause == "a" and "82%" in reason
    # ... unless it removes less than half: (8^2 - 6^2) / 63 = 44 %
    assert _judge(8.0, 8.0, [_fit("a", 6.0)], noise=1.0)[:2] == ("unexplained", None)
    # ... or a rival removes about as much
    assert _judge(8.0, 8.0, [_fit("a", 3.5), _fit("b", 3.6)], noise=1.0)[:2] \
        == ("unexplained", None)
    # consistent, but removing less than half of the discrepancy over the trial noise:
    # (2.5^2 - 2.1^2) / (2.5^2 - 1^2) = 35 %
    assert _judge(2.5, 2.5, [_fit("a", 2.1)], noise=1.0)[0] == "unexplained"
    # the same extension against a base error twice as large removes 84 %
    assert _judge(5.0, 5.0, [_fit("a", 2.1)], noise=1.0)[0] == "explained"
    # a discrepancy on the training runs only: the held-out runs are within the
    # no-discrepancy limit (1.9), so they cannot confirm what would otherwise be named
    # ((1.9^2 - 1.2^2) / (1.9^2 - 1) = 83 % removed, the runner-up far behind)
    result, named, reason = _judge(3.0, z - 0.1, [_fit("a", 1.2), _fit("b", 3.0)], noise=1.0)
    assert (result, named) == ("unexplained", None) and "cannot confirm" in reason
    assert _judge(3.0, z + 0.1, [_fit("a", 1.2), _fit("b", 3.0)], noise=1.0)[0] == "explained"
    # ... and its reason names what the training runs rank first, not the held-out best
    # (issue 21's draws 1068 and 1187: the held-out best was another cause, the training
    # runs' lead the hidden one), or says that they tell none from the base model
    fits = [_fit("a", 1.2), _fit("b", 3.0)]
    fits[0].train_error, fits[1].train_error = 2.2, 1.5
    assert "the training runs point to b (training error 3.00 -> 1.50)" in _judge(
        3.0, z - 0.1, fits, noise=1.0)[2]
    fits[0].train_error, fits[1].train_error = 2.95, 2.9  # 3^2 < 2.9^2 (1 + 1/6)
    assert "the training runs tell no candidate from the base model" in _judge(
        3.0, z - 0.1, fits, noise=1.0)[2]
    # the same, but the held-out runs are repeat trials of the trained commands (fewer
    # than three commands): they cannot confirm it either
    result, named, reason = diagnosis.verdict(
        3.0, z + 0.1, [_fit("a", 1.2), _fit("b", 3.0)], 1.0, base_train=3.0, n_train=6,
        held_out_new_commands=False)
    assert (result, named) == ("unexplained", None) and "repeat the commands" in reason
    assert "a third command" in reason and "a," in reason
    # two candidates equally good
    assert _judge(8.0, 8.0, [_fit("a", 1.2), _fit("b", 1.25)], noise=1.0)[0] \
        == "unexplained"
    result, named, _ = _judge(8.0, 8.0, [_fit("a", 1.2), _fit("b", 5.0)], noise=1.0)
    assert result == "explained" and named.cause == "a"
    # most of a small discrepancy removed ((1.6^2 - 1.1^2) / (1.6^2 - 1) = 87 %), but the
    # score with the fitted parameters' penalty (2.7) does not beat the base model's
    # (1.6^2 = 2.56): the held-out runs do not support the extension
    assert _judge(3.0, 1.6, [_fit("a", 1.1, 2.7), _fit("b", 1.5, 2.8)],
                  noise=1.0)[:2] == ("unexplained", None)
    # the runner-up closes more than 3/4 of a large gap ((5.5^2 - 2.5^2) / (5.5^2 - 1.6^2)
    # = 87 %), but the held-out runs tell the two apart: the best is consistent with them
    # and the runner-up is not
    result, named, _ = _judge(5.5, 5.5, [_fit("a", 1.6), _fit("b", 2.5)], noise=1.0)
    assert result == "explained" and named.cause == "a"
    # ... not when a third candidate is consistent with them too (a worse score: more
    # parameters)
    assert _judge(5.5, 5.5, [_fit("a", 1.6), _fit("b", 2.5), _fit("c", 1.9, 7.0)],
                  noise=1.0)[0] == "unexplained"
    # ... nor when both are consistent and close (the 3/4 rule decides: 0.56 < 0.75)
    assert _judge(2.5, 2.5, [_fit("a", 1.8), _fit("b", 1.95)], noise=1.0)[0] \
        == "unexplained"
    # most of the held-out discrepancy removed and told apart from the others, but the
    # training runs do not tell the fit from the base model: its training error (1.83)
    # leaves the base model's (1.88) inside its profile bound (1.83 sqrt(7/6) = 1.98)
    # (issue 21's draw 1106, an unbalanced fan named slip_lambda_max at 0.087 for 0.1)
    fits = [_fit("a", 1.86), _fit("b", 2.57)]
    fits[0].train_error = 1.83
    assert diagnosis.verdict(2.13, 2.55, fits, noise=0.7, base_train=1.88, n_train=6)[:2] \
        == ("unexplained", None)
    assert "training runs do not tell" in diagnosis.verdict(
        2.13, 2.55, fits, noise=0.7, base_train=1.88, n_train=6)[2]
    # ... where a base training error outside the bound names it
    result, named, _ = diagnosis.verdict(2.13, 2.55, fits, noise=0.7, base_train=2.1,
                                         n_train=6)
    assert result == "explained" and named.cause == "a"

    # a runner-up as close held-out (1.64 against 1.37: a gap of 0.81 in score, under a
    # quarter of the base model's excess, 2.06; both within 2 sigma) is no rival when the
    # training runs do not tell it from the base model: its training error, 2.14, is the
    # base model's 2.07 or worse (issue 21's draw 1177, friction_levels beside a mast at
    # the prior's stiffest)
    fits = [_fit("a", 1.37), _fit("b", 1.64)]
    fits[0].train_error, fits[1].train_error = 1.43, 2.14
    result, named, reason = diagnosis.verdict(2.11, 3.18, fits, noise=0.89, base_train=2.07,
                                              n_train=6)
    assert result == "explained" and named.cause == "a"
    assert "runner-up b reaches 1.64, but the training runs do not tell it" in reason
    # ... and is one when they do (training error 1.60: 2.07 is outside its bound, 1.73)
    fits[1].train_error = 1.60
    result, named, reason = diagnosis.verdict(2.11, 3.18, fits, noise=0.89, base_train=2.07,
                                              n_train=6)
    assert (result, named) == ("unexplained", None) and "about equally well" in reason

    # the held-out runs name the run-out (1.55, the floor 3.40: separated), but the
    # training runs rank the floor first: training scores 1.42^2 + 2 (2 + ln 8) / 6 = 3.38
    # against 1.77^2 + 2 (1 + ln 8) / 6 = 4.16 (issue 21's draw 1126, a rough floor named
    # a run-out; the parameters' penalty counts: the floor pays for one more)
    fits = [_fit("wheel_eccentricity", 1.55, 3.44), _fit("ground_roughness", 3.40, 12.90)]
    fits[0].intervals = {"eccentricity_m": (0.0, 1.0)}
    fits[1].intervals = {"height_rms_m": (0.0, 1.0), "correlation_length_m": (0.0, 1.0)}
    fits[0].train_error, fits[1].train_error = 1.77, 1.42
    result, named, reason = diagnosis.verdict(7.21, 8.40, fits, noise=0.98, base_train=6.52,
                                              n_train=6)
    assert (result, named) == ("unexplained", None)
    assert "training runs prefer ground_roughness" in reason
    # ... where the floor's training error is 1.70 its score (4.25) is above the run-out's:
    # the run-out is named, though its training error is higher
    fits[1].train_error = 1.70
    result, named, _ = diagnosis.verdict(7.21, 8.40, fits, noise=0.98, base_train=6.52,
                                         n_train=6)
    assert result == "explained" and named.cause == "wheel_eccentricity"


def test_gain_counts_the_discrepancy_beyond_the_trial_noise():
    # a perfect extension (at the noise) removes all of it, even against a base error
    # below twice the noise, where the plain RMS ratio could never reach 50 %
    assert diagnosis.gain(1.8, 1.0, noise=1.0) == pytest.approx(1.0)
    assert diagnosis.gain(3.0, 3.0, noise=1.0) == 0.0
    assert diagnosis.gain(3.0, 2.0, noise=1.0) == pytest.approx(5 / 8)
    # below the noise by chance: capped; a base model within the noise: nothing to remove
    assert diagnosis.gain(3.0, 0.5, noise=1.0) == 1.0
    assert diagnosis.gain(0.9, 0.5, noise=1.0) == 0.0


def test_noise_error_is_the_trials_own_scatter():
    rng = np.random.default_rng(4)
    logs = rng.normal(-6.0, 0.3, (40, N_POWER + 1))  # 0.3 decade scatter, above the floor
    features = 10.0 ** logs
    features[:, -1] = rng.normal(0.05, 0.02, 40)
    comp = Comparison(_observed(features, [i // 4 for i in range(40)]))
    assert comp.noise_error() == pytest.approx(1.0)  # spread == scale for every feature
    # where the floor exceeds the spread, a perfect simulation scores below 1
    quiet = 10.0 ** rng.normal(-6.0, 0.01, (40, N_POWER + 1))
    quiet[:, -1] = 0.05
    assert Comparison(_observed(quiet, [i // 4 for i in range(40)])).noise_error() < 0.2


def test_trial_spread_counts_a_feature_only_where_it_is_scored():
    # a wheel-order feature is NaN in groups whose window holds no revolution; its
    # spread must come from the groups that score it, not collapse to zero
    rng = np.random.default_rng(5)
    features = 10.0 ** rng.normal(-6.0, 0.5, (9, N_POWER + 1))
    features[:3, 0] = np.nan  # group 0 does not score feature 0
    comp = Comparison(_observed(features, [0, 0, 0, 1, 1, 1, 2, 2, 2]))
    logs = np.log10(features[3:, 0]).reshape(2, 3)
    pooled = np.sqrt(((logs - logs.mean(axis=1, keepdims=True)) ** 2).sum() / 4)
    assert comp.observed.trial_spread()[0] == pytest.approx(pooled)
    assert comp.observed.trial_spread()[0] > 0.2


@pytest.mark.slow
def test_a_hold_out_the_dataset_lacks_is_a_clear_error_before_any_simulation(tmp_path,
                                                                             capsys):
    from skidsteer.cli import main

    data = tmp_path / "three"
    make_dataset(data, None, seed=5, omegas=(20.0, 30.0, 40.0), trials=2, duration_s=8.0,
                 file_format="csv")
    out = tmp_path / "out"
    assert main(["diagnose", str(data), "--out", str(out), "--no-progress",
                 "--hold-out", "v0-w45"]) == 2
    error = capsys.readouterr().err
    assert str(data) in error and "'v0-w45'" in error and "v0-w20 concrete extended" in error
    cache = out / ".skidsteer-cache"
    assert not cache.exists() or not any(cache.iterdir())  # nothing was simulated


def test_missing_dataset_is_a_clear_error(tmp_path, capsys):
    from skidsteer.cli import main

    assert main(["diagnose", str(tmp_path / "nowhere"), "--out", str(tmp_path / "o")]) == 2
    assert "nowhere" in capsys.readouterr().err


# ------------------------------------------------------------------ hidden effects

@pytest.fixture(scope="module")
def hidden(tmp_path_factory):
    return hidden_diagnoses(tmp_path_factory)


def test_the_rivals_are_the_benchmarks_most_frequent_runners_up(tmp_path):
    # the newest row of a draw counts (draw-2's first row is replaced), the causes
    # ranked right beside the effect are counted, ties go by name
    def row(case, effect, ranked):
        return json.dumps({"case": case, "effect": effect,
                           "ranking": [{"cause": c} for c in ranked]})

    bench = tmp_path / "bench.jsonl"
    bench.write_text("\n".join([
        row("draw-1", "slip_lambda_max", ["slip_lambda_max", "friction_levels", "mast_compliance"]),
        row("draw-2", "slip_lambda_max", ["mast_compliance", "slip_lambda_max", "sensor_mount"]),
        row("draw-3", "slip_lambda_max", ["loose_payload", "friction_levels", "slip_lambda_max"]),
        row("draw-2", "slip_lambda_max", ["loose_payload", "slip_lambda_max"]),
        row("draw-4", "friction_levels", ["mast_compliance", "friction_levels"]),
        json.dumps({"case": "draw-5", "effect": "slip_lambda_max"}),  # no ranking kept
    ]) + "\n")
    assert rivals("slip_lambda_max", bench, n=1) == ["loose_payload"]
    assert rivals("slip_lambda_max", bench, n=2) == ["friction_levels", "loose_payload"]
    with pytest.raises(ValueError, match="fewer than 2 rivals of friction_levels"):
        rivals("friction_levels", bench, n=2)
    bench.write_text(bench.read_text() + "{not json\n")
    with pytest.raises(ValueError, match=r"bench.jsonl:7: not a JSON row"):
        rivals("slip_lambda_max", bench)


def _one_diagnosis(effect):
    """The tests of one hidden effect run on one pytest-xdist worker (scripts/test.sh's
    --dist loadgroup), where its diagnosis is computed once; the effects spread over
    the workers."""
    return pytest.mark.xdist_group(f"hidden-{effect or 'nothing'}")


@_one_diagnosis(None)
@pytest.mark.slow
def test_nothing_hidden_gives_no_discrepancy(hidden):
    _, result, _ = hidden(None)
    assert result["verdict"] == "no-discrepancy", result["reason"]
    assert result["cause"] is None


HIDDEN = [pytest.param(effect, marks=_one_diagnosis(effect)) for effect in NAMED]


@pytest.mark.parametrize("effect", HIDDEN)
@pytest.mark.slow
def test_diagnose_names_the_hidden_cause(hidden, effect):
    check_named(*hidden(effect)[:2], effect)


@pytest.mark.parametrize("effect", HIDDEN)
@pytest.mark.slow
def test_diagnose_never_names_a_wrong_cause(hidden, effect):
    check_not_wrong(hidden(effect)[1], effect)


@pytest.mark.parametrize("effect", [pytest.param(effect, marks=_one_diagnosis(effect))
                                    for effect in sorted(OUTSIDE_EFFECTS)])
@pytest.mark.slow
def test_an_effect_outside_the_candidates_is_unexplained(hidden, effect):
    _, result, _ = hidden(effect)
    assert result["verdict"] == "unexplained", result["reason"]
    assert result["cause"] is None


@pytest.fixture(scope="module")  # a diagnosis (146 s here): the tests that use it are slow
def written(tmp_path_factory):
    """(dataset, out dir, result) of one uninterrupted diagnose with outputs: a hidden
    slip parameter, one candidate, a broken run file in the dataset."""
    root = tmp_path_factory.mktemp("written")
    data = root / "data"
    make_dataset(data, "slip_lambda_max", seed=SEED, duration_s=DURATION_S, file_format="csv")
    (data / "broken.csv").write_text("time_s,ax,ay,az\n0,1,2\n")
    with open(data / "runs.csv", "a") as f:
        f.write("broken.csv,0,30,concrete,extended,platform,4\n")
    out = root / "out"
    result = diagnose(data, out, progress=False, candidates=["slip_lambda_max"])
    return data, out, result


@pytest.mark.slow
def test_diagnose_writes_its_outputs(written):
    data, out, result = written
    saved = json.loads((out / "diagnosis.json").read_text())
    for key in ("verdict", "cause", "parameters", "intervals", "ranking", "gain",
                "discrepancies", "skipped_runs"):
        assert key in saved
    assert set(saved["gain"]) >= {"metric", "baseline_error", "extended_error",
                                  "relative_reduction"}
    assert saved["search_starts"] == 1  # the default: the search reads the start from rest
    # the default scale is the trials' spread alone (--model-spread adds the model's), and
    # the metric says which
    assert saved["model_spread"] is False
    assert "start-to-start spread" not in saved["gain"]["metric"]
    assert [s["file"] for s in saved["skipped_runs"]] == ["broken.csv"]
    assert "broken.csv" in saved["skipped_runs"][0]["reason"]
    assert (out / "report.md").read_text().count("figures/") == 2
    assert (out / "figures" / "spectra.png").stat().st_size > 0
    # the hidden slip parameter is the only candidate here, so it is named, and its
    # extended model is one self-contained MJCF file carrying the fitted attribute
    assert result["verdict"] == "explained", result["reason"]
    m = mujoco.MjModel.from_xml_path(str(out / "extended_model.xml"))
    spec = mujoco.MjSpec.from_file(str(out / "extended_model.xml"))
    config = dict(spec.plugins[0].config)
    assert float(config["lambda_max"]) == pytest.approx(saved["parameters"]["lambda_max"])
    assert m.nu == 2
    # its interval is read against its training error from each start, the first the
    # search's own (from rest): the saved profile and starts give the saved interval,
    # which holds the one the search's value alone would give
    named = saved["ranking"][0]
    starts, n_train = named["train_errors_over_starts"], saved["training_runs"]
    assert len(starts) == STARTS and starts[0] == pytest.approx(named["train_error"])
    prior = causes.get("slip_lambda_max").main
    profile = [tuple(point) for point in named["profile"]]
    bound = interval_bound(starts, named["train_error"], n_train)
    low, high = saved["intervals"]["lambda_max"]
    assert (low, high) == pytest.approx(interval(profile, n_train, prior, bound))
    single = interval(profile, n_train, prior)
    assert low <= single[0] <= single[1] <= high
    # and it records a side open for want of a probe as the saved profile shows it
    assert named["unprobed"].get("lambda_max", []) == unprobed_sides(profile, prior, (low, high))
    # the named fit's open sides are also at the top level and under most_likely, beside
    # the intervals they qualify
    assert saved["unprobed"] == saved["most_likely"]["unprobed"] == named["unprobed"]


@pytest.mark.slow
def test_the_progress_plan_is_the_count_run_but_for_brents_steps(written):
    # simulations_planned is a plan (a progress bar's total), not a bound: what it cannot
    # know is how many steps each Brent search takes (it plans REFINE_STEPS_PLANNED).  A
    # one-parameter cause is not refined and one cause has no pair, so with the steps
    # the search took (its saved profile: the grid's points and Brent's) the plan must
    # be the count the written diagnosis ran, exactly (nothing was reused).  The plan
    # once counted a pair here (7 simulations too many).
    from skidsteer.diagnosis.diagnose import simulations_planned
    from skidsteer.diagnosis.search import REFINE_STEPS_PLANNED
    from skidsteer.reports.diagnosis import _observed as read_observed
    data, out, result = written
    saved = json.loads((out / "diagnosis.json").read_text())
    assert saved["simulations"]["reused"] == 0
    observed = read_observed(data, None)
    trained = len(observed.groups) - len(saved["dataset"]["held_out_groups"])
    brent_steps = len(saved["ranking"][0]["profile"]) - GRID_POINTS
    planned = simulations_planned(["slip_lambda_max"], observed)
    unplanned = (brent_steps - REFINE_STEPS_PLANNED) * trained
    assert saved["simulations"]["simulated"] == planned + unplanned


def test_the_verdict_printout_says_which_interval_sides_are_unprobed(capsys):
    from skidsteer.cli import _print_verdict
    # a cause of the registry's, as a diagnosis.json holds it
    result = {"verdict": "explained", "cause": "loose_payload", "reason": "r",
              "parameters": {"frequency_hz": 5.4, "damping_ratio": 0.08},
              "intervals": {"frequency_hz": [4.5, 5.8], "damping_ratio": [0.05, 0.15]},
              "unprobed": {"damping_ratio": ["below"]}}
    _print_verdict(result)
    lines = capsys.readouterr().out.splitlines()
    assert "  damping_ratio = 0.08 (interval 0.05 to 0.15; not probed below)" in lines
    assert "  frequency_hz = 5.4 (interval 4.5 to 5.8)" in lines
    # a diagnosis.json written before the field existed prints as before
    del result["unprobed"]
    _print_verdict(result)
    assert ("  damping_ratio = 0.08 (interval 0.05 to 0.15)"
            in capsys.readouterr().out.splitlines())


def _comparable(diagnosis_json: dict) -> dict:
    """diagnosis.json without what differs between two runs of one diagnosis: its wall
    time and how many simulations it ran or found stored."""
    return {k: v for k, v in diagnosis_json.items() if k not in ("wall_time_s", "simulations")}


@pytest.mark.slow
def test_a_killed_diagnose_looks_unfinished_and_its_rerun_resumes_to_the_same_result(
        written, tmp_path):
    # issue 7: SIGKILL a diagnose midway (no cleanup runs); its directory must not
    # look finished, and the same command rerun must reuse what was simulated and
    # write what the uninterrupted diagnose wrote
    from skidsteer.cli import main
    from skidsteer.data import INCOMPLETE_MARKER
    from skidsteer.simulation.cache import CACHE_DIR

    data, whole, whole_result = written
    # the base model on the 3 commands from STARTS starts, the fit's points (5 grid, then
    # Brent to its tolerance) on the 2 training commands, the fit's end on the held-out
    # one from STARTS starts and on the training ones from the STARTS - 1 others (the
    # scatter its intervals are read against)
    points = len(whole_result["ranking"][0]["profile"])
    assert GRID_POINTS < points <= GRID_POINTS + REFINE_MAX_STEPS
    simulated = 3 * STARTS + points * 2 + STARTS + (STARTS - 1) * 2
    assert whole_result["simulations"] == {"simulated": simulated, "reused": 0,
                                           "cache": str(whole / CACHE_DIR)}
    out = tmp_path / "out"
    args = ["diagnose", str(data), "--out", str(out), "--cause", "slip_lambda_max",
            "--no-progress"]
    process = subprocess.Popen([sys.executable, "-c", "import sys; from skidsteer.cli import "
                                "main; sys.exit(main(sys.argv[1:]))", *args])
    deadline = time.monotonic() + 300
    # killed once the base model (3) and some fit points are stored; a simulation
    # takes ~1 s on a core, the poll 10 ms
    while len(list((out / CACHE_DIR).glob("*.npz"))) < 9 and time.monotonic() < deadline:
        time.sleep(0.01)
    process.send_signal(signal.SIGKILL)
    process.wait()
    stored = len(list((out / CACHE_DIR).glob("*.npz")))
    assert 9 <= stored < simulated, stored
    assert not (out / "diagnosis.json").exists()
    assert "unfinished skidsteer diagnose" in (out / INCOMPLETE_MARKER).read_text()

    assert main(args + ["--json"]) == 0
    resumed = json.loads((out / "diagnosis.json").read_text())
    expected = json.loads((whole / "diagnosis.json").read_text())
    assert _comparable(resumed) == _comparable(expected)
    # every fit point stored before the kill was reused; the base model is simulated
    # again (the report plots its signals, which are not stored), and so is the
    # fitted model if it came from the store
    assert resumed["simulations"]["reused"] == stored - 3
    assert resumed["simulations"]["simulated"] + resumed["simulations"]["reused"] in (
        simulated, simulated + 3)
    assert not (out / INCOMPLETE_MARKER).exists()
    assert not list(out.rglob(".*.part*"))
    for name in ("extended_model.xml", "figures/spectra.png", "figures/features_vs_omega.png"):
        assert (out / name).read_bytes() == (whole / name).read_bytes(), name


@pytest.mark.slow
def test_compare_writes_its_result_last_and_leaves_no_marker(written, tmp_path):
    # compare keeps diagnose's rule: comparison.json present means the outputs are whole
    from skidsteer.data import INCOMPLETE_MARKER

    data, _, _ = written
    out = tmp_path / "compare"
    out.mkdir()
    (out / "comparison.json").write_text("{\"stale\": true}\n")  # a previous run's
    summary = compare(data, out, progress=False, figures=False)
    saved = json.loads((out / "comparison.json").read_text())
    assert "stale" not in saved and saved["verdict"] == summary["verdict"] == "discrepancy"
    assert [s["file"] for s in saved["skipped_runs"]] == ["broken.csv"]
    assert (out / "report.md").is_file() and not (out / INCOMPLETE_MARKER).exists()


def test_wheel_orders_are_read_at_the_wheels_actual_rate():
    # issue 21: the servos droop under the tires' torque (the issue measured ~9 % slower
    # than commanded at 30 deg/s on concrete); the simulated side's wheel orders are read
    # at the simulated wheels' steady rate, and the droop must show (between 3 % and
    # 15 %: the issue's 9 % with room for the perturbed start; a rate at the command
    # would mean the command was returned unchanged)

    m = load_model()
    settled = settle(m, mujoco.MjData(m), 2.0)
    commanded = wheel_rates_hz(m, 0.0, 30.0)
    time_s, accel, yaw, actual = simulate_group(m, settled, 0.0, 30.0, 8.0, SensorChain())
    assert len(commanded) == len(actual) == 1
    droop = 1 - actual[0] / commanded[0]
    assert 0.03 < droop < 0.15, droop
