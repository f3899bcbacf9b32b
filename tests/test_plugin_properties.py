"""Property tests of the tire plugin (issue 7): whatever a user can command.

Hypothesis draws a model (valid random tire attributes, or the defaults; a plane
floor of each friction set or a rough heightfield; every integrator), an initial
pose (upright, tilted, upside down; on the floor or dropped from up to 0.5 m)
and a command sequence (both sides, up to twice the motors' range, abrupt
reversals).  Every run must stay finite without a MuJoCo warning and replay to
the bit.  With zero commands the mechanical energy, tires included, must not
grow (the tire law is passive; MuJoCo's native contacts off).

CI runs a fixed, derandomized budget (PROPERTY_EXAMPLES below).  The long run
of issue 7's acceptance, 10,000 command sequences:

    SKIDSTEER_PROPERTY_EXAMPLES=10000 python -m pytest tests/test_plugin_properties.py \
        -k sequences
"""

from __future__ import annotations

import math
import os

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from skidsteer import FLOORS
import tire_reference as tr
from skidsteer.robot import load_spec
from skidsteer.simulation import rollout
from test_tire_reference import random_config, with_heightfield

# Command sequences per run of the suite: 60 (~40 s here) in CI; the long run
# sets the variable.  Derandomized: the same examples on every CI run.
PROPERTY_EXAMPLES = int(os.environ.get("SKIDSTEER_PROPERTY_EXAMPLES", "60"))
PROPERTIES = settings(max_examples=PROPERTY_EXAMPLES, derandomize=True, deadline=None,
                      suppress_health_check=[HealthCheck.too_slow])

I = mujoco.mjtIntegrator
# The step each integrator needs for the model's own stiffest element, the
# velocity servo (kv = 100 N m s/rad on a side's tendon, wheel inertia 4e-4 kg m^2:
# its common mode decays at ~1.25e5 /s).  Euler and RK4 treat actuator damping
# explicitly: Euler is unstable at 2e-5 s and RK4 at 5e-5 s with or without the
# tire plugin (measured), so they run at 1e-5 and 2e-5 s; the implicit
# integrators at the models' 0.1 ms.
INTEGRATOR_STEP_S = {I.mjINT_IMPLICITFAST: 1e-4, I.mjINT_IMPLICIT: 1e-4,
                     I.mjINT_RK4: 2e-5, I.mjINT_EULER: 1e-5}
# Simulated time per run: long enough for a 0.5 m drop to land (0.32 s) on the
# implicit integrators; the explicit ones are 5-10x dearer per second, so they
# run 0.1 s (their landings are the implicit runs' business).
RUN_S = {I.mjINT_IMPLICITFAST: 0.6, I.mjINT_IMPLICIT: 0.6, I.mjINT_RK4: 0.1,
         I.mjINT_EULER: 0.1}


@st.composite
def models(draw):
    integrator = draw(st.sampled_from(list(INTEGRATOR_STEP_S)))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    tire = draw(st.sampled_from(["defaults", "coulomb", "relay", "combined"]))
    config = None if tire == "defaults" else random_config(
        rng, contact_point="relay" if tire == "relay" else "coulomb",
        slip_law="combined" if tire == "combined" else None)
    floor = draw(st.sampled_from(list(FLOORS) + ["heightfield"]))
    spec = load_spec("extended", None if floor == "heightfield" else floor, tire=config,
                     timestep=INTEGRATOR_STEP_S[integrator])
    if floor == "heightfield":
        with_heightfield(spec, rng)
    spec.option.integrator = integrator
    spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    return spec.compile(), config, integrator


@st.composite
def poses(draw):
    """(height of the base above the floor m, tilt deg, tilt axis angle rad, yaw rad)."""
    kind = draw(st.sampled_from(["upright", "tilted", "upside_down"]))
    tilt = {"upright": 0.0, "tilted": draw(st.floats(5, 80)),
            "upside_down": draw(st.floats(150, 180))}[kind]
    # on its tires (0.23 m) or dropped; upside down it starts above its mast
    low = 0.23 if kind != "upside_down" else 1.0
    height = low + draw(st.floats(0.0, 0.5))
    return height, tilt, draw(st.floats(0, 2 * math.pi)), draw(st.floats(-math.pi, math.pi))


