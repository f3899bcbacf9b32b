// The tire law of the thesis, Ch. 4, per wheel and per direction.
// tests/tire_reference.py is the same law written for reading; the
// tests require both to agree to ~1e-12 relative on random inputs.

#include "tire.h"

#include <math.h>

mjtNum tire_normal_force(const tireParams* p, const tireKinematics* k) {
  if (k->compression <= 0) {
    return 0;  // wheel off the floor
  }
  // eq. 4.15 with the integral of v_z replaced by the measured compression,
  // clamped at zero: the floor pushes, it never pulls (Sec. 4.3).
  mjtNum normal = p->stiffness_z * k->compression + p->damping_z * k->compression_rate;
  return normal > 0 ? normal : 0;
}


// The normal-load coupling of the lateral stiffness (attributes
// stiffness_y_load_exponent n, reference_load N_0; off at n = 0): a tire's
// lateral stiffness grows with the load it carries (the Magic Formula's cornering
// stiffness, c1 sin(2 atan(N / c2)), is proportional to N well below c2; Pacejka,
// Tire and Vehicle Dynamics, 2012, Ch. 4), so K_y (N / N_0)^n with K_y the
// stiffness measured at N_0.  The deflection is the state: a change of load at a
// given deflection changes the force (the coupling of the lateral force to the
// wheel's load that the roll and pitch motions modulate).
mjtNum tire_lateral_stiffness(const tireParams* p, mjtNum normal) {
  if (p->stiffness_y_load_exponent == 0) {
    return p->stiffness_y;
  }
  return p->stiffness_y * pow(normal / p->reference_load, p->stiffness_y_load_exponent);
}


static mjtNum sign(mjtNum x) {
  return (mjtNum)((x > 0) - (x < 0));
}


// mu_x, mu_y of eq. 4.12a/b and, when slope is not NULL, d mu_x / d u_x and
// d mu_y / d u_y within the branch taken (0 where a factor is saturated).
static void friction_thesis(const tireParams* p, const tireKinematics* k, mjtNum mu[2],
                            mjtNum* slope) {
  mjtNum rolling = fabs(k->rolling_speed);
  mjtNum slip_x = fabs(k->slip_x);
  mjtNum slip_y = fabs(k->slip_y);

  // |lambda| of eq. 2.7, saturated at 1 as in Sec. 2.1.1; a wheel that does not
  // turn slides with |lambda| = 1 (the thesis's NaN/inf converter, Sec. 6.1).
  mjtNum lambda = rolling > 0 ? fmin(1, slip_x / rolling) : 1;

  if (lambda < p->lambda_max) {
    // eq. 4.12a: mu_x = k_s |lambda| with k_s = 1/lambda_max, and eq. 4.12b
    // simplified as in Sec. 4.1: mu_y = |v_y| / (r |omega| lambda_max).
    // lambda < lambda_max <= 1 implies rolling > 0 here.
    mjtNum scale = rolling * p->lambda_max;
    mu[TIRE_DIR_X] = lambda / p->lambda_max;
    mu[TIRE_DIR_Y] = fmin(1, slip_y / scale);
    if (slope) {
      slope[TIRE_DIR_X] = sign(k->slip_x) / scale;
      slope[TIRE_DIR_Y] = slip_y < scale ? sign(k->slip_y) / scale : 0;
    }
  } else {
    // eq. 4.12a saturated, eq. 4.12b: mu_y = tan(theta) = |v_y| / |Delta v_x|,
    // saturated at 1 (Sec. 4.1); no longitudinal slip at all means full grip.
    mu[TIRE_DIR_X] = 1;
    mu[TIRE_DIR_Y] = slip_x > 0 ? fmin(1, slip_y / slip_x) : 1;
    if (slope) {
      slope[TIRE_DIR_X] = 0;
      slope[TIRE_DIR_Y] = slip_x > 0 && slip_y < slip_x ? sign(k->slip_y) / slip_x : 0;
    }
  }
}


