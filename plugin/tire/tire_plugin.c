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
  int nwheel;
  int* wheel_body;     // body id of each wheel, in body order
  int* wheel_joint;    // its hinge joint (the axle)
  int* wheel_geom;     // geom whose center is the wheel center (-1: body origin)
  mjtNum* radius;      // unloaded wheel radius, m
  int nfloor;
  int* floor_geom;     // plane and hfield geoms of the world body
  int sensor_adr;      // address in sensordata, -1 if no sensor names the instance
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
             (!a->finite || isfinite(value));
    if (!ok) {
      invalid(m, instance, a, text, value, a->rule);
      return -1;
    }
    cfg->value[i] = value;
  }
  return 0;
}


static int read_params(const mjModel* m, int instance, tireParams* p, mjtNum* radius) {
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
  *radius = cfg.value[ATTR_RADIUS];
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
  free(ti->floor_geom);
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

  int found = 0;
  mjtNum best = -mjMAXVAL, normal[3] = {0, 0, 1}, spread = 1;
  for (int i = 0; i < ti->nfloor; i++) {
    int f = ti->floor_geom[i];
    const mjtNum* mat = d->geom_xmat + 9 * f;
    mjtNum up[3] = {mat[2], mat[5], mat[8]};
    mjtNum cos_tilt = mju_dot3(up, axle);
    // |up - (up.axle) axle|: 1 for an upright wheel, 0 for one lying flat
    mjtNum sin_tilt = mju_sqrt(mjMAX(0, 1 - cos_tilt * cos_tilt));
    if (sin_tilt < 1e-9) continue;  // wheel lying flat: no rolling contact
    // distance from the wheel center down to its lowest rim point, along up
    mjtNum rim = radius * sin_tilt;

    mjtNum height;
    if (m->geom_type[f] == mjGEOM_PLANE) {
      mjtNum rel[3];
      mju_sub3(rel, center, d->geom_xpos + 3 * f);
      height = mju_dot3(rel, up);
    } else {
      mjtNum down[3] = {-up[0], -up[1], -up[2]};
      height = mj_rayHfield(m, d, f, center, down, NULL);
      if (height < 0) continue;  // not above this heightfield
    }
    mjtNum compression = rim - height;
    if (compression > best) {
      best = compression;
      mju_copy3(normal, up);
      spread = sin_tilt;
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
  k->compression_rate = -mju_dot3(v_rim, n);
  k->slip_x = mju_dot3(v_rim, tx);
  k->slip_y = mju_dot3(v_rim, ty);
  k->rolling_speed = mju_dot3(v_center, tx) - k->slip_x;
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


static int tire_init(const mjModel* m, mjData* d, int instance) {
  tireInstance* ti = calloc(1, sizeof(tireInstance));
  if (!ti) {
    mju_warning("%s: out of memory", TIRE_PLUGIN_NAME);
    return -1;
  }
  mjtNum radius_attr = 0;
  if (read_params(m, instance, &ti->params, &radius_attr) ||
      find_wheels_and_floor(m, instance, radius_attr, ti)) {
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


static void tire_compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  const tireInstance* ti = (const tireInstance*)d->plugin_data[instance];
  const mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  int passive = capability_bit & mjPLUGIN_PASSIVE;
  int sensor = (capability_bit & mjPLUGIN_SENSOR) && ti->sensor_adr >= 0;

  for (int w = 0; w < ti->nwheel; w++) {
    tireKinematics k;
    mjtNum frame[9], point[3], force[3] = {0, 0, 0};
    if (wheel_contact(m, d, ti, w, &k, frame, point)) {
      tire_forces(&ti->params, &k, state + TIRE_NSTATE_WHEEL * w, force);
    }
    if (sensor) {
      mju_copy3(d->sensordata + ti->sensor_adr + 3 * w, force);
    }
    if (passive && force[0] > 0) {
      mjtNum world[3];
      mju_scl3(world, frame, force[0]);
      mju_addToScl3(world, frame + 3, force[1]);
      mju_addToScl3(world, frame + 6, force[2]);
      mj_applyFT(m, d, world, NULL, point, ti->wheel_body[w], d->qfrc_passive);
    }
  }
}


// Integrates the contact-point states over the step just taken.  The
// kinematics here (xpos, cvel, geom_xpos) are those of the start of the step,
// the same that `compute` used for the forces.
static void tire_advance_cb(const mjModel* m, mjData* d, int instance) {
  const tireInstance* ti = (const tireInstance*)d->plugin_data[instance];
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  for (int w = 0; w < ti->nwheel; w++) {
    tireKinematics k;
    mjtNum frame[9], point[3];
    mjtNum* st = state + TIRE_NSTATE_WHEEL * w;
    if (wheel_contact(m, d, ti, w, &k, frame, point)) {
      tire_advance(&ti->params, &k, m->opt.timestep, st);
    } else {
      tire_reset_state(st);
    }
  }
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
