// The plugin's attributes: the contract's tables (tire_contract.h) of every
// attribute with its default, bounds, unit and source, of the floors it knows by
// name and of the state layout; and an instance's attributes read and validated
// against these tables alone.

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "tire.h"
#include "tire_contract.h"
#include "tire_internal.h"

// The plugin's contract (tire_contract.h): every attribute with its default,
// bounds, unit and source; the floors it knows by name; the state layout.
// tire_read_params() validates an instance's attributes against this table alone.
enum {
  ATTR_FLOOR = 0,
  ATTR_MU_STATIC,
  ATTR_MU_KINETIC,
  ATTR_STIFFNESS_Z,
  ATTR_DAMPING_Z,
  ATTR_STIFFNESS_Y,
  ATTR_DAMPING_Y,
  ATTR_BELT_STIFFNESS,
  ATTR_BELT_DAMPING,
  ATTR_TREAD_STIFFNESS_X,
  ATTR_TREAD_DAMPING_X,
  ATTR_CONTACT_MASS,
  ATTR_LAMBDA_MAX,
  ATTR_CONTACT_POINT,
  ATTR_RADIUS,
  ATTR_COUPLING,
  ATTR_SLIDING_FRICTION_RATIO,
  ATTR_SLIDING_VELOCITY,
  ATTR_STIFFNESS_Y_LOAD_EXPONENT,
  ATTR_REFERENCE_LOAD,
  ATTR_LUG_COUNT,
  ATTR_LUG_DEPTH,
  ATTR_FLOOR_INTERPOLATION,
  ATTR_FLOOR_NORMAL,
  ATTR_SLIP_LAW,
  ATTR_LATERAL_FRICTION_RATIO,
  ATTR_TREAD_LATERAL_FRICTION_RATIO,
  ATTR_CONTACT_SUBSTEPS,
  TIRE_NATTRIBUTE
};

#define POSITIVE "must be a finite number > 0"
#define NONNEGATIVE "must be a finite number >= 0"

// The floor attribute's words and rule, written from kFloors when the library loads.
static char kFloorNames[128];
static char kFloorRule[192];

