"""The tire plugin's contract with MuJoCo and the robot's behaviour at rest and under command."""

from __future__ import annotations

import mujoco
import mujoco.rollout
import numpy as np
import pytest

import skidsteer
from skidsteer.experiments import tire_loads
from skidsteer.robot import Setup
from skidsteer.simulation import FULLPHYSICS, get_state, rollout, sensor_slice, settle


def random_commands(m: mujoco.MjModel, rng: np.random.Generator, duration_s: float) -> np.ndarray:
    """Piecewise-constant wheel commands over the whole ctrlrange, held 10 ms to 1 s,
    so abrupt full reversals happen."""
    nstep = int(round(duration_s / m.opt.timestep))
    ctrl = np.empty((nstep, m.nu))
    i = 0
    while i < nstep:
        hold = int(rng.uniform(0.01, 1.0) / m.opt.timestep)
        lo, hi = m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1]
        ctrl[i:i + hold] = rng.uniform(lo, hi)
        i += hold
    return ctrl


def test_tire_loads_at_rest_match_weight_and_eq_2_24():
    # acceptance: the four normal forces sum to m g within 0.1 % and split
    # front/rear as eq. 2.24 within 2 %.  At rest the vertical springs carry
    # the weight exactly; the residual is the settling transient (<1e-6).
    result = tire_loads(Setup(build="extended", floor="concrete"))
    assert result["sum_over_weight"] == pytest.approx(1.0, abs=1e-3)
    np.testing.assert_allclose(result["normal_forces_N"], result["eq_2_24_N"], rtol=0.02)


def test_bare_platform_loads_match_its_weight():
    result = tire_loads(Setup(build="platform", floor="carpet"))
    assert result["sum_N"] == pytest.approx(225 / 9.8 * 9.81, rel=1e-3)


@pytest.mark.parametrize("floor", skidsteer.FLOORS)
@pytest.mark.slow
def test_random_commands_for_60_s_stay_finite_without_warnings(floor):
    # acceptance: 60 s of random wheel commands up to the motors' limits on
    # each floor: no NaN, no MuJoCo warning
    m = skidsteer.load_model("extended", floor)
    d = mujoco.MjData(m)
    settle(m, d, 0.5)
    ctrl = random_commands(m, np.random.default_rng(len(floor)), 60.0)
    states, sensors = rollout(m, d, ctrl, len(ctrl))
    assert np.isfinite(states).all() and np.isfinite(sensors).all()
    assert all(w.number == 0 for w in d.warning), [w.number for w in d.warning]
    # the robot stays on the floor: CoM height within the tire's travel and
    # a few cm of hop
    height = states[:, 1 + 2]  # FULLPHYSICS: time, then qpos
    assert height.min() > 0.15 and height.max() < 0.40


