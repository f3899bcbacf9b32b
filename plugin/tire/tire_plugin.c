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

#define TIRE_PLUGIN_NAME "skidsteer.tire"

// ---------------------------------------------------------------- attributes

static const char* const kAttributes[] = {
  "floor",
  "mu_static",
  "mu_kinetic",
  "stiffness_z",
  "damping_z",
  "stiffness_y",
  "damping_y",
  "belt_stiffness",
  "belt_damping",
  "tread_stiffness_x",
  "tread_damping_x",
  "contact_mass",
  "lambda_max",
  "contact_point",
  "radius",
};
#define TIRE_NATTRIBUTE ((int)(sizeof(kAttributes) / sizeof(kAttributes[0])))

// Floors measured in the thesis (Sec. 3.3); see plugin/tire/README.md.
typedef struct {
  const char* name;
  mjtNum mu_static;
  mjtNum mu_kinetic;
} tireFloor;

static const tireFloor kFloors[] = {
  {"concrete", 0.86, 0.786},
  {"tile", 0.86, 0.786},
  {"carpet", 0.98, 0.896},
};
#define TIRE_NFLOOR ((int)(sizeof(kFloors) / sizeof(kFloors[0])))

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


// Reads one numeric attribute; returns 0 on success, -1 (after a warning
// naming the attribute and value) on failure.  `fallback` applies when unset.
static int read_number(const mjModel* m, int instance, const char* key, mjtNum fallback,
                       mjtNum* out) {
  const char* text = mj_getPluginConfig(m, instance, key);
  if (!text || !text[0]) {
    *out = fallback;
    return 0;
  }
  char* end = NULL;
  double value = strtod(text, &end);
  while (end && (*end == ' ' || *end == '\t')) end++;
  if (end == text || (end && *end) || isnan(value)) {
    mju_warning("%s instance '%s': attribute %s=\"%s\" is not a number",
                TIRE_PLUGIN_NAME, instance_name(m, instance), key, text);
    return -1;
  }
  *out = value;
  return 0;
}


static int require(int ok, const mjModel* m, int instance, const char* key, mjtNum value,
                   const char* rule) {
  if (!ok) {
    mju_warning("%s instance '%s': attribute %s=\"%g\" is invalid: %s",
                TIRE_PLUGIN_NAME, instance_name(m, instance), key, value, rule);
    return -1;
  }
  return 0;
}


// Series spring or damper, eq. 4.14 (an infinite tread leaves the belt alone).
static mjtNum series(mjtNum tread, mjtNum belt) {
  if (isinf(tread)) return belt;
  return tread * belt / (tread + belt);
}