static const skidsteerTireAttribute kAttributeTable[TIRE_NATTRIBUTE] = {
  [ATTR_FLOOR] = {
      .name = "floor", .symbol = "", .kind = SKIDSTEER_TIRE_CHOICE,
      .default_value = NAN, .default_text = "concrete",
      .low = 0, .high = 0, .low_open = 0, .high_open = 0, .finite = 0,
      .choices = kFloorNames, .unit = "",
      .rule = kFloorRule,
      .source = "the friction set of a floor measured in Sec. 3.3 (the floors table)"},
  [ATTR_MU_STATIC] = {
      .name = "mu_static", .symbol = "mu_s,max", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = NAN, .default_text = "from floor",
      .low = 0, .high = INFINITY, .low_open = 1, .high_open = 0, .finite = 1,
      .choices = "", .unit = "",
      .rule = POSITIVE,
      .source = "static friction coefficient (eq. 4.10); overrides the floor's"},
  [ATTR_MU_KINETIC] = {
      .name = "mu_kinetic", .symbol = "mu_k,max", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = NAN, .default_text = "from floor",
      .low = 0, .high = INFINITY, .low_open = 0, .high_open = 0, .finite = 1,
      .choices = "", .unit = "",
      .rule = NONNEGATIVE,
      .source = "kinetic friction coefficient (eq. 4.10); overrides the floor's; must be <= "
          "mu_static"},
  [ATTR_STIFFNESS_Z] = {
      .name = "stiffness_z", .symbol = "K_z", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 80000, .default_text = "80000",
      .low = 0, .high = INFINITY, .low_open = 1, .high_open = 0, .finite = 1,
      .choices = "", .unit = "N/m",
      .rule = POSITIVE,
      .source = "Sec. 3.3, Fig. 3.10(a): vertical compression of one wheel"},
  [ATTR_DAMPING_Z] = {
      .name = "damping_z", .symbol = "D_z", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 70, .default_text = "70",
      .low = 0, .high = INFINITY, .low_open = 0, .high_open = 0, .finite = 1,
      .choices = "", .unit = "N s/m",
      .rule = NONNEGATIVE,
      .source = "eq. 6.5 (fitted in the thesis to the roll/pitch free responses)"},
  [ATTR_STIFFNESS_Y] = {
      .name = "stiffness_y", .symbol = "K_y", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 18000, .default_text = "18000",
      .low = 0, .high = INFINITY, .low_open = 1, .high_open = 0, .finite = 1,
      .choices = "", .unit = "N/m",
      .rule = POSITIVE,
      .source = "Sec. 3.3, Fig. 3.9: single wheel dragged on wood (two-slope fit 15/21 kN/m); "
          "also the value eq. 5.10 uses"},
  [ATTR_DAMPING_Y] = {
      .name = "damping_y", .symbol = "D_y", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 30, .default_text = "30",
      .low = 0, .high = INFINITY, .low_open = 0, .high_open = 0, .finite = 1,
      .choices = "", .unit = "N s/m",
      .rule = NONNEGATIVE,
      .source = "eq. 6.5"},
  [ATTR_BELT_STIFFNESS] = {
      .name = "belt_stiffness", .symbol = "K_b", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 3000, .default_text = "3000",
      .low = 0, .high = INFINITY, .low_open = 1, .high_open = 0, .finite = 1,
      .choices = "", .unit = "N/m",
      .rule = POSITIVE,
      .source = "Sec. 3.3, eq. 3.8: saw-tooth ramps 5-7 kN/m over two belts"},
  [ATTR_BELT_DAMPING] = {
      .name = "belt_damping", .symbol = "D_b", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 50, .default_text = "50",
      .low = 0, .high = INFINITY, .low_open = 0, .high_open = 0, .finite = 1,
      .choices = "", .unit = "N s/m",
      .rule = NONNEGATIVE,
      .source = "eq. 6.5 (the thesis's D_x, with D_x ~ D_b by eq. 4.14)"},
  [ATTR_TREAD_STIFFNESS_X] = {
      .name = "tread_stiffness_x", .symbol = "K_tx", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = INFINITY, .default_text = "inf",
      .low = 0, .high = INFINITY, .low_open = 1, .high_open = 0, .finite = 0,
      .choices = "", .unit = "N/m",
      .rule = "must be > 0 (inf: rigid tread, the thesis's K_tx >> K_belt)",
      .source = "eq. 4.14: K_x = K_tx K_b / (K_tx + K_b); the thesis takes K_tx >> K_b"},
  [ATTR_TREAD_DAMPING_X] = {
      .name = "tread_damping_x", .symbol = "D_tx", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = INFINITY, .default_text = "inf",
      .low = 0, .high = INFINITY, .low_open = 1, .high_open = 0, .finite = 0,
      .choices = "", .unit = "N s/m",
      .rule = "must be > 0 (inf: the thesis's D_tx >> D_belt)",
      .source = "eq. 4.14, the same for damping"},
  [ATTR_CONTACT_MASS] = {
      .name = "contact_mass", .symbol = "m_t", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 0.035, .default_text = "0.035",
      .low = 0, .high = INFINITY, .low_open = 1, .high_open = 0, .finite = 1,
      .choices = "", .unit = "kg",
      .rule = POSITIVE,
      .source = "Sec. 6.2: half the 0.07 kg wheel; the thesis found 0.001-0.07 kg barely "
          "matters"},
  [ATTR_LAMBDA_MAX] = {
      .name = "lambda_max", .symbol = "lambda_max", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 0.1, .default_text = "0.1",
      .low = 0, .high = 1, .low_open = 1, .high_open = 0, .finite = 1,
      .choices = "", .unit = "",
      .rule = "must lie in (0, 1]",
      .source = "assumed: never identified; Sec. 6.2 suggests \"order 1e-1 to 1e-2\" and we "
          "take the upper end"},
  [ATTR_CONTACT_POINT] = {
      .name = "contact_point", .symbol = "", .kind = SKIDSTEER_TIRE_CHOICE,
      .default_value = NAN, .default_text = "coulomb",
      .low = 0, .high = 0, .low_open = 0, .high_open = 0, .finite = 0,
      .choices = "coulomb relay", .unit = "",
      .rule = "use coulomb (default) or relay (eq. 6.4 as the thesis simulated it)",
      .source = "coulomb: the contact point of eq. 4.9/4.13 with kinetic friction; relay: eq. "
          "6.4 as the thesis's Simulink model integrates it (relay flag on at mu_s, off at "
          "mu_k; kinetic friction and m_t du/dt dropped), the thesis's model as published"},
  [ATTR_RADIUS] = {
      .name = "radius", .symbol = "r", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 0, .default_text = "from geom",
      .low = 0, .high = INFINITY, .low_open = 0, .high_open = 0, .finite = 1,
      .choices = "", .unit = "m",
      .rule = "must be > 0, or unset to take each wheel's radius from its geom",
      .source = "unloaded wheel radius; unset (or 0): each wheel's cylinder or sphere geom"},
  [ATTR_COUPLING] = {
      .name = "coupling", .symbol = "", .kind = SKIDSTEER_TIRE_CHOICE,
      .default_value = NAN, .default_text = "explicit",
      .low = 0, .high = 0, .low_open = 0, .high_open = 0, .finite = 0,
      .choices = "explicit implicit", .unit = "",
      .rule = "use explicit (default) or implicit",
      .source = "numerics, not physics: explicit applies the forces of the start-of-step "
          "state; implicit solves each step for the end-of-step slips at which the tire "
          "forces of every wheel, stick/slip decided at the end of the step, move the robot "
          "(stable to 2 ms, yaw rate within 1 % at 1 ms; stick-slip vibration amplitudes "
          "still need 0.1 ms or less: README, Time step)"},
  [ATTR_SLIDING_FRICTION_RATIO] = {
      .name = "sliding_friction_ratio", .symbol = "alpha_s", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 1, .default_text = "1",
      .low = 0, .high = 1, .low_open = 1, .high_open = 0, .finite = 1,
      .choices = "", .unit = "",
      .rule = "must lie in (0, 1] (1: friction does not fall with sliding speed)",
      .source = "eq. 2.29b (the thesis's ref. [4]): sliding friction a fraction alpha_s of "
          "the peak; rubber's friction falls above a sliding speed (Grosch 1963; Persson "
          "2001); 1 (off): the law of Ch. 4, whose kinetic friction does not depend on speed"},
  [ATTR_SLIDING_VELOCITY] = {
      .name = "sliding_velocity", .symbol = "v_S", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 0.1, .default_text = "0.1",
      .low = 0, .high = INFINITY, .low_open = 1, .high_open = 0, .finite = 1,
      .choices = "", .unit = "m/s",
      .rule = POSITIVE,
      .source = "Stribeck velocity of the falling branch: kinetic friction times alpha_s + (1 "
          "- alpha_s) exp(-(v/v_S)^2), v the rim's sliding speed; assumed: the order of a "
          "swivel's sliding speeds (median 0.04, 0.10, 0.14 m/s at 20, 45, 64 deg/s, extended "
          "build on concrete, mostly lateral), within the mm/s-m/s span where tread rubber's "
          "friction peaks (Grosch 1963; Persson 2001); used only when alpha_s < 1"},
  [ATTR_STIFFNESS_Y_LOAD_EXPONENT] = {
      .name = "stiffness_y_load_exponent", .symbol = "n", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 0, .default_text = "0",
      .low = 0, .high = 2, .low_open = 0, .high_open = 0, .finite = 1,
      .choices = "", .unit = "",
      .rule = "must lie in [0, 2] (0: K_y does not depend on the load)",
      .source = "normal-load coupling of the lateral force: K_y (N / N_0)^n, a tire's lateral "
          "stiffness growing with its load as the Magic Formula's cornering stiffness does, "
          "proportional to N well below its rating (Pacejka, Tire and Vehicle Dynamics, 2012, "
          "Ch. 4); 0 (off): the law of Ch. 4, K_y independent of the load"},
  [ATTR_REFERENCE_LOAD] = {
      .name = "reference_load", .symbol = "N_0", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 56.25, .default_text = "56.25",
      .low = 0, .high = INFINITY, .low_open = 1, .high_open = 0, .finite = 1,
      .choices = "", .unit = "N",
      .rule = POSITIVE,
      .source = "the load at which K_y holds: Sec. 3.3's platform, 225 N on four wheels, in "
          "the pulls that measured the tire's lateral stiffness; used only when n > 0"},
  [ATTR_LUG_COUNT] = {
      .name = "lug_count", .symbol = "", .kind = SKIDSTEER_TIRE_INTEGER,
      .default_value = 0, .default_text = "0",
      .low = 0, .high = 1000, .low_open = 0, .high_open = 0, .finite = 1,
      .choices = "", .unit = "",
      .rule = "must be a whole number in [0, 1000] (0: a round wheel)",
      .source = "tread lugs per revolution: the rolling radius falls by up to lug_depth "
          "between lugs, a line at lug_count times the wheel's rotation rate and its "
          "harmonics (a lugged tyre on a hard floor; BorealTC's Husky shows 18, 36 and 54 on "
          "flooring and asphalt, docs/real-data/borealtc.md); every wheel's lugs start in "
          "phase with its joint angle (assumed); 0 (off): the round wheel of Ch. 4"},
  [ATTR_LUG_DEPTH] = {
      .name = "lug_depth", .symbol = "", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 0, .default_text = "0",
      .low = 0, .high = 0.05, .low_open = 0, .high_open = 0, .finite = 1,
      .choices = "", .unit = "m",
      .rule = "must lie in [0, 0.05] m",
      .source = "the drop of the wheel centre midway between two lugs, as a polygon of "
          "lug_count sides rolls (r (1 - cos(alpha)) / (1 - cos(pi / lug_count)) scaled to "
          "it, alpha the angle from the nearest lug); a rigid polygon of radius r drops r (1 "
          "- cos(pi / lug_count)), 2.5 mm for 18 lugs at 0.165 m; the tyre's carcass makes it "
          "less (fitted: no public value); used only when lug_count > 0"},
  [ATTR_FLOOR_INTERPOLATION] = {
      .name = "floor_interpolation", .symbol = "", .kind = SKIDSTEER_TIRE_CHOICE,
      .default_value = NAN, .default_text = "cubic",
      .low = 0, .high = 0, .low_open = 0, .high_open = 0, .finite = 0,
      .choices = "cubic triangles", .unit = "",
      .rule = "use cubic (default) or triangles",
      .source = "geometry of a heightfield floor between its samples: cubic, the "
          "interpolating cubic B-spline through the samples (mirror ends, as scipy.ndimage's "
          "mode='mirror'), smooth to its curvature, with the floor's slope under the moving "
          "wheel in d(delta)/dt (eq. 4.15); triangles: MuJoCo's triangulation (mj_rayHfield), "
          "whose slope jumps at every grid line, a line at v / (grid spacing) in the loads "
          "that the sampled floor does not have, and whose d(delta)/dt leaves the floor's "
          "slope out (the plugin until 2026-12); planes are the same under both"},
  [ATTR_FLOOR_NORMAL] = {
      .name = "floor_normal", .symbol = "", .kind = SKIDSTEER_TIRE_CHOICE,
      .default_value = NAN, .default_text = "vertical",
      .low = 0, .high = 0, .low_open = 0, .high_open = 0, .finite = 0,
      .choices = "vertical surface", .unit = "",
      .rule = "use vertical (default) or surface; surface needs floor_interpolation=\"cubic\"",
      .source = "the contact normal on a heightfield floor: vertical, the floor geom's up "
          "whatever the slope under the wheel (the normal force carries no fore-aft or "
          "sideways part on a bump; the plugin until 2026-12); surface, the cubic floor's own "
          "normal under the wheel centre (up - dh/dx x - dh/dy y, normalised), so the normal "
          "force pushes back on a rising slope and the friction acts in the floor's tangent "
          "plane, as on a tilted plane; compression measured along it.  A heightfield read as "
          "MuJoCo's triangles has no normal here (floor_interpolation=\"triangles\" with "
          "surface is refused); planes are the same under both"},
  [ATTR_SLIP_LAW] = {
      .name = "slip_law", .symbol = "", .kind = SKIDSTEER_TIRE_CHOICE,
      .default_value = NAN, .default_text = "thesis",
      .low = 0, .high = 0, .low_open = 0, .high_open = 0, .finite = 0,
      .choices = "thesis combined", .unit = "",
      .rule = "use thesis (default) or combined",
      .source = "how the friction limits share a slip that is both longitudinal and lateral: "
          "thesis, eq. 4.12a/b (mu_x = 1 and mu_y = min(1, |v_y| / |Delta v_x|) once |lambda| "
          "> lambda_max, a resultant up to sqrt(2) mu N); combined, Coulomb friction on the "
          "resultant slip velocity (the friction circle, or ellipse with "
          "lateral_friction_ratio: maximum dissipation, Goyal, Ruina & Papadopoulos 1991; the "
          "skid-steer force model of Wong & Chiang 2001 and Yu et al. 2010), magnitude min(1, "
          "|slip| / (r |omega| lambda_max)); both agree in pure longitudinal and pure lateral "
          "slip"},
  [ATTR_LATERAL_FRICTION_RATIO] = {
      .name = "lateral_friction_ratio", .symbol = "mu_y/mu_x", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 1, .default_text = "1",
      .low = 0, .high = 10, .low_open = 1, .high_open = 0, .finite = 1,
      .choices = "", .unit = "",
      .rule = "must lie in (0, 10]",
      .source = "the floor's lateral over longitudinal friction (static and kinetic alike): "
          "the friction ellipse's axes; 1: isotropic, as the thesis takes the lateral pulls "
          "of Sec. 3.3 (the only friction it measured) for both directions"},
  [ATTR_TREAD_LATERAL_FRICTION_RATIO] = {
      .name = "tread_lateral_friction_ratio", .symbol = "", .kind = SKIDSTEER_TIRE_NUMBER,
      .default_value = 1, .default_text = "1",
      .low = 0, .high = 10, .low_open = 1, .high_open = 0, .finite = 1,
      .choices = "", .unit = "",
      .rule = "must lie in (0, 10]",
      .source = "the tyre's lateral over longitudinal friction on any floor (its tread: lugs "
          "and blocks that grip along and slide across), multiplying the floor's "
          "lateral_friction_ratio: a robot's property where lateral_friction_ratio is a "
          "floor's; 1: isotropic (the thesis's tyres, Sec. 3.3)"},
  [ATTR_CONTACT_SUBSTEPS] = {
      .name = "contact_substeps", .symbol = "", .kind = SKIDSTEER_TIRE_INTEGER,
      .default_value = 1, .default_text = "1",
      .low = 1, .high = 1000, .low_open = 0, .high_open = 0, .finite = 1,
      .choices = "", .unit = "",
      .rule = "must be a whole number in [1, 1000] (1: the step's own clock)",
      .source = "numerics, not physics: the contact points' backward-Euler steps per body "
          "step, with coupling=\"implicit\" only; the rim's slip held over the step, the body "
          "given the substeps' mean force (their impulse); measured: the 10 deg/s stick-slip "
          "line converges at 1e-5 s with 10, not at 1 ms with any (README, The contact points "
          "on their own clock)"},
};