@st.composite
def commands(draw, m: mujoco.MjModel, duration_s: float):
    """Piecewise-constant (left, right) wheel speeds up to twice the motors' range
    (the actuator clamps what the firmware would refuse), held 5-300 ms, with
    abrupt reversals."""
    nstep = int(round(duration_s / m.opt.timestep))
    limit = 2 * m.actuator_ctrlrange[:, 1]
    ctrl = np.empty((nstep, m.nu))
    i = 0
    while i < nstep:
        hold = max(1, int(draw(st.floats(0.005, 0.3)) / m.opt.timestep))
        value = [draw(st.floats(-lim, lim)) for lim in limit]
        if draw(st.booleans()) and i:
            value = -ctrl[i - 1]  # a full reversal
        ctrl[i:i + hold] = value
        i += hold
    return ctrl


def place(m: mujoco.MjModel, d: mujoco.MjData, pose) -> None:
    height, tilt_deg, axis_angle, yaw = pose
    mujoco.mj_resetData(m, d)
    axis = np.array([math.cos(axis_angle), math.sin(axis_angle), 0.0])
    tilt, turn, q = np.zeros(4), np.zeros(4), np.zeros(4)
    mujoco.mju_axisAngle2Quat(tilt, axis, math.radians(tilt_deg))
    mujoco.mju_axisAngle2Quat(turn, np.array([0.0, 0.0, 1.0]), yaw)
    mujoco.mju_mulQuat(q, turn, tilt)
    d.qpos[2], d.qpos[3:7] = height, q
    mujoco.mj_forward(m, d)


@PROPERTIES
@given(data=st.data())
@pytest.mark.slow
def test_random_command_sequences_stay_finite_warning_free_and_replay_bit_for_bit(data):
    m, config, integrator = data.draw(models())
    pose = data.draw(poses())
    ctrl = data.draw(commands(m, RUN_S[integrator]))
    d = mujoco.MjData(m)
    place(m, d, pose)
    states, sensors = rollout(m, d, ctrl, len(ctrl))
    warnings = {mujoco.mjtWarning(i).name: w.number for i, w in enumerate(d.warning) if w.number}
    assert not warnings, (warnings, config, pose)
    assert np.isfinite(states).all() and np.isfinite(sensors).all(), (config, pose)
    place(m, d, pose)
    again, sensors_again = rollout(m, d, ctrl, len(ctrl))
    assert np.array_equal(states, again) and np.array_equal(sensors, sensors_again)


def tire_energy(m: mujoco.MjModel, d: mujoco.MjData, ref: tr.TireReference) -> float:
    """Energy stored in the tires: vertical spring, contact-point springs, and the
    contact points' kinetic energy (none of it is in mjData.energy)."""
    p, energy = ref.params, 0.0
    for w, wheel in enumerate(ref.wheels):
        state = ref._state(d.plugin_state, w).reshape(2, 3)  # x, y: [s, v_c, stuck]
        contact = tr.wheel_contact(m, d, wheel, ref.floors)
        if contact is not None and contact[0].compression > 0:
            energy += 0.5 * p.stiffness_z * contact[0].compression ** 2
        energy += 0.5 * (p.stiffness_x * state[0, 0] ** 2 + p.stiffness_y * state[1, 0] ** 2)
        energy += 0.5 * p.contact_mass * (state[0, 1] ** 2 + state[1, 1] ** 2)
    return energy


# With zero commands every force on the robot is passive: gravity, the motors
# holding zero speed (a damper), the tire law (springs, dampers, friction) and
# the chassis's native contacts.  The discrete energy still ripples: at 0.1 ms
# the largest rise of the total over any window was 1.8e-4 J in a 0.5 s drop
# with the default tires, 1e-5 J at 2e-5 s (second order in the step), and
# random coulomb attributes gave up to 2.4e-3 J.  1e-2 J
# is 50x the default tires' ripple and still 100x below what a sign error in any
# damper would inject (D v^2 ~ 1 W over the run).
ENERGY_RIPPLE_J = 1e-2