// The friction ellipse (slip_law="combined"): Coulomb friction on the resultant
// slip velocity u = (u_x, u_y), limits mu_x,max and mu_y,max = rho mu_x,max.  By
// maximum dissipation the force opposes (u_x, rho^2 u_y) and lies on the ellipse,
// so with q = sqrt(u_x^2 + rho^2 u_y^2) the factors of the two directions' limits
// (both relative to mu_x,max) are g |u_x| / q and rho^2 g |u_y| / q, where
// g = min(1, q / (r |omega| lambda_max)) carries eq. 4.12a's linear rise of a
// rolling wheel's friction with slip (g = 1 for a wheel that does not roll).
// At rho = 1 it agrees with eq. 4.12a/b in pure longitudinal slip, in pure
// lateral slip and throughout the linear regime; it differs in combined slip
// beyond it, where eq. 4.12a/b's resultant exceeds mu N.
static void friction_combined(const tireParams* p, const tireKinematics* k, mjtNum mu[2],
                              mjtNum* slope) {
  mjtNum rho = p->lateral_ratio;
  mjtNum rolling = fabs(k->rolling_speed);
  mjtNum slip_x = fabs(k->slip_x);
  mjtNum slip_y = rho * fabs(k->slip_y);  // the lateral slip in the ellipse's metric
  mjtNum q = sqrt(slip_x * slip_x + slip_y * slip_y);
  mjtNum scale = rolling * p->lambda_max;

  if (q < scale) {
    // linear regime (rolling > 0): g / q = 1 / scale
    mu[TIRE_DIR_X] = slip_x / scale;
    mu[TIRE_DIR_Y] = rho * slip_y / scale;
    if (slope) {
      slope[TIRE_DIR_X] = sign(k->slip_x) / scale;
      slope[TIRE_DIR_Y] = rho * rho * sign(k->slip_y) / scale;
    }
  } else if (q > 0) {
    mjtNum q3 = q * q * q;
    mu[TIRE_DIR_X] = slip_x / q;
    mu[TIRE_DIR_Y] = rho * slip_y / q;
    if (slope) {
      slope[TIRE_DIR_X] = sign(k->slip_x) * slip_y * slip_y / q3;
      slope[TIRE_DIR_Y] = rho * rho * sign(k->slip_y) * slip_x * slip_x / q3;
    }
  } else {
    // a wheel at rest on the floor: each direction holds up to its full limit
    mu[TIRE_DIR_X] = 1;
    mu[TIRE_DIR_Y] = rho;
    if (slope) slope[TIRE_DIR_X] = slope[TIRE_DIR_Y] = 0;
  }
}


static void friction(const tireParams* p, const tireKinematics* k, mjtNum mu[2],
                     mjtNum* slope) {
  if (p->combined_slip) {
    friction_combined(p, k, mu, slope);
    return;
  }
  friction_thesis(p, k, mu, slope);
  if (p->lateral_ratio != 1) {  // the ellipse's lateral axis, eq. 4.12b's factor kept
    mu[TIRE_DIR_Y] *= p->lateral_ratio;
    if (slope) slope[TIRE_DIR_Y] *= p->lateral_ratio;
  }
}


void tire_friction_factors(const tireParams* p, const tireKinematics* k, mjtNum mu[2]) {
  friction(p, k, mu, NULL);
}


// Spring-damper force that the tire puts on the wheel along one direction
// (first line of eq. 4.9 / 4.13): f = -D (u - v_c) - K s.
static mjtNum direction_force(mjtNum stiffness, mjtNum damping, mjtNum drive,
                              const mjtNum* st) {
  return -damping * (drive - st[TIRE_VELOCITY]) - stiffness * st[TIRE_DEFLECTION];
}


void tire_forces(const tireParams* p, const tireKinematics* k, const mjtNum* state,
                 mjtNum force[3]) {
  mjtNum normal = tire_normal_force(p, k);
  force[0] = normal;
  if (normal <= 0) {
    // no normal force, no friction: the tire carries no tangential load
    force[1] = force[2] = 0;
    return;
  }
  force[1] = direction_force(p->stiffness_x, p->damping_x, k->slip_x,
                             state + TIRE_DIR_X * TIRE_NSTATE_DIR);
  force[2] = direction_force(tire_lateral_stiffness(p, normal), p->damping_y, k->slip_y,
                             state + TIRE_DIR_Y * TIRE_NSTATE_DIR);
}


// One substep's end-of-substep slope d f / d drive, the state's derivatives carried in
// chain ([d s / d drive, d v / d drive], updated) and d v' / d drive = dv.
static mjtNum chained_slope(mjtNum stiffness, mjtNum damping, mjtNum h, mjtNum dv,
                            mjtNum* chain) {
  chain[0] += h * (1 - dv);
  chain[1] = dv;
  return -damping * (1 - dv) - stiffness * chain[0];
}