// Floors measured in the thesis (Sec. 3.3, lateral pull tests of the platform, 225 N).
static const skidsteerTireFloor kFloors[] = {
  {"concrete", 0.86, 0.786,
   "mu_s: mean peak of 180-200 N / 225 N; mu_k: Sec. 4.1 states F_s,min - F_k,min = "
   "(mu_s,max - mu_k,max) * 0.12 * 225 N ~ 2 N, so mu_k,max = 0.86 - 2/27 = 0.786"},
  {"tile", 0.86, 0.786,
   "assumed equal to concrete: no pull test on tile; Sec. 3.2 finds tile and concrete "
   "behave alike"},
  {"carpet", 0.98, 0.896,
   "mu_s: peaks 200-224 N; mu_k: assumed at concrete's ratio mu_k/mu_s = 0.914 (carpet's "
   "mu_k,min = 0.12 would give mu_k,max = 1.0 > mu_s with concrete's 0.12 slip factor, which "
   "the law forbids)"},
};
#define TIRE_NFLOOR ((int)(sizeof(kFloors) / sizeof(kFloors[0])))

static const skidsteerTireLayout kLayout = {
  SKIDSTEER_TIRE_CONTRACT_VERSION, TIRE_NDIR, TIRE_NSTATE_DIR, TIRE_DEFLECTION,
  TIRE_VELOCITY, TIRE_STUCK, 3,
};