# The tire law's passivity, on the shipped tire and on random `coulomb`
# attributes.  MuJoCo's native contacts are switched off (energy_rise): they are
# soft constraints, not energy-conserving, and the chassis touching the floor
# gained up to 2.0 J in runs where no tire carried load (found by this property
# before they were off; a robot released tilted 12 deg, seed 447 below).  The
# thesis's relay (`contact_point="relay"`, eq. 6.4 as its Simulink model
# integrates it) is not passive by construction, pinned by the last test.
PASSIVITY_EXAMPLES = max(10, PROPERTY_EXAMPLES // 4)


@settings(PROPERTIES, max_examples=PASSIVITY_EXAMPLES)
@given(seed=st.integers(0, 2**32 - 1),
       tire=st.sampled_from(["defaults", "coulomb", "combined"]),
       drop_m=st.floats(0.0, 0.1), tilt_deg=st.floats(0, 15), speed=st.floats(0.0, 1.0))
@pytest.mark.slow
def test_with_zero_commands_the_energy_never_grows(seed, tire, drop_m, tilt_deg, speed):
    rng = np.random.default_rng(seed)
    config = None if tire == "defaults" else random_config(
        rng, contact_point="coulomb", slip_law="combined" if tire == "combined" else None)
    assert energy_rise(config, rng, drop_m, tilt_deg, speed) <= ENERGY_RIPPLE_J


@pytest.mark.parametrize("seed, config_seed, drop_m, tilt_deg, speed", [
    (447, None, 0.0028, 12.03, 0.0),  # released tilted: 2.0 J with native contacts on
    (35, 35, 0.0, 6.0, 1.0),  # K_z 1.9e5, D_z 29, K_y 5.0e3, m_t 0.098: 0.76 J with them on
])
def test_energy_cases_that_native_contacts_had_raised(seed, config_seed, drop_m, tilt_deg, speed):
    rng = np.random.default_rng(seed)
    config = None if config_seed is None else random_config(rng, contact_point="coulomb")
    assert energy_rise(config, rng, drop_m, tilt_deg, speed) <= ENERGY_RIPPLE_J


def test_the_thesis_relay_is_not_passive():
    # while the relay is off the contact point obeys m_t dv/dt = -D v: the floor
    # holds it with -(K s + D u) and does work -(K s + D u) v on it while it still
    # moves.  Found by the property above when it drew the relay: 0.14 J in
    # 17 ms, 14x the ripple allowed; with native contacts on or off alike.
    rng = np.random.default_rng(66)
    config = random_config(rng, contact_point="relay")
    assert energy_rise(config, rng, 0.0, 0.0, 1.0) > 10 * ENERGY_RIPPLE_J


def energy_rise(config, rng, drop_m, tilt_deg, speed) -> float:
    """The largest rise of the total energy (J) over any window of a 0.4 s run with
    zero commands, from a pose dropped drop_m and tilted tilt_deg, moving at speed."""
    spec = load_spec("extended", "concrete", tire=config)
    m = spec.compile()
    m.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT  # the tires only (above)
    d = mujoco.MjData(m)
    place(m, d, (0.23 + drop_m, tilt_deg, rng.uniform(0, 2 * math.pi), 0.0))
    d.qvel[:6] = speed * rng.normal(size=6) / math.sqrt(6)  # up to ~1 m/s and 1 rad/s
    ref = tr.TireReference(m, tr.TireParams.from_config(dict(spec.plugins[0].config)))
    energy = np.empty(int(round(0.4 / m.opt.timestep)))
    for i in range(len(energy)):
        mujoco.mj_forward(m, d)
        energy[i] = d.energy.sum() + tire_energy(m, d, ref)
        mujoco.mj_step(m, d)
    return float((energy - np.minimum.accumulate(energy)).max())