// One implicit (backward Euler) step of the contact point along one direction.
//
// The contact point, mass m_t, is tied to the wheel rim by the spring K and
// damper D and rubs on the floor (eq. 4.2-4.9).  With s the deflection and v
// its velocity over the floor, driven by the rim velocity u:
//   ds/dt = u - v,   m_t dv/dt = K s + D (u - v) - F_k sign(v)   (slipping)
//   v = 0 while |K s + D u| <= F_s                                 (sticking)
// Sticking ends when the spring-damper force exceeds static friction F_s
// (eq. 4.9, first switching condition).  Slipping ends when the contact point
// stops, which the implicit Coulomb step detects exactly: the kinetic-friction
// impulse over the step is at least the momentum it would otherwise have.
// With m_t small that is the moment |K s + D u| falls to F_k (eq. 4.8), the
// relay condition of eq. 6.4; unlike eq. 6.4 the kinetic-friction term stays
// in, so a wheel in sustained slip feels kinetic friction.
//
// slope: when not NULL, receives d f / d drive of the end-of-step force
// f = -D (u - v') - K s' within the regime the step ends in, with
// kinetic_slope = d kinetic_limit / d drive (the slip-dependent friction of
// eq. 4.12): the stiffness the implicit coupling of tire_implicit.c needs.
//
// chain: when not NULL, the state's derivatives [d s / d drive, d v / d drive]
// from the earlier substeps of the same step, carried through this one (a
// step of several substeps, the drive held); *slope then receives d f / d drive
// with them: -D (1 - d v' / d drive) - K d s' / d drive.
static void advance_direction(mjtNum stiffness, mjtNum damping, mjtNum mass,
                              mjtNum static_limit, mjtNum kinetic_limit, mjtNum kinetic_slope,
                              mjtNum drive, mjtNum h, mjtNum* st, mjtNum* slope,
                              mjtNum* chain) {
  mjtNum deflection = st[TIRE_DEFLECTION];
  mjtNum velocity = st[TIRE_VELOCITY];
  mjtNum spring_damper = damping + h * stiffness;  // -d f / d (u - v') at fixed s

  if (st[TIRE_STUCK] > 0.5) {
    mjtNum deflection_next = deflection + h * drive;
    mjtNum holding = stiffness * deflection_next + damping * drive;
    if (fabs(holding) <= static_limit) {
      st[TIRE_DEFLECTION] = deflection_next;
      st[TIRE_VELOCITY] = 0;
      if (chain) {
        mjtNum chained = chained_slope(stiffness, damping, h, 0, chain);
        if (slope) *slope = chained;
      } else if (slope) {
        *slope = -spring_damper;
      }
      return;
    }
    velocity = 0;  // breaks away from rest
    if (chain) chain[1] = 0;
  }

  // backward Euler for (s, v), friction as an impulse that cannot reverse v
  mjtNum a = mass + h * damping + h * h * stiffness;
  mjtNum velocity_free = (mass * velocity
                          + h * (stiffness * deflection + (stiffness * h + damping) * drive)) / a;
  mjtNum friction_dv = h * kinetic_limit / a;
  mjtNum velocity_next, velocity_slope;
  if (fabs(velocity_free) > friction_dv) {
    velocity_next = velocity_free - copysign(friction_dv, velocity_free);
    // d/du of -sign(v) h F_k(u) / a: kinetic_slope keeps its own sign
    velocity_slope = (h * (stiffness * h + damping)
                      - (velocity_free > 0 ? 1 : -1) * h * kinetic_slope) / a;
    st[TIRE_STUCK] = 0;
  } else {
    velocity_next = 0;
    velocity_slope = 0;
    st[TIRE_STUCK] = 1;
  }
  st[TIRE_VELOCITY] = velocity_next;
  st[TIRE_DEFLECTION] = deflection + h * (drive - velocity_next);
  if (chain) {
    // velocity_slope above is this substep's alone: add what the state carried in
    mjtNum dv = st[TIRE_STUCK] > 0.5 ? 0
                : velocity_slope + (mass * chain[1] + h * stiffness * chain[0]) / a;
    mjtNum chained = chained_slope(stiffness, damping, h, dv, chain);
    if (slope) *slope = chained;
  } else if (slope) {
    *slope = -spring_damper * (1 - velocity_slope);
  }
}


