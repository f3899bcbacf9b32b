// MuJoCo engine plugin "skidsteer.tire": the thesis's tire law (tire_law.c) in
// place of native wheel/floor contacts.
//
// One instance serves every wheel that names it (<plugin instance="..."/>
// inside the wheel body).  Per wheel it finds the floor under the wheel,
// builds the contact frame, applies [N, f_x, f_y] at the contact point as a
// passive force, integrates the contact-point states in `advance`, and, when a
// <sensor><plugin instance="..."/></sensor> names it, reports the forces.

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "tire.h"
#include "tire_contract.h"

#define TIRE_PLUGIN_NAME "skidsteer.tire"

// ---------------------------------------------------------------- attributes

// The plugin's contract (tire_contract.h): every attribute with its default,
// bounds, unit and source; the floors it knows by name; the state layout.
// read_params() validates an instance's attributes against this table alone.
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
  TIRE_NATTRIBUTE
};

#define POSITIVE "must be a finite number > 0"
#define NONNEGATIVE "must be a finite number >= 0"

// The floor attribute's words and rule, written from kFloors when the library loads.
static char kFloorNames[128];
static char kFloorRule[192];

static const skidsteerTireAttribute kAttributeTable[TIRE_NATTRIBUTE] = {
  [ATTR_FLOOR] = {
    "floor", "", SKIDSTEER_TIRE_CHOICE, NAN, "concrete", 0, 0, 0, 0, 0,
    kFloorNames, "", kFloorRule,
    "the friction set of a floor measured in Sec. 3.3 (the floors table)"},
  [ATTR_MU_STATIC] = {
    "mu_static", "mu_s,max", SKIDSTEER_TIRE_NUMBER, NAN, "from floor", 0, INFINITY, 1, 0, 1,
    "", "", POSITIVE,
    "static friction coefficient (eq. 4.10); overrides the floor's"},
  [ATTR_MU_KINETIC] = {
    "mu_kinetic", "mu_k,max", SKIDSTEER_TIRE_NUMBER, NAN, "from floor", 0, INFINITY, 0, 0, 1,
    "", "", NONNEGATIVE,
    "kinetic friction coefficient (eq. 4.10); overrides the floor's; must be <= mu_static"},
  [ATTR_STIFFNESS_Z] = {
    "stiffness_z", "K_z", SKIDSTEER_TIRE_NUMBER, 80000, "80000", 0, INFINITY, 1, 0, 1,
    "", "N/m", POSITIVE,
    "Sec. 3.3, Fig. 3.10(a): vertical compression of one wheel"},
  [ATTR_DAMPING_Z] = {
    "damping_z", "D_z", SKIDSTEER_TIRE_NUMBER, 70, "70", 0, INFINITY, 0, 0, 1,
    "", "N s/m", NONNEGATIVE,
    "eq. 6.5 (fitted in the thesis to the roll/pitch free responses)"},
  [ATTR_STIFFNESS_Y] = {
    "stiffness_y", "K_y", SKIDSTEER_TIRE_NUMBER, 18000, "18000", 0, INFINITY, 1, 0, 1,
    "", "N/m", POSITIVE,
    "Sec. 3.3, Fig. 3.9: single wheel dragged on wood (two-slope fit 15/21 kN/m); also the "
    "value eq. 5.10 uses"},
  [ATTR_DAMPING_Y] = {
    "damping_y", "D_y", SKIDSTEER_TIRE_NUMBER, 30, "30", 0, INFINITY, 0, 0, 1,
    "", "N s/m", NONNEGATIVE, "eq. 6.5"},
  [ATTR_BELT_STIFFNESS] = {
    "belt_stiffness", "K_b", SKIDSTEER_TIRE_NUMBER, 3000, "3000", 0, INFINITY, 1, 0, 1,
    "", "N/m", POSITIVE,
    "Sec. 3.3, eq. 3.8: saw-tooth ramps 5-7 kN/m over two belts"},
  [ATTR_BELT_DAMPING] = {
    "belt_damping", "D_b", SKIDSTEER_TIRE_NUMBER, 50, "50", 0, INFINITY, 0, 0, 1,
    "", "N s/m", NONNEGATIVE,
    "eq. 6.5 (the thesis's D_x, with D_x ~ D_b by eq. 4.14)"},
  [ATTR_TREAD_STIFFNESS_X] = {
    "tread_stiffness_x", "K_tx", SKIDSTEER_TIRE_NUMBER, INFINITY, "inf", 0, INFINITY, 1, 0, 0,
    "", "N/m", "must be > 0 (inf: rigid tread, the thesis's K_tx >> K_belt)",
    "eq. 4.14: K_x = K_tx K_b / (K_tx + K_b); the thesis takes K_tx >> K_b"},
  [ATTR_TREAD_DAMPING_X] = {
    "tread_damping_x", "D_tx", SKIDSTEER_TIRE_NUMBER, INFINITY, "inf", 0, INFINITY, 1, 0, 0,
    "", "N s/m", "must be > 0 (inf: the thesis's D_tx >> D_belt)",
    "eq. 4.14, the same for damping"},
  [ATTR_CONTACT_MASS] = {
    "contact_mass", "m_t", SKIDSTEER_TIRE_NUMBER, 0.035, "0.035", 0, INFINITY, 1, 0, 1,
    "", "kg", POSITIVE,
    "Sec. 6.2: half the 0.07 kg wheel; the thesis found 0.001-0.07 kg barely matters"},
  [ATTR_LAMBDA_MAX] = {
    "lambda_max", "lambda_max", SKIDSTEER_TIRE_NUMBER, 0.1, "0.1", 0, 1, 1, 0, 1,
    "", "", "must lie in (0, 1]",
    "assumed: never identified; Sec. 6.2 suggests \"order 1e-1 to 1e-2\" and we take the "
    "upper end"},
  [ATTR_CONTACT_POINT] = {
    "contact_point", "", SKIDSTEER_TIRE_CHOICE, NAN, "coulomb", 0, 0, 0, 0, 0,
    "coulomb relay", "",
    "use coulomb (default) or relay (eq. 6.4 as the thesis simulated it)",
    "coulomb: the contact point of eq. 4.9/4.13 with kinetic friction; relay: eq. 6.4 as the "
    "thesis's Simulink model integrates it (relay flag on at mu_s, off at mu_k; kinetic "
    "friction and m_t du/dt dropped), the thesis's model as published"},
  [ATTR_RADIUS] = {
    "radius", "r", SKIDSTEER_TIRE_NUMBER, 0, "from geom", 0, INFINITY, 0, 0, 1,
    "", "m", "must be > 0, or unset to take each wheel's radius from its geom",
    "unloaded wheel radius; unset (or 0): each wheel's cylinder or sphere geom"},
  [ATTR_COUPLING] = {
    "coupling", "", SKIDSTEER_TIRE_CHOICE, NAN, "explicit", 0, 0, 0, 0, 0,
    "explicit implicit", "",
    "use explicit (default) or implicit",
    "numerics, not physics: explicit applies the forces of the start-of-step state; "
    "implicit solves each step for the end-of-step slips at which the tire forces of every "
    "wheel, stick/slip decided at the end of the step, move the robot (stable to 2 ms, yaw "
    "rate within 1 % at 1 ms; stick-slip vibration amplitudes still need 0.1 ms or less: "
    "README, Time step)"},
  [ATTR_SLIDING_FRICTION_RATIO] = {
    "sliding_friction_ratio", "alpha_s", SKIDSTEER_TIRE_NUMBER, 1, "1", 0, 1, 1, 0, 1,
    "", "", "must lie in (0, 1] (1: friction does not fall with sliding speed)",
    "eq. 2.29b (the thesis's ref. [4]): sliding friction a fraction alpha_s of the peak; "
    "rubber's friction falls above a sliding speed (Grosch 1963; Persson 2001); 1 (off): the "
    "law of Ch. 4, whose kinetic friction does not depend on speed"},
  [ATTR_SLIDING_VELOCITY] = {
    "sliding_velocity", "v_S", SKIDSTEER_TIRE_NUMBER, 0.1, "0.1", 0, INFINITY, 1, 0, 1,
    "", "m/s", POSITIVE,
    "Stribeck velocity of the falling branch: kinetic friction times alpha_s + (1 - alpha_s) "
    "exp(-(v/v_S)^2), v the rim's sliding speed; assumed: the order of a swivel's sliding "
    "speeds (median 0.04, 0.10, 0.14 m/s at 20, 45, 64 deg/s, extended build on concrete, "
    "mostly lateral), within the mm/s-m/s span where tread rubber's friction peaks "
    "(Grosch 1963; Persson 2001); used only when alpha_s < 1"},
  [ATTR_STIFFNESS_Y_LOAD_EXPONENT] = {
    "stiffness_y_load_exponent", "n", SKIDSTEER_TIRE_NUMBER, 0, "0", 0, 2, 0, 0, 1,
    "", "", "must lie in [0, 2] (0: K_y does not depend on the load)",
    "normal-load coupling of the lateral force: K_y (N / N_0)^n, a tire's lateral stiffness "
    "growing with its load as the Magic Formula's cornering stiffness does, proportional "
    "to N well below its rating (Pacejka, Tire and Vehicle Dynamics, 2012, Ch. 4); 0 (off): "
    "the law of Ch. 4, K_y independent of the load"},
  [ATTR_REFERENCE_LOAD] = {
    "reference_load", "N_0", SKIDSTEER_TIRE_NUMBER, 56.25, "56.25", 0, INFINITY, 1, 0, 1,
    "", "N", POSITIVE,
    "the load at which K_y holds: Sec. 3.3's platform, 225 N on four wheels, in the pulls "
    "that measured the tire's lateral stiffness; used only when n > 0"},
  [ATTR_LUG_COUNT] = {
    "lug_count", "", SKIDSTEER_TIRE_INTEGER, 0, "0", 0, 1000, 0, 0, 1,
    "", "", "must be a whole number in [0, 1000] (0: a round wheel)",
    "tread lugs per revolution: the rolling radius falls by up to lug_depth between "
    "lugs, a line at lug_count times the wheel's rotation rate and its harmonics (a "
    "lugged tyre on a hard floor; BorealTC's Husky shows 18, 36 and 54 on flooring and "
    "asphalt, docs/real-data/borealtc.md); every wheel's lugs start in phase with its "
    "joint angle (assumed); 0 (off): the round wheel of Ch. 4"},
  [ATTR_LUG_DEPTH] = {
    "lug_depth", "", SKIDSTEER_TIRE_NUMBER, 0, "0", 0, 0.05, 0, 0, 1,
    "", "m", "must lie in [0, 0.05] m",
    "the drop of the wheel centre midway between two lugs, as a polygon of lug_count "
    "sides rolls (r (1 - cos(alpha)) / (1 - cos(pi / lug_count)) scaled to it, alpha the "
    "angle from the nearest lug); a rigid polygon of radius r drops r (1 - cos(pi / "
    "lug_count)), 2.5 mm for 18 lugs at 0.165 m; the tyre's carcass makes it less "
    "(fitted: no public value); used only when lug_count > 0"},
  [ATTR_FLOOR_INTERPOLATION] = {
    "floor_interpolation", "", SKIDSTEER_TIRE_CHOICE, NAN, "cubic", 0, 0, 0, 0, 0,
    "cubic triangles", "",
    "use cubic (default) or triangles",
    "geometry of a heightfield floor between its samples: cubic, the interpolating cubic "
    "B-spline through the samples (mirror ends, as scipy.ndimage's mode='mirror'), smooth to "
    "its curvature, with the floor's slope under the moving wheel in d(delta)/dt (eq. 4.15); "
    "triangles: MuJoCo's triangulation (mj_rayHfield), whose slope jumps at every grid "
    "line, a line at v / (grid spacing) in the loads that the sampled floor does not have, "
    "and whose d(delta)/dt leaves the floor's slope out (the plugin until 2026-12); planes "
    "are the same under both"},
  [ATTR_FLOOR_NORMAL] = {
    "floor_normal", "", SKIDSTEER_TIRE_CHOICE, NAN, "vertical", 0, 0, 0, 0, 0,
    "vertical surface", "",
    "use vertical (default) or surface; surface needs floor_interpolation=\"cubic\"",
    "the contact normal on a heightfield floor: vertical, the floor geom's up whatever "
    "the slope under the wheel (the normal force carries no fore-aft or sideways part "
    "on a bump; the plugin until 2026-12); surface, the cubic floor's own normal under "
    "the wheel centre (up - dh/dx x - dh/dy y, normalised), so the normal force pushes "
    "back on a rising slope and the friction acts in the floor's tangent plane, as on a "
    "tilted plane; compression measured along it.  A heightfield read as MuJoCo's "
    "triangles has no normal here (floor_interpolation=\"triangles\" with surface is "
    "refused); planes are the same under both"},
  [ATTR_SLIP_LAW] = {
    "slip_law", "", SKIDSTEER_TIRE_CHOICE, NAN, "thesis", 0, 0, 0, 0, 0,
    "thesis combined", "",
    "use thesis (default) or combined",
    "how the friction limits share a slip that is both longitudinal and lateral: thesis, "
    "eq. 4.12a/b (mu_x = 1 and mu_y = min(1, |v_y| / |Delta v_x|) once |lambda| > "
    "lambda_max, a resultant up to sqrt(2) mu N); combined, Coulomb friction on the "
    "resultant slip velocity (the friction circle, or ellipse with lateral_friction_ratio: "
    "maximum dissipation, Goyal, Ruina & Papadopoulos 1991; the skid-steer force model of "
    "Wong & Chiang 2001 and Yu et al. 2010), magnitude min(1, |slip| / (r |omega| "
    "lambda_max)); both agree in pure longitudinal and pure lateral slip"},
  [ATTR_LATERAL_FRICTION_RATIO] = {
    "lateral_friction_ratio", "mu_y/mu_x", SKIDSTEER_TIRE_NUMBER, 1, "1", 0, 10, 1, 0, 1,
    "", "", "must lie in (0, 10]",
    "the floor's lateral over longitudinal friction (static and kinetic alike): the "
    "friction ellipse's axes; 1: isotropic, as the thesis takes the lateral pulls of Sec. "
    "3.3 (the only friction it measured) for both directions"},
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

static void fill_tables(void) {
  for (int i = 0; i < TIRE_NATTRIBUTE; i++) kAttributeNames[i] = kAttributeTable[i].name;
  kFloorNames[0] = 0;
  for (int i = 0; i < TIRE_NFLOOR; i++) {
    if (i) strncat(kFloorNames, " ", sizeof(kFloorNames) - strlen(kFloorNames) - 1);
    strncat(kFloorNames, kFloors[i].name, sizeof(kFloorNames) - strlen(kFloorNames) - 1);
  }
  snprintf(kFloorRule, sizeof(kFloorRule),
           "use one of %s, or set mu_static and mu_kinetic", kFloorNames);
}

// ---------------------------------------------------------------- instance data

typedef struct {
  tireParams params;
  int implicit;        // 1: implicit coupling (the coupling attribute)
  int lug_count;       // tread lugs per revolution (0: round wheels)
  mjtNum lug_depth;    // the centre's drop midway between lugs, m
  int nwheel;
  int* wheel_body;     // body id of each wheel, in body order
  int* wheel_joint;    // its hinge joint (the axle)
  int* wheel_geom;     // geom whose center is the wheel center (-1: body origin)
  mjtNum* radius;      // unloaded wheel radius, m
  int nfloor;
  int* floor_geom;     // plane and hfield geoms of the world body
  int cubic_floor;     // 1: heightfields as cubic B-splines (floor_interpolation)
  int surface_normal;  // 1: a cubic heightfield's contact normal is its own (floor_normal)
  mjtNum** floor_spline;  // per floor: its heightfield's B-spline coefficients (elevation,
                          // m; nrow x ncol, row-major as hfield_data), NULL for a plane or
                          // with floor_interpolation="triangles"
  int sensor_adr;      // address in sensordata, -1 if no sensor names the instance
  int warned_off_floor;   // 1 once a wheel beyond every floor was warned of (per mjData)

  // Written by each passive compute, read by the sensor and by advance: derived
  // from mjData and plugin_state, never state of their own.
  int fresh;              // 1 from a passive compute until the advance that uses it
  int* touching;          // wheel w touched the floor at that compute
  tireKinematics* kinematics;  // its start-of-step kinematics
  mjtNum* jacobian;       // rows t_x^T J_p, t_y^T J_p at the contact point (2 nwheel x nv)
  mjtNum* force;          // [N, f_x, f_y] applied (nwheel x 3)
  char* same_branch;      // dofs i, j on one branch of the tree: M's sparsity (nv x nv)
  int max_equality_rows;  // equality-constraint rows the scratch has room for
  mjtNum* scratch;        // the implicit solve's work space (scratch_size numbers)
  size_t scratch_size;
  int* rows;              // its loaded contact rows (2 nwheel)
} tireInstance;


static const char* instance_name(const mjModel* m, int instance) {
  const char* name = mj_id2name(m, mjOBJ_PLUGIN, instance);
  return name ? name : "(unnamed)";
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


static void invalid(const mjModel* m, int instance, const skidsteerTireAttribute* a,
                    const char* text, mjtNum value, const char* rule) {
  if (text && text[0]) {
    mju_warning("%s instance '%s': attribute %s=\"%s\" is invalid: %s", TIRE_PLUGIN_NAME,
                instance_name(m, instance), a->name, text, rule);
  } else {
    mju_warning("%s instance '%s': attribute %s=\"%g\" is invalid: %s", TIRE_PLUGIN_NAME,
                instance_name(m, instance), a->name, value, rule);
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
                    instance_name(m, instance), a->name, text, a->rule);
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
                  instance_name(m, instance), a->name, text);
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


static int read_params(const mjModel* m, int instance, tireParams* p, mjtNum* radius,
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
  p->lateral_ratio = cfg.value[ATTR_LATERAL_FRICTION_RATIO];
  *radius = cfg.value[ATTR_RADIUS];
  *implicit = cfg.choice[ATTR_COUPLING] == 1;
  *lug_count = (int)cfg.value[ATTR_LUG_COUNT];
  *lug_depth = cfg.value[ATTR_LUG_DEPTH];
  *cubic_floor = cfg.choice[ATTR_FLOOR_INTERPOLATION] == 0;
  *surface_normal = cfg.choice[ATTR_FLOOR_NORMAL] == 1;
  if (*surface_normal && !*cubic_floor) {
    mju_warning("%s instance '%s': attribute floor_normal=\"surface\" is invalid with "
                "floor_interpolation=\"triangles\": MuJoCo's triangles give the plugin no "
                "normal (use floor_interpolation=\"cubic\")", TIRE_PLUGIN_NAME,
                instance_name(m, instance));
    return -1;
  }
  return 0;
}


// ---------------------------------------------------------------- model queries

static int count_wheels(const mjModel* m, int instance) {
  int n = 0;
  for (int b = 1; b < m->nbody; b++) {
    if (m->body_plugin[b] == instance) n++;
  }
  return n;
}


static int can_collide(const mjModel* m, int g1, int g2) {
  return (m->geom_contype[g1] & m->geom_conaffinity[g2]) ||
         (m->geom_contype[g2] & m->geom_conaffinity[g1]);
}


static void free_instance(tireInstance* ti) {
  if (!ti) return;
  free(ti->wheel_body);
  free(ti->wheel_joint);
  free(ti->wheel_geom);
  free(ti->radius);
  if (ti->floor_spline) {
    for (int i = 0; i < ti->nfloor; i++) free(ti->floor_spline[i]);
  }
  free(ti->floor_spline);
  free(ti->floor_geom);
  free(ti->touching);
  free(ti->kinematics);
  free(ti->jacobian);
  free(ti->force);
  free(ti->same_branch);
  free(ti->scratch);
  free(ti->rows);
  free(ti);
}


static int find_wheels_and_floor(const mjModel* m, int instance, mjtNum radius_attr,
                                 tireInstance* ti) {
  const char* iname = instance_name(m, instance);
  ti->nwheel = count_wheels(m, instance);
  if (ti->nwheel == 0) {
    mju_warning("%s instance '%s': no body uses it; put <plugin instance=\"%s\"/> in each "
                "wheel body", TIRE_PLUGIN_NAME, iname, iname);
    return -1;
  }
  ti->wheel_body = calloc(ti->nwheel, sizeof(int));
  ti->wheel_joint = calloc(ti->nwheel, sizeof(int));
  ti->wheel_geom = calloc(ti->nwheel, sizeof(int));
  ti->radius = calloc(ti->nwheel, sizeof(mjtNum));

  int w = 0;
  for (int b = 1; b < m->nbody; b++) {
    if (m->body_plugin[b] != instance) continue;
    const char* bname = mj_id2name(m, mjOBJ_BODY, b);
    bname = bname ? bname : "(unnamed)";

    int hinge = -1, nhinge = 0;
    for (int j = m->body_jntadr[b]; j < m->body_jntadr[b] + m->body_jntnum[b]; j++) {
      if (m->jnt_type[j] == mjJNT_HINGE) {
        hinge = j;
        nhinge++;
      }
    }
    if (nhinge != 1 || m->body_jntnum[b] != 1) {
      mju_warning("%s instance '%s': wheel body '%s' must have exactly one hinge joint "
                  "(its axle), found %d joints", TIRE_PLUGIN_NAME, iname, bname,
                  m->body_jntnum[b]);
      return -1;
    }

    int geom = -1;
    for (int g = m->body_geomadr[b]; g < m->body_geomadr[b] + m->body_geomnum[b]; g++) {
      if (m->geom_type[g] == mjGEOM_CYLINDER || m->geom_type[g] == mjGEOM_SPHERE ||
          m->geom_type[g] == mjGEOM_ELLIPSOID) {
        geom = g;
        break;
      }
    }
    mjtNum radius = radius_attr;
    if (radius <= 0) {
      if (geom < 0) {
        mju_warning("%s instance '%s': wheel body '%s' has no cylinder or sphere geom to take "
                    "its radius from; add one or set the radius attribute",
                    TIRE_PLUGIN_NAME, iname, bname);
        return -1;
      }
      radius = m->geom_size[3 * geom];
    }

    for (int g = m->body_geomadr[b]; g < m->body_geomadr[b] + m->body_geomnum[b]; g++) {
      for (int f = m->body_geomadr[0]; f < m->body_geomadr[0] + m->body_geomnum[0]; f++) {
        if (can_collide(m, g, f)) {
          const char* gname = mj_id2name(m, mjOBJ_GEOM, g);
          mju_warning("%s instance '%s': geom '%s' of wheel '%s' also collides with the floor "
                      "natively; set contype=\"0\" conaffinity=\"0\" on wheel geoms",
                      TIRE_PLUGIN_NAME, iname, gname ? gname : "(unnamed)", bname);
          return -1;
        }
      }
    }

    ti->wheel_body[w] = b;
    ti->wheel_joint[w] = hinge;
    ti->wheel_geom[w] = geom;
    ti->radius[w] = radius;
    w++;
  }

  ti->nfloor = 0;
  ti->floor_geom = calloc(m->body_geomnum[0] > 0 ? m->body_geomnum[0] : 1, sizeof(int));
  for (int g = m->body_geomadr[0]; g < m->body_geomadr[0] + m->body_geomnum[0]; g++) {
    if (m->geom_type[g] == mjGEOM_PLANE || m->geom_type[g] == mjGEOM_HFIELD) {
      ti->floor_geom[ti->nfloor++] = g;
    }
  }
  if (ti->nfloor == 0) {
    mju_warning("%s instance '%s': no floor; the tire law needs a plane or hfield geom in "
                "the worldbody", TIRE_PLUGIN_NAME, iname);
    return -1;
  }

  ti->sensor_adr = -1;
  for (int s = 0; s < m->nsensor; s++) {
    if (m->sensor_type[s] == mjSENS_PLUGIN && m->sensor_plugin[s] == instance) {
      ti->sensor_adr = m->sensor_adr[s];
    }
  }
  return 0;
}


// ---------------------------------------------------------------- heightfield splines

// A heightfield floor as the interpolating cubic B-spline through its samples
// (floor_interpolation="cubic"): the elevation is continuous to its curvature
// between the samples, where MuJoCo's triangles break its slope at every grid
// line.  Coefficients by the recursive filter of Unser, Aldroubi & Eden (IEEE
// Trans. Signal Process. 41, 1993), with the mirror-symmetric extension of
// scipy.ndimage's mode="mirror" (d c b | a b c d | c b a), so that the samples'
// spline is the one ndimage.map_coordinates(order=3, mode="mirror") evaluates.

#define TIRE_SPLINE_POLE (-0.26794919243112270)  // sqrt(3) - 2: the cubic B-spline's pole

// In place: the cubic B-spline coefficients of the n samples c[0], c[stride], ...
static void spline_filter_line(mjtNum* c, int n, int stride) {
  if (n < 2) return;
  const mjtNum z = TIRE_SPLINE_POLE;
  for (int i = 0; i < n; i++) c[i * stride] *= 6;  // the gain (1 - z)(1 - 1/z)
  // causal initialisation for the mirror extension (its period is 2n - 2)
  mjtNum z_n1 = pow(z, n - 1), z_i = z, first = c[0] + z_n1 * c[(n - 1) * stride];
  for (int i = 1; i < n - 1; i++) {
    first += z_i * (c[i * stride] + z_n1 * c[(n - 1 - i) * stride]);
    z_i *= z;
  }
  c[0] = first / (1 - z_n1 * z_n1);
  for (int i = 1; i < n; i++) c[i * stride] += z * c[(i - 1) * stride];
  // anticausal initialisation, then the anticausal pass
  c[(n - 1) * stride] = (z * c[(n - 2) * stride] + c[(n - 1) * stride]) * z / (z * z - 1);
  for (int i = n - 2; i >= 0; i--) c[i * stride] = z * (c[(i + 1) * stride] - c[i * stride]);
}


// The B-spline coefficients of heightfield `hfield`'s elevation (m), or NULL when out of
// memory.
static mjtNum* floor_spline(const mjModel* m, int hfield) {
  int nrow = m->hfield_nrow[hfield], ncol = m->hfield_ncol[hfield];
  mjtNum* c = malloc((size_t)nrow * ncol * sizeof(mjtNum));
  if (!c) return NULL;
  const float* data = m->hfield_data + m->hfield_adr[hfield];
  mjtNum scale = m->hfield_size[4 * hfield + 2];
  for (int i = 0; i < nrow * ncol; i++) c[i] = scale * data[i];
  for (int r = 0; r < nrow; r++) spline_filter_line(c + (size_t)r * ncol, ncol, 1);
  for (int col = 0; col < ncol; col++) spline_filter_line(c + col, nrow, ncol);
  return c;
}


static int make_floor_splines(const mjModel* m, tireInstance* ti) {
  ti->floor_spline = calloc(ti->nfloor, sizeof(mjtNum*));
  if (!ti->floor_spline) {
    mju_warning("%s: out of memory", TIRE_PLUGIN_NAME);
    return -1;
  }
  if (!ti->cubic_floor) return 0;
  for (int i = 0; i < ti->nfloor; i++) {
    int f = ti->floor_geom[i];
    if (m->geom_type[f] != mjGEOM_HFIELD) continue;
    ti->floor_spline[i] = floor_spline(m, m->geom_dataid[f]);
    if (!ti->floor_spline[i]) {
      mju_warning("%s: out of memory for the spline of heightfield '%s'", TIRE_PLUGIN_NAME,
                  mj_id2name(m, mjOBJ_HFIELD, m->geom_dataid[f]));
      return -1;
    }
  }
  return 0;
}


// The cubic B-spline's weights for samples i-1 .. i+2 at fraction t in [0, 1] past
// sample i, and their derivatives in t.
static void spline_weights(mjtNum t, mjtNum w[4], mjtNum dw[4]) {
  mjtNum s = 1 - t;
  w[0] = s * s * s / 6;
  w[1] = (3 * t * t * t - 6 * t * t + 4) / 6;
  w[2] = (-3 * t * t * t + 3 * t * t + 3 * t + 1) / 6;
  w[3] = t * t * t / 6;
  dw[0] = -s * s / 2;
  dw[1] = 1.5 * t * t - 2 * t;
  dw[2] = -1.5 * t * t + t + 0.5;
  dw[3] = t * t / 2;
}


// Sample i of n, reflected at the ends as the mirror extension does.
static int mirror_index(int i, int n) {
  if (n < 2) return 0;
  int period = 2 * (n - 1);
  i %= period;
  if (i < 0) i += period;
  return i > n - 1 ? period - i : i;
}


// The spline's elevation (m) at the heightfield coordinates (x, y) of floor geom f
// (its frame, origin at its centre) and its slope (dh/dx, dh/dy).  Returns 0 when
// (x, y) lies outside the heightfield, as mj_rayHfield misses it.
static int spline_elevation(const mjModel* m, int f, const mjtNum* coef, mjtNum x, mjtNum y,
                            mjtNum* elevation, mjtNum slope[2]) {
  int hfield = m->geom_dataid[f];
  const mjtNum* size = m->hfield_size + 4 * hfield;
  int nrow = m->hfield_nrow[hfield], ncol = m->hfield_ncol[hfield];
  if (x < -size[0] || x > size[0] || y < -size[1] || y > size[1]) return 0;
  // grid coordinates: column u along x, row v along y (hfield_data's layout)
  mjtNum du_dx = (ncol - 1) / (2 * size[0]), dv_dy = (nrow - 1) / (2 * size[1]);
  mjtNum u = (x + size[0]) * du_dx, v = (y + size[1]) * dv_dy;
  int i = mjMIN(mjMAX((int)floor(u), 0), mjMAX(ncol - 2, 0));
  int j = mjMIN(mjMAX((int)floor(v), 0), mjMAX(nrow - 2, 0));
  mjtNum wu[4], dwu[4], wv[4], dwv[4];
  spline_weights(u - i, wu, dwu);
  spline_weights(v - j, wv, dwv);
  mjtNum h = 0, h_u = 0, h_v = 0;
  for (int a = 0; a < 4; a++) {
    const mjtNum* row = coef + (size_t)mirror_index(j - 1 + a, nrow) * ncol;
    mjtNum along = 0, along_u = 0;
    for (int b = 0; b < 4; b++) {
      mjtNum c = row[mirror_index(i - 1 + b, ncol)];
      along += wu[b] * c;
      along_u += dwu[b] * c;
    }
    h += wv[a] * along;
    h_u += wv[a] * along_u;
    h_v += dwv[a] * along;
  }
  *elevation = h;
  slope[0] = h_u * du_dx;
  slope[1] = h_v * dv_dy;
  return 1;
}


// ---------------------------------------------------------------- kinematics

// Velocity of the material point p of body b, world frame.
static void point_velocity(const mjModel* m, const mjData* d, int b, const mjtNum p[3],
                           mjtNum v[3]) {
  const mjtNum* cvel = d->cvel + 6 * b;
  mjtNum offset[3];
  mju_sub3(offset, p, d->subtree_com + 3 * m->body_rootid[b]);
  mju_cross(v, cvel, offset);
  mju_addTo3(v, cvel + 3);
}


// The angle (rad, in (-pi, pi]) of wheel w about its axle relative to its parent body
// and its rate (rad/s), from the bodies' poses and velocities (xquat, cvel: those of
// the start of the step also when `advance` calls, after qpos and qvel have moved on).
static void wheel_angle(const mjModel* m, const mjData* d, const tireInstance* ti, int w,
                        mjtNum* angle, mjtNum* rate) {
  int body = ti->wheel_body[w], parent = m->body_parentid[body], joint = ti->wheel_joint[w];
  // xquat_wheel = xquat_parent body_quat q_joint: q_joint = body_quat^-1 xquat_parent^-1 xquat_wheel
  mjtNum inv_parent[4], inv_body[4], relative[4], q_joint[4], rotation[3];
  mju_negQuat(inv_parent, d->xquat + 4 * parent);
  mju_negQuat(inv_body, m->body_quat + 4 * body);
  mju_mulQuat(relative, inv_parent, d->xquat + 4 * body);
  mju_mulQuat(q_joint, inv_body, relative);
  mju_quat2Vel(rotation, q_joint, 1);
  *angle = mju_dot3(rotation, m->jnt_axis + 3 * joint);
  mjtNum spin[3];
  mju_sub3(spin, d->cvel + 6 * body, d->cvel + 6 * parent);
  *rate = mju_dot3(spin, d->xaxis + 3 * joint);
}


// Contact of wheel w with the floor that compresses it most.  Fills the
// kinematics, the contact frame (rows: normal n, rolling direction t_x,
// lateral t_y) and the contact point.  Returns 0 when no floor is under the
// wheel (then nothing else is filled).
static int wheel_contact(const mjModel* m, const mjData* d, const tireInstance* ti, int w,
                         tireKinematics* k, mjtNum frame[9], mjtNum point[3]) {
  int body = ti->wheel_body[w];
  int geom = ti->wheel_geom[w];
  mjtNum radius = ti->radius[w];
  const mjtNum* center = geom >= 0 ? d->geom_xpos + 3 * geom : d->xpos + 3 * body;
  const mjtNum* axle = d->xaxis + 3 * ti->wheel_joint[w];
  // a lugged tread: the rolling radius of a polygon of lug_count sides, scaled to
  // lug_depth, at the angle alpha of the wheel from its nearest lug
  mjtNum drop_rate = 0;
  if (ti->lug_count > 0 && ti->lug_depth > 0) {
    mjtNum angle, angle_rate;
    wheel_angle(m, d, ti, w, &angle, &angle_rate);
    mjtNum pitch = 2 * mjPI / ti->lug_count;
    mjtNum alpha = angle - pitch * floor(angle / pitch + 0.5);
    mjtNum scale = ti->lug_depth / (1 - cos(pitch / 2));
    radius -= scale * (1 - cos(alpha));
    drop_rate = scale * sin(alpha) * angle_rate;
  }

  int found = 0;
  mjtNum best = -mjMAXVAL, normal[3] = {0, 0, 1}, spread = 1, profile_rate = 0;
  for (int i = 0; i < ti->nfloor; i++) {
    int f = ti->floor_geom[i];
    const mjtNum* mat = d->geom_xmat + 9 * f;
    mjtNum up[3] = {mat[2], mat[5], mat[8]};
    // the contact normal: the floor's up, or on a cubic heightfield with
    // floor_normal="surface" its own normal under the centre (surface below)
    mjtNum floor_normal[3] = {up[0], up[1], up[2]};
    mjtNum height, rate = 0, surface = 0;
    if (m->geom_type[f] == mjGEOM_PLANE) {
      mjtNum rel[3];
      mju_sub3(rel, center, d->geom_xpos + 3 * f);
      height = mju_dot3(rel, up);
    } else if (ti->floor_spline[i]) {
      // the spline's elevation under the centre, and how fast it rises under the
      // centre's motion across the floor: d(delta)/dt = -(approach) + slope . v
      mjtNum rel[3], elevation, slope[2], v_center[3];
      mju_sub3(rel, center, d->geom_xpos + 3 * f);
      mjtNum x_axis[3] = {mat[0], mat[3], mat[6]}, y_axis[3] = {mat[1], mat[4], mat[7]};
      if (!spline_elevation(m, f, ti->floor_spline[i], mju_dot3(rel, x_axis),
                            mju_dot3(rel, y_axis), &elevation, slope)) {
        continue;  // not above this heightfield
      }
      height = mju_dot3(rel, up) - elevation;
      if (ti->surface_normal) {
        // n = (up - h_x x - h_y y) / |.|; the centre's distance to the floor's tangent
        // plane is height n.up; the floor's rise under the moving centre is in the
        // approach along n (-v.n), so no separate profile rate
        mju_addToScl3(floor_normal, x_axis, -slope[0]);
        mju_addToScl3(floor_normal, y_axis, -slope[1]);
        mju_normalize3(floor_normal);
        surface = 1;
      } else {
        point_velocity(m, d, body, center, v_center);
        rate = slope[0] * mju_dot3(v_center, x_axis) + slope[1] * mju_dot3(v_center, y_axis);
      }
    } else {
      mjtNum down[3] = {-up[0], -up[1], -up[2]};
      height = mj_rayHfield(m, d, f, center, down, NULL);
      if (height < 0) continue;  // not above this heightfield
    }
    mjtNum cos_tilt = mju_dot3(floor_normal, axle);
    // |n - (n.axle) axle|: 1 for an upright wheel, 0 for one lying flat
    mjtNum sin_tilt = mju_sqrt(mjMAX(0, 1 - cos_tilt * cos_tilt));
    if (sin_tilt < 1e-9) continue;  // wheel lying flat: no rolling contact
    // distance from the wheel center down to its lowest rim point, along n
    mjtNum rim = radius * sin_tilt;
    if (surface) height *= mju_dot3(floor_normal, up);
    mjtNum compression = rim - height;
    if (compression > best) {
      best = compression;
      mju_copy3(normal, floor_normal);
      spread = sin_tilt;
      profile_rate = rate;
      found = 1;
    }
  }
  if (!found) return 0;

  // lowest rim point: one radius from the center along -n with its axle
  // component removed, (cos_tilt axle - n) / sin_tilt
  mjtNum cos_tilt = mju_dot3(normal, axle);
  mjtNum down_rim[3];
  mju_scl3(down_rim, axle, cos_tilt);
  mju_subFrom3(down_rim, normal);
  mju_scl3(down_rim, down_rim, radius / spread);
  mju_add3(point, center, down_rim);

  mjtNum* n = frame;
  mjtNum* tx = frame + 3;
  mjtNum* ty = frame + 6;
  mju_copy3(n, normal);
  mju_cross(tx, axle, n);
  mju_normalize3(tx);
  mju_cross(ty, n, tx);

  mjtNum v_rim[3], v_center[3];
  point_velocity(m, d, body, point, v_rim);
  point_velocity(m, d, body, center, v_center);
  k->compression = best;
  // the rim point's approach, plus the floor rising under it (a cubic heightfield),
  // less the shrinking of the rolling radius (lugs)
  k->compression_rate = -mju_dot3(v_rim, n) + profile_rate - drop_rate * spread;
  k->slip_x = mju_dot3(v_rim, tx);
  k->slip_y = mju_dot3(v_rim, ty);
  k->rolling_speed = mju_dot3(v_center, tx) - k->slip_x;
  return 1;
}

// 1 when wheel w's centre lies beyond every floor: the worldbody has no plane and the
// centre is outside every heightfield's extent (a robot driven off a heightfield's
// edge).  Such a wheel finds no floor and gets no tire force, as a wheel in the air.
static int beyond_every_floor(const mjModel* m, const mjData* d, const tireInstance* ti,
                              int w) {
  int geom = ti->wheel_geom[w];
  const mjtNum* center = geom >= 0 ? d->geom_xpos + 3 * geom : d->xpos + 3 * ti->wheel_body[w];
  for (int i = 0; i < ti->nfloor; i++) {
    int f = ti->floor_geom[i];
    if (m->geom_type[f] == mjGEOM_PLANE) return 0;
    const mjtNum* mat = d->geom_xmat + 9 * f;
    const mjtNum* size = m->hfield_size + 4 * m->geom_dataid[f];
    mjtNum rel[3];
    mju_sub3(rel, center, d->geom_xpos + 3 * f);
    mjtNum x = rel[0] * mat[0] + rel[1] * mat[3] + rel[2] * mat[6];
    mjtNum y = rel[0] * mat[1] + rel[1] * mat[4] + rel[2] * mat[7];
    if (fabs(x) <= size[0] && fabs(y) <= size[1]) return 0;
  }
  return 1;
}


// ---------------------------------------------------------------- callbacks

static int tire_nstate(const mjModel* m, int instance) {
  return TIRE_NSTATE_WHEEL * count_wheels(m, instance);
}


static int tire_nsensordata(const mjModel* m, int instance, int sensor_id) {
  (void)sensor_id;
  return 3 * count_wheels(m, instance);
}


static size_t implicit_scratch_size(int nv, int n, int ne, int nw);


static int tire_init(const mjModel* m, mjData* d, int instance) {
  tireInstance* ti = calloc(1, sizeof(tireInstance));
  if (!ti) {
    mju_warning("%s: out of memory", TIRE_PLUGIN_NAME);
    return -1;
  }
  mjtNum radius_attr = 0;
  if (read_params(m, instance, &ti->params, &radius_attr, &ti->implicit, &ti->lug_count,
                  &ti->lug_depth, &ti->cubic_floor, &ti->surface_normal) ||
      find_wheels_and_floor(m, instance, radius_attr, ti) || make_floor_splines(m, ti)) {
    free_instance(ti);
    return -1;
  }
  ti->touching = calloc(ti->nwheel, sizeof(int));
  ti->kinematics = calloc(ti->nwheel, sizeof(tireKinematics));
  ti->jacobian = calloc((size_t)2 * ti->nwheel * (m->nv > 0 ? m->nv : 1), sizeof(mjtNum));
  ti->force = calloc((size_t)3 * ti->nwheel, sizeof(mjtNum));
  ti->same_branch = calloc((size_t)m->nv * m->nv + 1, 1);
  if (ti->same_branch) {
    for (int i = 0; i < m->nv; i++) {
      for (int j = i; j >= 0; j = m->dof_parentid[j]) {
        ti->same_branch[i * m->nv + j] = ti->same_branch[j * m->nv + i] = 1;
      }
    }
  }
  ti->max_equality_rows = 6 * m->neq;  // a weld is the largest equality: 6 rows
  ti->scratch_size = implicit_scratch_size(m->nv, 2 * ti->nwheel, ti->max_equality_rows,
                                           ti->nwheel);
  ti->scratch = calloc(ti->scratch_size, sizeof(mjtNum));
  ti->rows = calloc(2 * ti->nwheel, sizeof(int));
  if (!ti->touching || !ti->kinematics || !ti->jacobian || !ti->force || !ti->same_branch ||
      !ti->scratch || !ti->rows) {
    mju_warning("%s: out of memory", TIRE_PLUGIN_NAME);
    free_instance(ti);
    return -1;
  }
  d->plugin_data[instance] = (uintptr_t)ti;
  return 0;
}


static void tire_destroy(mjData* d, int instance) {
  free_instance((tireInstance*)d->plugin_data[instance]);
  d->plugin_data[instance] = 0;
}


static void tire_reset(const mjModel* m, mjtNum* plugin_state, void* plugin_data,
                       int instance) {
  (void)plugin_data;
  int nwheel = count_wheels(m, instance);
  for (int w = 0; w < nwheel; w++) {
    tire_reset_state(plugin_state + TIRE_NSTATE_WHEEL * w);
  }
}


// Applies [N, f_x, f_y] (contact frame rows n, t_x, t_y) at `point` of `body`.
static void apply_force(const mjModel* m, mjData* d, int body, const mjtNum frame[9],
                        const mjtNum point[3], const mjtNum force[3]) {
  mjtNum world[3];
  mju_scl3(world, frame, force[0]);
  mju_addToScl3(world, frame + 3, force[1]);
  mju_addToScl3(world, frame + 6, force[2]);
  mj_applyFT(m, d, world, NULL, point, body, d->qfrc_passive);
}


static void explicit_forces(const mjModel* m, mjData* d, int instance, tireInstance* ti,
                            int passive) {
  const mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  for (int w = 0; w < ti->nwheel; w++) {
    tireKinematics k;
    mjtNum frame[9], point[3], force[3] = {0, 0, 0};
    if (wheel_contact(m, d, ti, w, &k, frame, point)) {
      tire_forces(&ti->params, &k, state + TIRE_NSTATE_WHEEL * w, force);
    }
    mju_copy3(ti->force + 3 * w, force);
    if (passive && force[0] > 0) apply_force(m, d, ti->wheel_body[w], frame, point, force);
  }
}


// d(actuator force)/d(actuator velocity) of actuator a, as MuJoCo's implicit
// integrators take it: the velocity terms of affine gain and bias.
static mjtNum actuator_velocity_slope(const mjModel* m, const mjData* d, int a) {
  mjtNum slope = 0;
  if (m->actuator_biastype[a] == mjBIAS_AFFINE) slope += m->actuator_biasprm[a * mjNBIAS + 2];
  if (m->actuator_gaintype[a] == mjGAIN_AFFINE) {
    mjtNum input = 0;
    if (m->actuator_dyntype[a] == mjDYN_NONE) {
      input = m->actuator_ctrlnum[a] > 0 ? d->ctrl[m->actuator_ctrladr[a]] : 0;
    } else if (m->actuator_actnum[a] > 0) {
      input = d->act[m->actuator_actadr[a] + m->actuator_actnum[a] - 1];
    }
    slope += m->actuator_gainprm[a * mjNGAIN + 2] * input;
  }
  return slope;
}


// H = M + h B: the matrix whose inverse maps a step's generalized impulse to
// its velocity change under the model's integrator.  B is the damping each
// integrator treats implicitly: joint damping (Euler unless eulerdamp is off,
// implicit, implicitfast), tendon damping and actuator velocity gains
// (implicit, implicitfast).  RK4 treats none.  Dense, nv x nv.  Like MuJoCo,
// which stores these derivatives in the mass matrix's sparsity, it keeps only
// entries between dofs on one branch of the kinematic tree: a tendon across
// two sibling wheels damps each wheel implicitly, not their difference.
static void step_matrix(const mjModel* m, const mjData* d, const char* same_branch, mjtNum h,
                        mjtNum* H) {
  int nv = m->nv;
  int integrator = m->opt.integrator;
  int implicit = integrator == mjINT_IMPLICIT || integrator == mjINT_IMPLICITFAST;
  int euler = integrator == mjINT_EULER && !(m->opt.disableflags & mjDSBL_EULERDAMP);
  int damper = !(m->opt.disableflags & mjDSBL_DAMPER);
  int actuation = !(m->opt.disableflags & mjDSBL_ACTUATION);
  mj_fullM(m, d, H);
  if ((implicit || euler) && damper) {
    for (int i = 0; i < nv; i++) H[i * nv + i] += h * m->dof_damping[i];
  }
  if (implicit && damper) {
    for (int t = 0; t < m->ntendon; t++) {
      mjtNum b = m->tendon_damping[t];
      if (b == 0) continue;
      int adr = m->ten_J_rowadr[t], nnz = m->ten_J_rownnz[t];
      for (int i = 0; i < nnz; i++) {
        for (int j = 0; j < nnz; j++) {
          int at = m->ten_J_colind[adr + i] * nv + m->ten_J_colind[adr + j];
          if (same_branch[at]) H[at] += h * b * d->ten_J[adr + i] * d->ten_J[adr + j];
        }
      }
    }
  }
  if (implicit && actuation) {
    for (int a = 0; a < m->nu; a++) {
      mjtNum slope = actuator_velocity_slope(m, d, a);
      if (slope == 0) continue;
      for (int o = m->actuator_outadr[a]; o < m->actuator_outadr[a] + m->actuator_outnum[a];
           o++) {
        int adr = d->moment_rowadr[o], nnz = d->moment_rownnz[o];
        for (int i = 0; i < nnz; i++) {
          for (int j = 0; j < nnz; j++) {
            int at = d->moment_colind[adr + i] * nv + d->moment_colind[adr + j];
            if (same_branch[at]) {
              H[at] -= h * slope * d->actuator_moment[adr + i] * d->actuator_moment[adr + j];
            }
          }
        }
      }
    }
  }
}


// Row r of the constraint Jacobian, dense (nv numbers).
static void constraint_row(const mjModel* m, const mjData* d, int r, mjtNum* row) {
  int nv = m->nv;
  if (!mj_isSparse(m)) {
    mju_copy(row, d->efc_J + (size_t)r * nv, nv);
    return;
  }
  mju_zero(row, nv);
  int adr = d->efc_J_rowadr[r];
  for (int i = 0; i < d->efc_J_rownnz[r]; i++) row[d->efc_J_colind[adr + i]] = d->efc_J[adr + i];
}


// Solves a x = b in place (b becomes x) by Gaussian elimination with partial
// pivoting; a (n x n, row-major) is destroyed.  Returns 0, or -1 if singular.
static int solve_dense(mjtNum* a, mjtNum* b, int n) {
  for (int c = 0; c < n; c++) {
    int pivot = c;
    for (int r = c + 1; r < n; r++) {
      if (fabs(a[r * n + c]) > fabs(a[pivot * n + c])) pivot = r;
    }
    if (fabs(a[pivot * n + c]) < mjMINVAL) return -1;
    if (pivot != c) {
      for (int j = 0; j < n; j++) {
        mjtNum t = a[c * n + j];
        a[c * n + j] = a[pivot * n + j];
        a[pivot * n + j] = t;
      }
      mjtNum t = b[c];
      b[c] = b[pivot];
      b[pivot] = t;
    }
    for (int r = c + 1; r < n; r++) {
      mjtNum f = a[r * n + c] / a[c * n + c];
      if (f == 0) continue;
      for (int j = c; j < n; j++) a[r * n + j] -= f * a[c * n + j];
      b[r] -= f * b[c];
    }
  }
  for (int r = n - 1; r >= 0; r--) {
    mjtNum sum = b[r];
    for (int j = r + 1; j < n; j++) sum -= a[r * n + j] * b[j];
    b[r] = sum / a[r * n + r];
  }
  return 0;
}


// Newton iterations of the implicit coupling, and when they stop.
#define TIRE_MAX_ITERATIONS 20
#define TIRE_SMALLEST_STEP (1.0 / 64)  // line search: the shortest Newton step tried
#define TIRE_SLIP_TOLERANCE 1e-10  // m/s: well below any slip the law resolves


// The implicit solve's work space: one block allocated per instance at init
// (plugin_data, not state), handed out in order by take().  The sizes here are
// the allocations of implicit_forces, in its order.
static size_t implicit_scratch_size(int nv, int n, int ne, int nw) {
  size_t size = 9 * nw + 3 * nw + 3 * nv + nv;             // frame, point, jacp, normal
  size += 2 * nv + n * nv;                                   // other, bias, B
  size += 2 * ne * nv + ne * ne + ne * (n + 1) + n * nv + nv + 2 * ne;  // equality rows
  size += nv * nv + n * nv + n * n + nv + n;                 // H, Y, A, velocity, slip_free
  size += 4 * n + 4 * n + n * n + n;                         // Newton
  return size;
}


static mjtNum* take(mjtNum** cursor, size_t count) {
  mjtNum* block = *cursor;
  *cursor += count;
  return block;
}


// max |x_i|
static mjtNum max_abs(const mjtNum* x, int n) {
  mjtNum largest = 0;
  for (int i = 0; i < n; i++) largest = mjMAX(largest, fabs(x[i]));
  return largest;
}


// The tire forces f(u) at the end of the step for slips u (rows x, y per
// wheel), their slopes, and the residual u_free + h A f(u) - u; returns |.|^2.
static mjtNum tire_residual(const tireInstance* ti, const mjtNum* state, mjtNum h,
                            const mjtNum* A, const mjtNum* slip_free, const mjtNum* slip, int n,
                            mjtNum* force, mjtNum* slope, mjtNum* residual) {
  for (int w = 0; w < ti->nwheel; w++) {
    mjtNum f[3] = {0, 0, 0};
    slope[2 * w] = slope[2 * w + 1] = 0;
    if (ti->touching[w]) {
      tireKinematics k = ti->kinematics[w];
      k.slip_x = slip[2 * w];
      k.slip_y = slip[2 * w + 1];
      tire_step_force(&ti->params, &k, h, state + TIRE_NSTATE_WHEEL * w, f, slope + 2 * w);
    }
    force[2 * w] = f[1];
    force[2 * w + 1] = f[2];
  }
  mju_mulMatVec(residual, A, force, n, n);
  mjtNum merit = 0;
  for (int r = 0; r < n; r++) {
    residual[r] = slip_free[r] + h * residual[r] - slip[r];
    merit += residual[r] * residual[r];
  }
  return merit;
}


// The implicit coupling.  Unknown: the 2 nwheel rim slips u at the end of the
// step.  MuJoCo's step maps forces to velocities through H = M + h B (see
// step_matrix), so with J the contact rows and f the tire forces
//   u = u_free + h A f(u),   A = J H^-1 B^T,   u_free = J (v + h H^-1 q_other),
// where B adds to J the equality constraints' reaction to the tire forces and
// q_other is every other generalized force of the step (passive, actuator,
// applied, the normal forces, minus bias, plus the equality constraints'
// tire-free reaction; inequality constraints are not known yet and left out).
// f(u) is the tire law's force at the end of the step when the rim slips at u
// (tire_step_force: contact points advanced, stick/slip decided there).
// Newton's method on that with the law's own slopes d f_i / d u_i and a
// backtracking line search; when it stops short of convergence (at a jump of
// f) the force applied is the one that moves the slips to where it stopped.
static void implicit_forces(const mjModel* m, mjData* d, int instance, tireInstance* ti) {
  const mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  const tireParams* p = &ti->params;
  int nv = m->nv, nw = ti->nwheel, n = 2 * nw;
  mjtNum h = m->opt.timestep;
  mjtNum* J = ti->jacobian;

  mjtNum* cursor = ti->scratch;
  mjtNum* frame = take(&cursor, 9 * nw);
  mjtNum* point = take(&cursor, 3 * nw);
  mjtNum* jacp = take(&cursor, 3 * nv);
  mju_zero(J, n * nv);
  mju_zero(ti->force, 3 * nw);
  int loaded = 0;
  for (int w = 0; w < nw; w++) {
    ti->touching[w] = wheel_contact(m, d, ti, w, ti->kinematics + w, frame + 9 * w,
                                    point + 3 * w);
    if (ti->touching[w] && tire_normal_force(p, ti->kinematics + w) > 0) {
      mj_jac(m, d, jacp, NULL, point + 3 * w, ti->wheel_body[w]);
      mju_mulMatTVec(J + 2 * w * nv, jacp, frame + 9 * w + 3, 3, nv);
      mju_mulMatTVec(J + (2 * w + 1) * nv, jacp, frame + 9 * w + 6, 3, nv);
      loaded = 1;
    }
  }
  // the normal forces (explicit: eq. 4.15 at the start of the step) join the
  // other forces below
  mjtNum* normal = take(&cursor, nv);
  mju_zero(normal, nv);
  for (int w = 0; w < nw; w++) {
    mjtNum f[3] = {ti->touching[w] ? tire_normal_force(p, ti->kinematics + w) : 0, 0, 0};
    if (f[0] <= 0) continue;
    mjtNum world[3];
    mju_scl3(world, frame + 9 * w, f[0]);
    mj_applyFT(m, d, world, NULL, point + 3 * w, ti->wheel_body[w], normal);
  }
  if (!loaded) return;

  // Every other generalized force of the step.
  mjtNum* other = take(&cursor, nv);
  mjtNum* bias = take(&cursor, nv);
  mju_add(other, d->qfrc_passive, normal, nv);  // passive so far (not the tires') + N
  mj_fwdActuation(m, d);                 // MuJoCo computes them again after this stage
  mju_addTo(other, d->qfrc_actuator, nv);
  mj_rne(m, d, 0, bias);
  mju_subFrom(other, bias, nv);
  mju_addTo(other, d->qfrc_applied, nv);
  for (int b = 1; b < m->nbody; b++) {
    const mjtNum* xfrc = d->xfrc_applied + 6 * b;
    if (xfrc[0] || xfrc[1] || xfrc[2] || xfrc[3] || xfrc[4] || xfrc[5]) {
      mj_applyFT(m, d, xfrc, xfrc + 3, d->xipos + 3 * b, b, other);
    }
  }

  // B: the generalized force per unit tire force, rows J plus the reaction of
  // the equality constraints (e.g. the belts that make same-side wheels turn
  // together), which MuJoCo's solver gives, for rows without bounds, as
  //   lambda = (E M^-1 E^T + R)^-1 (a_ref - E M^-1 q),
  // linear in the tire forces; its tire-free part joins `other`.  Inequality
  // rows (limits, contacts other than the tires) are left out.
  mjtNum* B = take(&cursor, n * nv);
  mju_copy(B, J, n * nv);
  int ne = d->ne;
  if (ne > ti->max_equality_rows) {  // cannot happen: a weld, the largest, has 6 rows
    mju_warning("%s: %d equality rows, room for %d", TIRE_PLUGIN_NAME, ne,
                ti->max_equality_rows);
    ne = 0;
  }
  if (ne > 0) {
    mjtNum* E = take(&cursor, ne * nv);
    mjtNum* EMinv = take(&cursor, ne * nv);
    mjtNum* S = take(&cursor, ne * ne);
    mjtNum* rhs = take(&cursor, ne * (n + 1));
    mjtNum* JMinv = take(&cursor, n * nv);
    mjtNum* accel = take(&cursor, nv);
    for (int i = 0; i < ne; i++) constraint_row(m, d, i, E + i * nv);
    mj_solveM(m, d, EMinv, E, ne);
    mj_solveM(m, d, JMinv, J, n);
    mj_solveM(m, d, accel, other, 1);
    for (int i = 0; i < ne; i++) {
      for (int j = 0; j < ne; j++) S[i * ne + j] = mju_dot(E + i * nv, EMinv + j * nv, nv);
      S[i * ne + i] += d->efc_R[i];
      const mjtNum* kbip = d->efc_KBIP + 4 * i;
      mjtNum velocity = mju_dot(E + i * nv, d->qvel, nv);
      mjtNum aref = -kbip[1] * velocity - kbip[0] * kbip[2] * d->efc_pos[i];
      // column 0: the tire-free multipliers; column 1 + c: per unit force c
      rhs[i * (n + 1)] = aref - mju_dot(E + i * nv, accel, nv);
      for (int c = 0; c < n; c++) rhs[i * (n + 1) + 1 + c] = -mju_dot(EMinv + i * nv, J + c * nv, nv);
    }
    mju_cholFactor(S, ne, mjMINVAL);
    mjtNum* column = take(&cursor, ne);
    mjtNum* solved = take(&cursor, ne);
    for (int c = 0; c < n + 1; c++) {
      for (int i = 0; i < ne; i++) column[i] = rhs[i * (n + 1) + c];
      mju_cholSolve(solved, S, column, ne);
      mjtNum* target = c == 0 ? other : B + (c - 1) * nv;
      for (int i = 0; i < ne; i++) mju_addToScl(target, E + i * nv, solved[i], nv);
    }
  }

  // A = J H^-1 B^T and the slips the step would end with without the tires
  mjtNum* H = take(&cursor, nv * nv);
  step_matrix(m, d, ti->same_branch, h, H);
  mju_cholFactor(H, nv, mjMINVAL);
  mjtNum* Y = take(&cursor, n * nv);
  for (int r = 0; r < n; r++) mju_cholSolve(Y + r * nv, H, B + r * nv, nv);
  mjtNum* A = take(&cursor, n * n);
  for (int r = 0; r < n; r++) {
    for (int c = 0; c < n; c++) A[r * n + c] = mju_dot(J + r * nv, Y + c * nv, nv);
  }
  mjtNum* velocity = take(&cursor, nv);
  mju_cholSolve(velocity, H, other, nv);
  mju_scl(velocity, velocity, h, nv);
  mju_addTo(velocity, d->qvel, nv);
  mjtNum* slip_free = take(&cursor, n);
  mju_mulMatVec(slip_free, J, velocity, n, nv);

  // Newton on g(u) = u - u_free - h A f(u) from the start-of-step slips, with a
  // backtracking line search on |g|^2: f jumps where a contact point breaks
  // away (static above kinetic friction), and plain Newton can cycle there.
  mjtNum* slip = take(&cursor, n);
  mjtNum* force = take(&cursor, n);
  mjtNum* slope = take(&cursor, n);
  mjtNum* residual = take(&cursor, n);
  mjtNum* trial = take(&cursor, 4 * n);  // slips, forces, slopes, residual
  mjtNum* G = take(&cursor, n * n);
  mjtNum* step = take(&cursor, n);
  for (int w = 0; w < nw; w++) {
    slip[2 * w] = ti->kinematics[w].slip_x;
    slip[2 * w + 1] = ti->kinematics[w].slip_y;
  }
  mjtNum merit = tire_residual(ti, state, h, A, slip_free, slip, n, force, slope, residual);
  int converged = 0;
  for (int it = 0; it < TIRE_MAX_ITERATIONS; it++) {
    if (max_abs(residual, n) <= TIRE_SLIP_TOLERANCE) {
      converged = 1;
      break;
    }
    for (int r = 0; r < n; r++) {
      for (int c = 0; c < n; c++) G[r * n + c] = (r == c) - h * A[r * n + c] * slope[c];
    }
    mju_copy(step, residual, n);
    if (solve_dense(G, step, n)) break;
    int accepted = 0;
    for (mjtNum t = 1; t >= TIRE_SMALLEST_STEP; t *= 0.5) {
      for (int r = 0; r < n; r++) trial[r] = slip[r] + t * step[r];
      mjtNum trial_merit = tire_residual(ti, state, h, A, slip_free, trial, n, trial + n,
                                         trial + 2 * n, trial + 3 * n);
      if (trial_merit <= (1 - 1e-4 * t) * merit) {
        mju_copy(slip, trial, n);
        mju_copy(force, trial + n, n);
        mju_copy(slope, trial + 2 * n, n);
        mju_copy(residual, trial + 3 * n, n);
        merit = trial_merit;
        accepted = 1;
        break;
      }
    }
    if (!accepted) break;
  }
  if (!converged) {
    // Stopped at a jump of f: apply the force that moves the slips to where
    // the search stopped, h A f = u - u_free, on the loaded rows.
    int* rows = ti->rows;
    int nl = 0;
    for (int r = 0; r < n; r++) {
      if (mju_norm(J + r * nv, nv) > 0) rows[nl++] = r;
    }
    for (int i = 0; i < nl; i++) {
      step[i] = slip[rows[i]] - slip_free[rows[i]];
      for (int j = 0; j < nl; j++) G[i * nl + j] = h * A[rows[i] * n + rows[j]];
    }
    if (nl > 0 && !solve_dense(G, step, nl)) {
      for (int i = 0; i < nl; i++) force[rows[i]] = step[i];
    }
  }
  for (int w = 0; w < nw; w++) {
    if (!ti->touching[w]) continue;
    mjtNum* f = ti->force + 3 * w;
    f[0] = tire_normal_force(p, ti->kinematics + w);
    if (f[0] <= 0) continue;
    f[1] = force[2 * w];
    f[2] = force[2 * w + 1];
    apply_force(m, d, ti->wheel_body[w], frame + 9 * w, point + 3 * w, f);
  }
}


static void tire_compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  tireInstance* ti = (tireInstance*)d->plugin_data[instance];
  if (capability_bit & mjPLUGIN_PASSIVE) {
    if (ti->implicit) {
      implicit_forces(m, d, instance, ti);
    } else {
      explicit_forces(m, d, instance, ti, 1);
    }
    ti->fresh = 1;
  }
  if ((capability_bit & mjPLUGIN_SENSOR) && ti->sensor_adr >= 0) {
    // the forces applied at this step; without passive forces (disabled), the
    // forces the law would apply
    if (!ti->fresh) explicit_forces(m, d, instance, ti, 0);
    mju_copy(d->sensordata + ti->sensor_adr, ti->force, 3 * ti->nwheel);
  }
}


// Integrates the contact-point states over the step just taken.  Explicit
// coupling: with the kinematics of the start of the step (xpos, cvel and
// geom_xpos are still those here), the same that `compute` used for the
// forces.  Implicit coupling: with the rim slips at the end of the step, the
// contact rows of `compute` times the new qvel, so that stick and slip are
// decided on the velocities the step ended with.
static void tire_advance_cb(const mjModel* m, mjData* d, int instance) {
  tireInstance* ti = (tireInstance*)d->plugin_data[instance];
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  int nv = m->nv;
  for (int w = 0; w < ti->nwheel; w++) {
    tireKinematics k;
    mjtNum frame[9], point[3];
    mjtNum* st = state + TIRE_NSTATE_WHEEL * w;
    int touching;
    if (ti->implicit && ti->fresh) {
      touching = ti->touching[w];
      k = ti->kinematics[w];
      if (touching && tire_normal_force(&ti->params, &k) > 0) {
        k.slip_x = mju_dot(ti->jacobian + 2 * w * nv, d->qvel, nv);
        k.slip_y = mju_dot(ti->jacobian + (2 * w + 1) * nv, d->qvel, nv);
      }
    } else {
      touching = wheel_contact(m, d, ti, w, &k, frame, point);
    }
    if (touching) {
      tire_advance(&ti->params, &k, m->opt.timestep, st);
    } else {
      tire_reset_state(st);
      if (!ti->warned_off_floor && beyond_every_floor(m, d, ti, w)) {
        const char* name = mj_id2name(m, mjOBJ_BODY, ti->wheel_body[w]);
        mju_warning("%s instance '%s': wheel '%s' is beyond every floor at t = %.4g s (off "
                    "the edge of every heightfield, no plane): it gets no tire force; "
                    "warned once per mjData", TIRE_PLUGIN_NAME, instance_name(m, instance),
                    name ? name : "(unnamed)", d->time);
        ti->warned_off_floor = 1;
      }
    }
  }
  ti->fresh = 0;
}


mjPLUGIN_LIB_INIT(skidsteer_tire) {
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = TIRE_PLUGIN_NAME;
  plugin.capabilityflags = mjPLUGIN_PASSIVE | mjPLUGIN_SENSOR;
  plugin.needstage = mjSTAGE_VEL;
  fill_tables();
  plugin.nattribute = TIRE_NATTRIBUTE;
  plugin.attributes = kAttributeNames;
  plugin.nstate = tire_nstate;
  plugin.nsensordata = tire_nsensordata;
  plugin.init = tire_init;
  plugin.destroy = tire_destroy;
  plugin.reset = tire_reset;
  plugin.compute = tire_compute;
  plugin.advance = tire_advance_cb;
  mjp_registerPlugin(&plugin);
}