def test_locked_wheel_free_response_oscillates_and_decays(settled):
    # acceptance: released from a tire deflection as in Sec. 6.2 (left wheels
    # 1 mm more, right wheels 1 mm less compressed: a roll about x), the
    # robot oscillates with decaying amplitude
    m, d = settled
    roll = np.arctan2(2e-3, 0.36)
    quat = np.empty(4)
    mujoco.mju_axisAngle2Quat(quat, np.array([1.0, 0, 0]), -roll)
    mujoco.mju_mulQuat(d.qpos[3:7], quat, d.qpos[3:7].copy())
    d.qvel[:] = 0
    mujoco.mj_forward(m, d)
    per_s = int(round(1 / m.opt.timestep))
    _, sensors = rollout(m, d, np.zeros(m.nu), 2 * per_s)
    ay = sensors[:, sensor_slice(m, "accelerometer")][:, 1]
    ay = ay - ay[-per_s // 2:].mean()
    first_second = ay[:per_s]
    crossings = np.count_nonzero(np.diff(np.sign(first_second)) != 0)
    assert crossings >= 4  # several half-periods in the first second: it oscillates
    first = np.abs(first_second[:per_s // 4]).max()
    last = np.abs(first_second[3 * per_s // 4:]).max()
    assert last < 0.5 * first  # and decays


def _run_steps(m, d, nstep):
    out = []
    for _ in range(nstep):
        mujoco.mj_step(m, d)
        out.append(get_state(m, d))
    return np.array(out)


@pytest.fixture()
def mid_swivel():
    """A robot mid-swivel: tire states non-trivial, contacts slipping and sticking."""
    m = skidsteer.load_model("extended", "concrete")
    d = mujoco.MjData(m)
    settle(m, d, 0.3)
    d.ctrl[:] = [-2.0, 2.0]
    for _ in range(300):
        mujoco.mj_step(m, d)
    assert np.any(d.plugin_state != d.plugin_state[0])
    return m, d


def test_reset_data_reproduces_a_rollout_bit_for_bit(mid_swivel):
    m, d = mid_swivel
    mujoco.mj_resetData(m, d)
    d.ctrl[:] = [-2.0, 2.0]
    first = _run_steps(m, d, 400)
    mujoco.mj_resetData(m, d)
    d.ctrl[:] = [-2.0, 2.0]
    second = _run_steps(m, d, 400)
    np.testing.assert_array_equal(first, second)


def test_copy_data_reproduces_a_rollout_bit_for_bit(mid_swivel):
    m, d = mid_swivel
    copy = mujoco.MjData(m)
    mujoco.mj_copyData(copy, m, d)
    np.testing.assert_array_equal(copy.plugin_state, d.plugin_state)
    np.testing.assert_array_equal(_run_steps(m, d, 400), _run_steps(m, copy, 400))


def test_get_and_set_state_reproduce_a_rollout_bit_for_bit(mid_swivel):
    m, d = mid_swivel
    saved = get_state(m, d)
    first = _run_steps(m, d, 400)
    other = mujoco.MjData(m)
    mujoco.mj_setState(m, other, saved, FULLPHYSICS)
    other.ctrl[:] = d.ctrl
    np.testing.assert_array_equal(first, _run_steps(m, other, 400))


def test_rollout_with_two_threads_equals_sequential_stepping(mid_swivel):
    m, d = mid_swivel
    rng = np.random.default_rng(3)
    starts = []
    for _ in range(4):  # four different initial states
        for _ in range(50):
            mujoco.mj_step(m, d)
        starts.append(get_state(m, d))
    starts = np.array(starts)
    controls = random_commands(m, rng, 4 * 0.3).reshape(4, -1, m.nu)
    nstep = controls.shape[1]
    states, _ = mujoco.rollout.rollout(m, [mujoco.MjData(m), mujoco.MjData(m)], starts, controls,
                                       nstep=nstep)
    for b in range(4):
        seq = mujoco.MjData(m)
        mujoco.mj_setState(m, seq, starts[b], FULLPHYSICS)
        expected = []
        for t in range(nstep):
            seq.ctrl[:] = controls[b, t]
            mujoco.mj_step(m, seq)
            expected.append(get_state(m, seq))
        np.testing.assert_array_equal(states[b], np.array(expected))


def test_plugin_state_is_part_of_fullphysics_state(mid_swivel):
    m, d = mid_swivel
    size_physics = mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_PHYSICS)
    size_full = mujoco.mj_stateSize(m, FULLPHYSICS)
    assert size_full - size_physics >= m.npluginstate == 24


def test_a_wheel_driven_off_every_floor_is_warned_of_once():
    # a heightfield is the only floor: a wheel beyond its edge finds none and gets no
    # tire force (as in the air), which a user should not learn from a fallen robot
    from skidsteer.diagnosis import causes
    from skidsteer.robot import load_model

    said: list[str] = []
    before = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(said.append)
    try:
        rough = causes.get("ground_roughness")
        m = load_model("extended", "concrete", edit=rough.edit(rough.parameters()))
        d = mujoco.MjData(m)
        for _ in range(10):
            mujoco.mj_step(m, d)
        assert not said  # on the floor
        d = mujoco.MjData(m)
        d.qpos[0] = 5.0  # the floor is 3 m square about the origin
        for _ in range(10):
            mujoco.mj_step(m, d)
        assert len(said) == 1 and "beyond every floor" in said[0], said
        assert "skidsteer.tire instance 'tires'" in said[0] and "wheel '" in said[0]
        # a plane is under every wheel everywhere: never warned of
        said.clear()
        m = load_model("extended", "concrete")
        d = mujoco.MjData(m)
        d.qpos[0] = 50.0
        for _ in range(10):
            mujoco.mj_step(m, d)
        assert not said
    finally:
        mujoco.set_mju_user_warning(before)
