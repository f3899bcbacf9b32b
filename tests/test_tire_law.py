"""The tire law's physics (Ch. 4), on the Python reference that the C plugin equals."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tire_reference import (
    Kinematics, TireParams, advance, forces, friction_factors, friction_slopes, normal_force,
    reset_state, sliding_factor, step_force)

NORMAL = 70.0  # N, about a quarter of the extended robot's weight
P = TireParams()


def loaded(slip_x=0.0, slip_y=0.0, rolling=0.0, rate=0.0) -> Kinematics:
    return Kinematics(compression=NORMAL / P.stiffness_z, compression_rate=rate,
                      slip_x=slip_x, slip_y=slip_y, rolling_speed=rolling)


def drag(k: Kinematics, duration_s: float, h: float = 1e-5,
         params: TireParams = P) -> np.ndarray:
    """Lateral force on a wheel dragged with fixed kinematics, sampled every step."""
    state = np.zeros(6)
    reset_state(state)
    out = []
    for _ in range(int(duration_s / h)):
        out.append(forces(params, k, state)[2])
        advance(params, k, h, state)
    return np.array(out)


def test_locked_wheel_dragged_sideways_gives_a_saw_tooth():
    # Sec. 3.3 / 4.1: the contact point sticks, the tire spring loads at K_y u,
    # breaks away at mu_s N, slips, stops, sticks again
    u = 1e-3  # m/s, the testing machine's speed
    f = -drag(loaded(slip_y=u), 6.0)
    peaks = np.flatnonzero((f[1:-1] > f[:-2]) & (f[1:-1] >= f[2:]) & (f[1:-1] > 0.5 * NORMAL)) + 1
    assert len(peaks) >= 3  # repeated teeth, not one breakaway
    # every tooth breaks away at the static limit mu_s N (+ the damper's D u)
    np.testing.assert_allclose(f[peaks], P.mu_static * NORMAL + P.damping_y * u, rtol=2e-3)
    # between teeth the force falls to about the kinetic level and no lower
    # than the static level mirrored about it (a light contact point)
    trough = f[peaks[0]:peaks[1]].min()
    assert (2 * P.mu_kinetic - P.mu_static) * NORMAL - 1 <= trough <= P.mu_kinetic * NORMAL + 1
    # the ramps load at the tire stiffness: df/dt = K_y u
    ramp = np.diff(f[peaks[1] - 2000:peaks[1] - 1000]) / 1e-5
    np.testing.assert_allclose(ramp, P.stiffness_y * u, rtol=1e-6)


def test_sustained_slip_feels_kinetic_friction():
    # the term eq. 6.4 drops: a wheel sliding steadily is held back by mu_k N
    for u in (0.05, 0.5, -2.0):
        f = drag(loaded(slip_y=u), 0.2)
        assert f[-1] == pytest.approx(-np.sign(u) * P.mu_kinetic * NORMAL, rel=1e-9)


def test_sustained_slip_with_falling_friction_feels_the_stribeck_curve():
    # sliding_friction_ratio alpha_s < 1: the kinetic limit falls with the sliding
    # speed as alpha_s + (1 - alpha_s) exp(-(v / v_S)^2); static friction is unchanged
    p = dataclasses.replace(P, sliding_friction_ratio=0.6, sliding_velocity=0.1)
    for u in (0.05, 0.5, -2.0):
        f = drag(loaded(slip_y=u), 0.2, params=p)
        expected = P.mu_kinetic * (0.6 + 0.4 * math.exp(-(u / 0.1) ** 2)) * NORMAL
        assert f[-1] == pytest.approx(-np.sign(u) * expected, rel=1e-9)
    # alpha_s = 1 is the law of Ch. 4 exactly
    assert sliding_factor(P, loaded(slip_x=0.3, slip_y=0.2)) == (1.0, (0.0, 0.0))


def test_falling_friction_slope_is_the_derivative_of_its_curve():
    # the slopes the implicit coupling's Newton steps use (they move its speed, not
    # its answer, so the plugin-vs-reference comparison cannot see them)
    p = dataclasses.replace(P, sliding_friction_ratio=0.4, sliding_velocity=0.07)
    k = loaded(slip_x=0.05, slip_y=-0.03)
    g, grad = sliding_factor(p, k)
    for i, name in enumerate(("slip_x", "slip_y")):
        step = 1e-7
        plus = dataclasses.replace(k, **{name: getattr(k, name) + step})
        minus = dataclasses.replace(k, **{name: getattr(k, name) - step})
        numeric = (sliding_factor(p, plus)[0] - sliding_factor(p, minus)[0]) / (2 * step)
        assert grad[i] == pytest.approx(numeric, rel=1e-6)


def test_load_coupled_lateral_stiffness_scales_the_spring_force():
    # stiffness_y_load_exponent n > 0: the lateral spring is K_y (N / N_0)^n, so at a
    # given deflection the force follows the load; n = 0 is the law of Ch. 4 exactly
    assert P.stiffness_y_load_exponent == 0 and P.lateral_stiffness(3 * NORMAL) == P.stiffness_y
    p = dataclasses.replace(P, stiffness_y_load_exponent=0.7, reference_load=50.0)
    state = np.zeros(6)
    reset_state(state)
    state[3] = 1e-4  # lateral deflection s_y, m; the contact point at rest
    for normal in (25.0, 50.0, 140.0):
        k = Kinematics(compression=normal / P.stiffness_z, compression_rate=0.0, slip_x=0.0,
                       slip_y=0.0, rolling_speed=0.0)
        expected = -P.stiffness_y * (normal / 50.0) ** 0.7 * 1e-4
        assert forces(p, k, state)[2] == pytest.approx(expected, rel=1e-12)
        # a sticking contact point is held until the loaded spring's force reaches
        # static friction: the stick/slip switch sees the same stiffness
        s_break = P.mu_static * normal / p.lateral_stiffness(normal)
        for s, stuck in ((0.99 * s_break, 1.0), (1.01 * s_break, 0.0)):
            st = state.copy()
            st[3] = s
            advance(p, k, 1e-9, st)
            assert st[5] == stuck


def test_friction_factors_follow_eq_4_12():
    lam_max = P.lambda_max
    # locked wheel, sliding any way: full friction both ways
    assert friction_factors(P, loaded(slip_x=0.1, slip_y=0.2)) == (1.0, 1.0)
    # nothing moves: full grip (static friction holds a robot at rest)
    assert friction_factors(P, loaded()) == (1.0, 1.0)
    # rolling with small slip: mu_x = |lambda| / lambda_max, mu_y = |v_y| / (r w lambda_max)
    mu = friction_factors(P, loaded(slip_x=-0.01, slip_y=0.002, rolling=0.5))
    assert mu == pytest.approx((0.02 / lam_max, 0.002 / (0.5 * lam_max)))
    # large slip: mu_x saturated, mu_y = tan(theta) = |v_y| / |Delta v_x|
    assert friction_factors(P, loaded(slip_x=0.4, slip_y=0.1, rolling=0.5)) == (1.0, 0.25)
    # spinning in place with little lateral motion: lateral friction mostly gone
    # (the 20-30 N floor of Sec. 3.3 is then carried by mu_y = v_y / Delta v_x)
    mu = friction_factors(P, loaded(slip_x=-0.04, slip_y=0.001, rolling=0.04))
    assert mu == (1.0, pytest.approx(0.025))


COMBINED = TireParams(slip_law="combined")


def _slips(rng, n=2000):
    """Random (slip_x, slip_y, rolling) over the regimes: locked, rolling with small and
    large slip, m/s."""
    scale = 10 ** rng.uniform(-4, 0, (n, 3))
    signs = rng.choice([-1.0, 1.0], (n, 3))
    out = scale * signs
    out[rng.random(n) < 0.1, 2] = 0.0  # a wheel that does not turn
    return out


@pytest.mark.parametrize("rho", [1.0, 0.6, 1.4])
def test_combined_law_keeps_the_force_on_the_friction_ellipse(rho):
    # Coulomb friction on the resultant slip: the limits' factors (f_x / mu_x N,
    # f_y / mu_x N) lie inside the ellipse of axes 1 and rho, on it once the slip
    # saturates, and the force opposes (u_x, rho^2 u_y) (maximum dissipation)
    p = TireParams(slip_law="combined", lateral_friction_ratio=rho)
    rng = np.random.default_rng(1)
    for sx, sy, rolling in _slips(rng):
        k = loaded(slip_x=sx, slip_y=sy, rolling=rolling)
        mx, my = friction_factors(p, k)
        radius = math.hypot(mx, my / rho)
        assert radius <= 1 + 1e-12
        q = math.hypot(sx, rho * sy)
        if q >= abs(rolling) * p.lambda_max and q > 0:
            assert radius == pytest.approx(1, rel=1e-12)
        if q > 0:
            # the direction: mu_x : mu_y = |u_x| : rho^2 |u_y|
            assert mx * rho ** 2 * abs(sy) == pytest.approx(my * abs(sx), abs=1e-12)


def test_combined_law_agrees_with_eq_4_12_in_pure_slip_and_linear_regime():
    rng = np.random.default_rng(2)
    for sx, sy, rolling in _slips(rng):
        for direction, k in enumerate((loaded(slip_x=sx, slip_y=0.0, rolling=rolling),
                                       loaded(slip_x=0.0, slip_y=sy, rolling=rolling))):
            # in the direction of the slip; across it too on a rolling wheel (a locked
            # wheel dragged sideways keeps eq. 4.12a's full longitudinal limit, which
            # the friction circle, sliding sideways, gives to the lateral one alone)
            for checked in ((0, 1) if rolling else (direction,)):
                assert friction_factors(COMBINED, k)[checked] == pytest.approx(
                    friction_factors(P, k)[checked], rel=1e-12)
        k = loaded(slip_x=sx, slip_y=sy, rolling=rolling)
        if math.hypot(sx, sy) < abs(rolling) * P.lambda_max:
            assert friction_factors(COMBINED, k) == pytest.approx(friction_factors(P, k),
                                                                  rel=1e-12)


def test_combined_law_caps_what_eq_4_12_lets_exceed_mu_n():
    # spinning in place at 45 degrees of slip: eq. 4.12a/b give mu_x = 1 and mu_y = 1, a
    # resultant of sqrt(2) mu N; the friction circle gives 1/sqrt(2) each
    k = loaded(slip_x=0.1, slip_y=0.1, rolling=0.2)
    assert friction_factors(P, k) == (1.0, 1.0)
    assert friction_factors(COMBINED, k) == pytest.approx((2 ** -0.5, 2 ** -0.5))


@pytest.mark.parametrize("rho", [1.0, 0.6])
def test_combined_law_slopes_are_the_derivatives_of_its_factors(rho):
    p = TireParams(slip_law="combined", lateral_friction_ratio=rho)
    rng = np.random.default_rng(3)
    for sx, sy, rolling in _slips(rng, 300):
        k = loaded(slip_x=sx, slip_y=sy, rolling=rolling)
        slope = friction_slopes(p, k)
        for direction in (0, 1):
            h = 1e-7 * max(abs(sx), abs(sy), 1e-6)
            up, down = (loaded(slip_x=sx + (h if direction == 0 else 0) * s,
                               slip_y=sy + (h if direction == 1 else 0) * s, rolling=rolling)
                        for s in (1, -1))
            numeric = (friction_factors(p, up)[direction]
                       - friction_factors(p, down)[direction]) / (2 * h)
            # away from the regime boundary (a kink) the central difference is the slope
            q = math.hypot(sx, rho * sy)
            if abs(q - abs(rolling) * p.lambda_max) > 1e-3 * q:
                assert slope[direction] == pytest.approx(numeric, rel=1e-4, abs=1e-6)


def test_wheel_off_the_floor_carries_nothing_and_relaxes():
    k = Kinematics(compression=-1e-3, compression_rate=0.0, slip_x=1.0, slip_y=1.0,
                   rolling_speed=0.0)
    state = np.array([1e-3, 0.1, 0.0, -2e-3, 0.2, 0.0])
    assert normal_force(P, k) == 0
    np.testing.assert_array_equal(forces(P, k, state), [0, 0, 0])
    advance(P, k, 1e-4, state)
    np.testing.assert_array_equal(state, [0, 0, 1, 0, 0, 1])


def test_floor_never_pulls():
    # fast unloading: the damper would pull the wheel down; the floor cannot
    assert normal_force(P, loaded(rate=-10.0)) == 0.0


def test_belt_and_tread_in_series():
    # eq. 4.14: K_x = K_tx K_b / (K_tx + K_b); an infinitely stiff tread leaves the belt
    assert P.stiffness_x == P.belt_stiffness
    p = TireParams(tread_stiffness_x=3000.0, belt_stiffness=3000.0)
    assert p.stiffness_x == pytest.approx(1500.0)


def _random_state(rng) -> np.ndarray:
    state = np.zeros(6)
    for k in (0, 3):
        state[k + 2] = float(rng.integers(0, 2))
        state[k] = rng.normal(0, 2e-3)
        state[k + 1] = 0.0 if state[k + 2] else rng.normal(0, 0.05)
    return state


@pytest.mark.parametrize("contact_point", ["coulomb", "relay"])
def test_substeps_are_the_fine_steps_and_their_mean_force(contact_point):
    # n substeps of h / n with the slips held are n steps of the law at h / n: the same
    # state, and the force the body receives is the mean of the n end-of-step forces
    rng = np.random.default_rng(11)
    for trial in range(200):
        n = int(rng.integers(2, 30))
        p = TireParams(contact_point=contact_point, contact_substeps=n,
                       sliding_friction_ratio=0.6 if trial % 2 else 1.0)
        fine = dataclasses.replace(p, contact_substeps=1)
        k = loaded(slip_x=rng.normal(0, 0.05), slip_y=rng.normal(0, 0.05),
                   rolling=rng.normal(0, 0.5))
        state = _random_state(rng)
        force, _ = step_force(p, k, 1e-3, state)
        stepped, fine_forces = state.copy(), []
        for _ in range(n):
            advance(fine, k, 1e-3 / n, stepped)
            fine_forces.append(forces(fine, k, stepped)[1:])
        np.testing.assert_allclose(force[1:], np.mean(fine_forces, axis=0), rtol=1e-12,
                                   atol=1e-12)
        substepped = state.copy()
        advance(p, k, 1e-3, substepped)
        np.testing.assert_array_equal(substepped, stepped)


@pytest.mark.parametrize("contact_point", ["coulomb", "relay"])
def test_substeps_slope_is_the_derivative_of_the_mean_force(contact_point):
    # the implicit coupling's Newton steps use d (mean force) / d u, carried through the
    # substeps' states; it must be the derivative wherever the mean force is smooth (a
    # kink where a substep changes regime is told by its one-sided differences differing)
    rng = np.random.default_rng(12)
    checked = 0
    for trial in range(400):
        p = TireParams(contact_point=contact_point, contact_substeps=int(rng.integers(2, 20)),
                       sliding_friction_ratio=0.6 if trial % 2 else 1.0)
        sx, sy = rng.normal(0, 0.02, 2)
        state = _random_state(rng)
        rolling = rng.normal(0, 0.5)
        slope = step_force(p, loaded(slip_x=sx, slip_y=sy, rolling=rolling), 1e-3, state)[1]
        for direction in (0, 1):
            eps = 1e-7
            f = [step_force(p, loaded(slip_x=sx + (e if direction == 0 else 0),
                                      slip_y=sy + (e if direction == 1 else 0),
                                      rolling=rolling), 1e-3, state)[0][1 + direction]
                 for e in (-eps, 0.0, eps)]
            right, left = (f[2] - f[1]) / eps, (f[1] - f[0]) / eps
            # smooth here: both one-sided differences agree to 1e-4 of the larger
            if abs(right - left) <= 1e-4 * max(abs(right), abs(left), 1.0):
                assert slope[direction] == pytest.approx((right + left) / 2, rel=1e-4,
                                                         abs=1e-3)
                checked += 1
    assert checked >= 400  # most draws are smooth: the comparison is not vacuous