// One implicit step of eq. 6.4 as the thesis's Simulink model has it (Sec. 6.1):
// the contact point obeys m_t dv/dt + D v = F' with F' = K s + D u while the
// relay flag is on and F' = 0 while it is off, so that a released contact
// point decays to rest instead of stopping; the relay switches on when |F'|
// exceeds the static limit and off when it falls below the kinetic limit.
// The kinetic-friction term is dropped (the thesis's zero-crossing fix) and so
// is m_t du/dt in F' (the wheel's acceleration; m_t = 0.035 kg makes it
// negligible next to D u).  The state's TIRE_STUCK holds the flag: 1 = off.
static void advance_direction_relay(mjtNum stiffness, mjtNum damping, mjtNum mass,
                                    mjtNum static_limit, mjtNum kinetic_limit,
                                    mjtNum kinetic_slope, mjtNum drive, mjtNum h, mjtNum* st,
                                    mjtNum* slope, mjtNum* chain) {
  (void)kinetic_slope;  // the relay's limits only switch it; they never enter the force
  mjtNum deflection = st[TIRE_DEFLECTION];
  mjtNum velocity = st[TIRE_VELOCITY];
  mjtNum driving = fabs(stiffness * deflection + damping * drive);  // |F'| at step start
  int off = st[TIRE_STUCK] > 0.5;
  if (off && driving > static_limit) {
    off = 0;
  } else if (!off && driving < kinetic_limit) {
    off = 1;
  }
  mjtNum velocity_next, velocity_slope;
  mjtNum carried;  // d v' / d drive from the state carried in (chain)
  if (off) {
    velocity_next = mass * velocity / (mass + h * damping);
    velocity_slope = 0;
    carried = chain ? mass * chain[1] / (mass + h * damping) : 0;
  } else {
    mjtNum a = mass + h * damping + h * h * stiffness;
    velocity_next = (mass * velocity
                     + h * (stiffness * deflection + (stiffness * h + damping) * drive)) / a;
    velocity_slope = h * (stiffness * h + damping) / a;
    carried = chain ? (mass * chain[1] + h * stiffness * chain[0]) / a : 0;
  }
  if (chain) {
    mjtNum chained = chained_slope(stiffness, damping, h, velocity_slope + carried, chain);
    if (slope) *slope = chained;
  } else if (slope) {
    *slope = -(damping + h * stiffness) * (1 - velocity_slope);
  }
  st[TIRE_STUCK] = off;
  st[TIRE_VELOCITY] = velocity_next;
  st[TIRE_DEFLECTION] = deflection + h * (drive - velocity_next);
}


// The falling branch of kinetic friction (attributes sliding_friction_ratio,
// sliding_velocity; off at alpha_s = 1): the kinetic limit is multiplied by
//   g(v) = alpha_s + (1 - alpha_s) exp(-(v / v_S)^2),
// v = |(u_x, u_y)| the rim's sliding speed over the floor at the contact point, a
// Stribeck-type curve (Armstrong-Helouvry 1994, exponent 2) that falls from 1 at
// rest to alpha_s at fast sliding, as rubber's does above its peak (Grosch 1963;
// Persson 2001) and as eq. 2.29b's sliding branch does in slip.  It multiplies
// the kinetic limit only: static friction, which holds a contact point at rest
// over the floor, is unchanged, so kinetic never exceeds static.  grad[d] =
// d g / d u_d (the implicit coupling's slopes).
static mjtNum sliding_factor(const tireParams* p, const tireKinematics* k, mjtNum grad[2]) {
  if (p->sliding_ratio >= 1) {
    if (grad) grad[0] = grad[1] = 0;
    return 1;
  }
  mjtNum vs2 = p->sliding_velocity * p->sliding_velocity;
  mjtNum falling = (1 - p->sliding_ratio)
                   * exp(-(k->slip_x * k->slip_x + k->slip_y * k->slip_y) / vs2);
  if (grad) {
    grad[TIRE_DIR_X] = -2 * falling * k->slip_x / vs2;
    grad[TIRE_DIR_Y] = -2 * falling * k->slip_y / vs2;
  }
  return p->sliding_ratio + falling;
}