int skidsteer_tire_attributes(const skidsteerTireAttribute** rows) {
  *rows = kAttributeTable;
  return TIRE_NATTRIBUTE;
}

int skidsteer_tire_floors(const skidsteerTireFloor** rows) {
  *rows = kFloors;
  return TIRE_NFLOOR;
}

const skidsteerTireLayout* skidsteer_tire_layout(void) {
  return &kLayout;
}

// The attribute names MuJoCo's compiler accepts, and the floor attribute's words
// and rule: filled from the tables when the library loads.
static const char* kAttributeNames[TIRE_NATTRIBUTE];

int tire_config_attribute_names(const char* const** names) {
  for (int i = 0; i < TIRE_NATTRIBUTE; i++) kAttributeNames[i] = kAttributeTable[i].name;
  kFloorNames[0] = 0;
  for (int i = 0; i < TIRE_NFLOOR; i++) {
    if (i) strncat(kFloorNames, " ", sizeof(kFloorNames) - strlen(kFloorNames) - 1);
    strncat(kFloorNames, kFloors[i].name, sizeof(kFloorNames) - strlen(kFloorNames) - 1);
  }
  snprintf(kFloorRule, sizeof(kFloorRule),
           "use one of %s, or set mu_static and mu_kinetic", kFloorNames);
  *names = kAttributeNames;
  return TIRE_NATTRIBUTE;
}