static int read_params(const mjModel* m, int instance, tireParams* p, mjtNum* radius) {
  const char* floor = mj_getPluginConfig(m, instance, "floor");
  const tireFloor* chosen = &kFloors[0];
  if (floor && floor[0]) {
    chosen = NULL;
    for (int i = 0; i < TIRE_NFLOOR; i++) {
      if (!strcmp(floor, kFloors[i].name)) chosen = &kFloors[i];
    }
    if (!chosen) {
      mju_warning("%s instance '%s': attribute floor=\"%s\" is unknown: "
                  "use concrete, tile or carpet, or set mu_static and mu_kinetic",
                  TIRE_PLUGIN_NAME, instance_name(m, instance), floor);
      return -1;
    }
  }

  const char* contact_point = mj_getPluginConfig(m, instance, "contact_point");
  p->relay = 0;
  if (contact_point && contact_point[0]) {
    if (!strcmp(contact_point, "relay")) {
      p->relay = 1;
    } else if (strcmp(contact_point, "coulomb")) {
      mju_warning("%s instance '%s': attribute contact_point=\"%s\" is unknown: "
                  "use coulomb (default) or relay (eq. 6.4 as the thesis simulated it)",
                  TIRE_PLUGIN_NAME, instance_name(m, instance), contact_point);
      return -1;
    }
  }

  mjtNum belt_stiffness, belt_damping, tread_stiffness, tread_damping;
  if (read_number(m, instance, "mu_static", chosen->mu_static, &p->mu_static) ||
      read_number(m, instance, "mu_kinetic", chosen->mu_kinetic, &p->mu_kinetic) ||
      read_number(m, instance, "stiffness_z", 80000, &p->stiffness_z) ||
      read_number(m, instance, "damping_z", 70, &p->damping_z) ||
      read_number(m, instance, "stiffness_y", 18000, &p->stiffness_y) ||
      read_number(m, instance, "damping_y", 30, &p->damping_y) ||
      read_number(m, instance, "belt_stiffness", 3000, &belt_stiffness) ||
      read_number(m, instance, "belt_damping", 50, &belt_damping) ||
      read_number(m, instance, "tread_stiffness_x", INFINITY, &tread_stiffness) ||
      read_number(m, instance, "tread_damping_x", INFINITY, &tread_damping) ||
      read_number(m, instance, "contact_mass", 0.035, &p->contact_mass) ||
      read_number(m, instance, "lambda_max", 0.1, &p->lambda_max) ||
      read_number(m, instance, "radius", 0, radius)) {
    return -1;
  }

  const char* positive = "must be a finite number > 0";
  const char* nonnegative = "must be a finite number >= 0";
  if (require(isfinite(p->mu_static) && p->mu_static > 0, m, instance, "mu_static",
              p->mu_static, positive) ||
      require(isfinite(p->mu_kinetic) && p->mu_kinetic >= 0, m, instance, "mu_kinetic",
              p->mu_kinetic, nonnegative) ||
      require(p->mu_kinetic <= p->mu_static, m, instance, "mu_kinetic", p->mu_kinetic,
              "must not exceed mu_static (kinetic friction above static friction)") ||
      require(isfinite(p->stiffness_z) && p->stiffness_z > 0, m, instance, "stiffness_z",
              p->stiffness_z, positive) ||
      require(isfinite(p->damping_z) && p->damping_z >= 0, m, instance, "damping_z",
              p->damping_z, nonnegative) ||
      require(isfinite(p->stiffness_y) && p->stiffness_y > 0, m, instance, "stiffness_y",
              p->stiffness_y, positive) ||
      require(isfinite(p->damping_y) && p->damping_y >= 0, m, instance, "damping_y",
              p->damping_y, nonnegative) ||
      require(isfinite(belt_stiffness) && belt_stiffness > 0, m, instance, "belt_stiffness",
              belt_stiffness, positive) ||
      require(isfinite(belt_damping) && belt_damping >= 0, m, instance, "belt_damping",
              belt_damping, nonnegative) ||
      require(tread_stiffness > 0, m, instance, "tread_stiffness_x", tread_stiffness,
              "must be > 0 (inf: rigid tread, the thesis's K_tx >> K_belt)") ||
      require(tread_damping > 0, m, instance, "tread_damping_x", tread_damping,
              "must be > 0 (inf: the thesis's D_tx >> D_belt)") ||
      require(isfinite(p->contact_mass) && p->contact_mass > 0, m, instance, "contact_mass",
              p->contact_mass, positive) ||
      require(isfinite(p->lambda_max) && p->lambda_max > 0 && p->lambda_max <= 1, m, instance,
              "lambda_max", p->lambda_max, "must lie in (0, 1]") ||
      require(isfinite(*radius) && *radius >= 0, m, instance, "radius", *radius,
              "must be > 0, or unset to take each wheel's radius from its geom")) {
    return -1;
  }
  p->stiffness_x = series(tread_stiffness, belt_stiffness);
  p->damping_x = series(tread_damping, belt_damping);
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
  plugin.nattribute = TIRE_NATTRIBUTE;
  plugin.attributes = kAttributes;
  plugin.nstate = tire_nstate;
  plugin.nsensordata = tire_nsensordata;
  plugin.init = tire_init;
  plugin.destroy = tire_destroy;
  plugin.reset = tire_reset;
  plugin.compute = tire_compute;
  plugin.advance = tire_advance_cb;
  mjp_registerPlugin(&plugin);
}