// Advances one wheel's state by h; slope (when not NULL): d f_d / d u_d; mean
// (when not NULL and contact_substeps > 1): each direction's mean force over the
// substeps, the force whose impulse over h is theirs.
static void advance_wheel(const tireParams* p, const tireKinematics* k, mjtNum h,
                          mjtNum* state, mjtNum* slope, mjtNum* mean) {
  mjtNum normal = tire_normal_force(p, k);
  if (normal <= 0) {
    tire_reset_state(state);  // unloaded tire relaxes; it lands undeflected
    if (slope) slope[0] = slope[1] = 0;
    if (mean) mean[0] = mean[1] = 0;
    return;
  }
  mjtNum mu[2], mu_slope[2] = {0, 0};
  friction(p, k, mu, slope ? mu_slope : NULL);
  mjtNum sliding_grad[2];
  mjtNum sliding = sliding_factor(p, k, sliding_grad);
  const mjtNum stiffness[2] = {p->stiffness_x, tire_lateral_stiffness(p, normal)};
  const mjtNum damping[2] = {p->damping_x, p->damping_y};
  const mjtNum drive[2] = {k->slip_x, k->slip_y};
  int n = p->contact_substeps > 1 ? p->contact_substeps : 1;
  for (int dir = 0; dir < TIRE_NDIR; dir++) {
    // eq. 4.10: static and kinetic limits scale with the slip factor
    void (*step)(mjtNum, mjtNum, mjtNum, mjtNum, mjtNum, mjtNum, mjtNum, mjtNum, mjtNum*,
                 mjtNum*, mjtNum*) = p->relay ? advance_direction_relay : advance_direction;
    // d (mu sliding) / d u within the branch taken (the cross-direction term of
    // the sliding speed is left to the coupling's line search)
    mjtNum kinetic_slope = mu_slope[dir] * sliding + mu[dir] * sliding_grad[dir];
    mjtNum static_limit = p->mu_static * mu[dir] * normal;
    mjtNum kinetic_limit = p->mu_kinetic * mu[dir] * sliding * normal;
    mjtNum* st = state + dir * TIRE_NSTATE_DIR;
    if (n == 1) {
      step(stiffness[dir], damping[dir], p->contact_mass, static_limit, kinetic_limit,
           p->mu_kinetic * kinetic_slope * normal, drive[dir], h, st,
           slope ? slope + dir : NULL, NULL);
      continue;
    }
    // the contact point on its own clock: n substeps of h / n, the rim's slip held
    mjtNum chain[2] = {0, 0}, force_sum = 0, slope_sum = 0, substep_slope = 0;
    for (int i = 0; i < n; i++) {
      step(stiffness[dir], damping[dir], p->contact_mass, static_limit, kinetic_limit,
           p->mu_kinetic * kinetic_slope * normal, drive[dir], h / n, st,
           &substep_slope, chain);
      force_sum += direction_force(stiffness[dir], damping[dir], drive[dir], st);
      slope_sum += substep_slope;
    }
    if (slope) slope[dir] = slope_sum / n;
    if (mean) mean[dir] = force_sum / n;
  }
}


void tire_advance(const tireParams* p, const tireKinematics* k, mjtNum h, mjtNum* state) {
  advance_wheel(p, k, h, state, NULL, NULL);
}


void tire_step_force(const tireParams* p, const tireKinematics* k, mjtNum h,
                     const mjtNum* state, mjtNum force[3], mjtNum slope[2]) {
  mjtNum next[TIRE_NSTATE_WHEEL];
  for (int i = 0; i < TIRE_NSTATE_WHEEL; i++) next[i] = state[i];
  mjtNum mean[2];
  advance_wheel(p, k, h, next, slope, mean);
  tire_forces(p, k, next, force);  // the spring-damper force at the end of the step
  if (p->contact_substeps > 1 && force[0] > 0) {
    force[1] = mean[TIRE_DIR_X];
    force[2] = mean[TIRE_DIR_Y];
  }
}


void tire_reset_state(mjtNum* state) {
  for (int dir = 0; dir < TIRE_NDIR; dir++) {
    mjtNum* st = state + dir * TIRE_NSTATE_DIR;
    st[TIRE_DEFLECTION] = 0;
    st[TIRE_VELOCITY] = 0;
    st[TIRE_STUCK] = 1;
  }
}