// Series spring or damper, eq. 4.14 (an infinite tread leaves the belt alone).
static mjtNum series(mjtNum tread, mjtNum belt) {
  if (isinf(tread)) return belt;
  return tread * belt / (tread + belt);
}


// An instance's attributes as read: each number's value, each choice's index
// into its words.  Unset numbers hold the table's default (NaN: "from floor").
typedef struct {
  mjtNum value[TIRE_NATTRIBUTE];
  int choice[TIRE_NATTRIBUTE];
} tireConfig;


// An instance's name for messages ("(unnamed)" without one).
const char* tire_instance_name(const mjModel* m, int instance) {
  const char* name = mj_id2name(m, mjOBJ_PLUGIN, instance);
  return name ? name : "(unnamed)";
}


static void invalid(const mjModel* m, int instance, const skidsteerTireAttribute* a,
                    const char* text, mjtNum value, const char* rule) {
  if (text && text[0]) {
    mju_warning("%s instance '%s': attribute %s=\"%s\" is invalid: %s", TIRE_PLUGIN_NAME,
                tire_instance_name(m, instance), a->name, text, rule);
  } else {
    mju_warning("%s instance '%s': attribute %s=\"%g\" is invalid: %s", TIRE_PLUGIN_NAME,
                tire_instance_name(m, instance), a->name, value, rule);
  }
}


