// skidsteer.tire: spring-damper stick-slip tire law for skid-steer robots.
//
// The law is Ch. 4 of S. Mafrica, "Advance Modeling of a Skid-Steering Mobile
// Robot for Remote Telepresence", MSc thesis, 2012 (the "thesis" below); see
// plugin/tire/README.md for every attribute, its default and its source.
//
// The functions here are pure: they take the wheel kinematics and the
// per-wheel state and return forces or the next state.  The plugin's units
// (tire_internal.h) wire them to MuJoCo; tests/tire_reference.py is the readable
// reference that the tests hold this code to.

#ifndef SKIDSTEER_PLUGIN_TIRE_TIRE_H_
#define SKIDSTEER_PLUGIN_TIRE_TIRE_H_

#include <mujoco/mujoco.h>

// Parameters of one tire law instance (SI units).
typedef struct {
  mjtNum mu_static;        // mu_s_max, static friction coefficient (eq. 4.10)
  mjtNum mu_kinetic;       // mu_k_max, kinetic friction coefficient (eq. 4.10)
  mjtNum stiffness_z;      // K_z, vertical tire stiffness, N/m (eq. 4.15)
  mjtNum damping_z;        // D_z, vertical tire damping, N s/m (eq. 4.15)
  mjtNum stiffness_y;      // K_y, lateral tire stiffness, N/m (eq. 4.9)
  mjtNum damping_y;        // D_y, lateral tire damping, N s/m (eq. 4.9)
  mjtNum stiffness_x;      // K_x = series(tread, belt), N/m (eq. 4.13, 4.14)
  mjtNum damping_x;        // D_x = series(tread, belt), N s/m (eq. 4.13, 4.14)
  mjtNum contact_mass;     // m_t, contact-point mass, kg (eq. 4.9)
  mjtNum lambda_max;       // slip at which friction saturates (eq. 4.12a)
  mjtNum sliding_ratio;    // alpha_s: kinetic friction at fast sliding over mu_kinetic (eq. 2.29b);
                           //   1: off, the law of Ch. 4
  mjtNum sliding_velocity; // v_S, m/s: Stribeck velocity of the falling branch
  mjtNum stiffness_y_load_exponent;  // n: K_y scales as (N / N_0)^n; 0: off, the law of Ch. 4
  mjtNum reference_load;   // N_0, N: the normal load at which K_y holds
  int combined_slip;       // 0: eq. 4.12a/b per direction; 1: friction limit on the
                           //   resultant slip (the friction ellipse)
  mjtNum lateral_ratio;    // mu_y,max / mu_x,max: the ellipse's axes (1: isotropic), the
                           //   floor's ratio times the tread's
  int relay;               // 0: Coulomb contact point (eq. 4.9/4.13, kinetic friction kept);
                           // 1: eq. 6.4 as the thesis simulated it (relay, no kinetic friction)
  int contact_substeps;    // the contact points' steps per body step (1: one, the
                           //   step's own); the force is their mean (the same impulse)
} tireParams;

// Per-direction contact-point state, stored in plugin_state.
enum {
  TIRE_DEFLECTION = 0,     // s: tire deflection, integral of (u - v_c), m
  TIRE_VELOCITY,           // v_c: contact-point velocity over the floor, m/s
  TIRE_STUCK,              // 1: contact point sticks (static friction), 0: slips
  TIRE_NSTATE_DIR
};
enum { TIRE_DIR_X = 0, TIRE_DIR_Y = 1, TIRE_NDIR = 2 };
#define TIRE_NSTATE_WHEEL (TIRE_NSTATE_DIR * TIRE_NDIR)

// What the law needs from the wheel kinematics at one instant.
typedef struct {
  mjtNum compression;       // delta > 0: tire compressed against the floor, m
  mjtNum compression_rate;  // d(delta)/dt, m/s
  mjtNum slip_x;            // u_x = Delta v_x = v_x - r*omega, rim velocity along the
                            //   rolling direction (eq. 2.7), m/s
  mjtNum slip_y;            // u_y = v_y, rim velocity across the wheel, m/s
  mjtNum rolling_speed;     // r*omega, m/s
} tireKinematics;

// Normal force N >= 0 (eq. 4.15, clamped so that the wheel can lift).
mjtNum tire_normal_force(const tireParams* p, const tireKinematics* k);

// Slip-dependent friction factors mu_x, mu_y in [0, 1] (eq. 4.12a/b, saturated).
void tire_friction_factors(const tireParams* p, const tireKinematics* k, mjtNum mu[2]);

// The lateral stiffness at normal load N > 0: K_y (N / N_0)^n (n = 0: K_y).
mjtNum tire_lateral_stiffness(const tireParams* p, mjtNum normal);

// Forces on the wheel in the contact frame [N, f_x, f_y] from the state at the
// start of the step (eq. 4.9, 4.13, 4.15).  state: TIRE_NSTATE_WHEEL numbers.
void tire_forces(const tireParams* p, const tireKinematics* k, const mjtNum* state,
                 mjtNum force[3]);

// Advance one wheel's contact-point state by h seconds, implicitly.
void tire_advance(const tireParams* p, const tireKinematics* k, mjtNum h, mjtNum* state);

// The force [N, f_x, f_y] on the wheel over a step of h seconds in which the rim
// slips at k->slip_x, k->slip_y (the contact-point state advanced from `state`,
// which is left unchanged): the force at the end of the step, or with
// contact_substeps > 1 the mean of the force at the end of each substep (the
// substeps' impulse over h); slope[d] = d f_d / d u_d within the regimes (stick,
// slip, relay on/off) the substeps end in.  The implicit coupling of
// tire_implicit.c solves for the slips at which these forces move the robot.
void tire_step_force(const tireParams* p, const tireKinematics* k, mjtNum h,
                     const mjtNum* state, mjtNum force[3], mjtNum slope[2]);

// Reset one wheel's state: no deflection, contact point at rest and sticking.
void tire_reset_state(mjtNum* state);

#endif  // SKIDSTEER_PLUGIN_TIRE_TIRE_H_