// The index of `word` among the space-separated `choices`, -1 if absent.
static int choice_index(const char* choices, const char* word) {
  size_t n = strlen(word);
  int index = 0;
  for (const char* c = choices; *c;) {
    const char* end = strchr(c, ' ');
    size_t len = end ? (size_t)(end - c) : strlen(c);
    if (len == n && !strncmp(c, word, n)) return index;
    if (!end) break;
    c = end + 1;
    index++;
  }
  return -1;
}


// Reads and validates every attribute of the table; 0 on success, -1 after a
// warning naming the instance, attribute, value and rule.
static int read_config(const mjModel* m, int instance, tireConfig* cfg) {
  for (int i = 0; i < TIRE_NATTRIBUTE; i++) {
    const skidsteerTireAttribute* a = &kAttributeTable[i];
    const char* text = mj_getPluginConfig(m, instance, a->name);
    int set = text && text[0];
    if (a->kind == SKIDSTEER_TIRE_CHOICE) {
      cfg->choice[i] = choice_index(a->choices, set ? text : a->default_text);
      if (cfg->choice[i] < 0) {
        mju_warning("%s instance '%s': attribute %s=\"%s\" is unknown: %s", TIRE_PLUGIN_NAME,
                    tire_instance_name(m, instance), a->name, text, a->rule);
        return -1;
      }
      continue;
    }
    cfg->value[i] = a->default_value;
    if (!set) continue;
    char* end = NULL;
    double value = strtod(text, &end);
    while (end && (*end == ' ' || *end == '\t')) end++;
    if (end == text || (end && *end) || isnan(value)) {
      mju_warning("%s instance '%s': attribute %s=\"%s\" is not a number", TIRE_PLUGIN_NAME,
                  tire_instance_name(m, instance), a->name, text);
      return -1;
    }
    int ok = (a->low_open ? value > a->low : value >= a->low) &&
             (a->high_open ? value < a->high : value <= a->high) &&
             (!a->finite || isfinite(value)) &&
             (a->kind != SKIDSTEER_TIRE_INTEGER || value == (double)(long long)value);
    if (!ok) {
      invalid(m, instance, a, text, value, a->rule);
      return -1;
    }
    cfg->value[i] = value;
  }
  return 0;
}


int tire_read_params(const mjModel* m, int instance, tireParams* p, mjtNum* radius,
                     int* implicit, int* lug_count, mjtNum* lug_depth, int* cubic_floor,
                     int* surface_normal) {
  tireConfig cfg;
  if (read_config(m, instance, &cfg)) return -1;
  const skidsteerTireFloor* floor = &kFloors[cfg.choice[ATTR_FLOOR]];
  p->mu_static = isnan(cfg.value[ATTR_MU_STATIC]) ? floor->mu_static : cfg.value[ATTR_MU_STATIC];
  p->mu_kinetic =
      isnan(cfg.value[ATTR_MU_KINETIC]) ? floor->mu_kinetic : cfg.value[ATTR_MU_KINETIC];
  if (p->mu_kinetic > p->mu_static) {
    invalid(m, instance, &kAttributeTable[ATTR_MU_KINETIC],
            mj_getPluginConfig(m, instance, "mu_kinetic"), p->mu_kinetic,
            "must not exceed mu_static (kinetic friction above static friction)");
    return -1;
  }
  p->stiffness_z = cfg.value[ATTR_STIFFNESS_Z];
  p->damping_z = cfg.value[ATTR_DAMPING_Z];
  p->stiffness_y = cfg.value[ATTR_STIFFNESS_Y];
  p->damping_y = cfg.value[ATTR_DAMPING_Y];
  p->stiffness_x = series(cfg.value[ATTR_TREAD_STIFFNESS_X], cfg.value[ATTR_BELT_STIFFNESS]);
  p->damping_x = series(cfg.value[ATTR_TREAD_DAMPING_X], cfg.value[ATTR_BELT_DAMPING]);
  p->contact_mass = cfg.value[ATTR_CONTACT_MASS];
  p->lambda_max = cfg.value[ATTR_LAMBDA_MAX];
  p->relay = cfg.choice[ATTR_CONTACT_POINT] == 1;
  p->sliding_ratio = cfg.value[ATTR_SLIDING_FRICTION_RATIO];
  p->sliding_velocity = cfg.value[ATTR_SLIDING_VELOCITY];
  p->stiffness_y_load_exponent = cfg.value[ATTR_STIFFNESS_Y_LOAD_EXPONENT];
  p->reference_load = cfg.value[ATTR_REFERENCE_LOAD];
  p->combined_slip = cfg.choice[ATTR_SLIP_LAW] == 1;
  p->lateral_ratio =
      cfg.value[ATTR_LATERAL_FRICTION_RATIO] * cfg.value[ATTR_TREAD_LATERAL_FRICTION_RATIO];
  *radius = cfg.value[ATTR_RADIUS];
  *implicit = cfg.choice[ATTR_COUPLING] == 1;
  *lug_count = (int)cfg.value[ATTR_LUG_COUNT];
  *lug_depth = cfg.value[ATTR_LUG_DEPTH];
  *cubic_floor = cfg.choice[ATTR_FLOOR_INTERPOLATION] == 0;
  *surface_normal = cfg.choice[ATTR_FLOOR_NORMAL] == 1;
  p->contact_substeps = (int)cfg.value[ATTR_CONTACT_SUBSTEPS];
  if (p->contact_substeps > 1 && !*implicit) {
    mju_warning("%s instance '%s': attribute contact_substeps=\"%d\" is invalid with "
                "coupling=\"explicit\": the substeps' mean force is solved for by the "
                "implicit coupling (use coupling=\"implicit\")", TIRE_PLUGIN_NAME,
                tire_instance_name(m, instance), p->contact_substeps);
    return -1;
  }
  if (*surface_normal && !*cubic_floor) {
    mju_warning("%s instance '%s': attribute floor_normal=\"surface\" is invalid with "
                "floor_interpolation=\"triangles\": MuJoCo's triangles give the plugin no "
                "normal (use floor_interpolation=\"cubic\")", TIRE_PLUGIN_NAME,
                tire_instance_name(m, instance));
    return -1;
  }
  return 0;
}
