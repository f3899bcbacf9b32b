// An instance's data (tireInstance): the wheels that name it, the floors of the
// world body, its attributes read, and the buffers its couplings write each
// step; made when MuJoCo creates an mjData, freed with it.

#include <stdlib.h>

#include <mujoco/mujoco.h>

#include "tire.h"
#include "tire_internal.h"

int tire_count_wheels(const mjModel* m, int instance) {
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


void tire_instance_free(tireInstance* ti) {
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


// Wheel w is body b: its axle (its one joint, a hinge), the geom whose centre is
// the wheel's and its radius (radius_attr, or unset that geom's); none of its geoms
// may collide with the floor natively.  0, or -1 after a warning naming what is wrong.
static int add_wheel(const mjModel* m, const char* iname, int b, mjtNum radius_attr,
                     tireInstance* ti, int w) {
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
  return 0;
}


// The wheels: the bodies that name the instance, in body order.  0, or -1 after a
// warning.
static int find_wheels(const mjModel* m, int instance, mjtNum radius_attr, tireInstance* ti) {
  const char* iname = tire_instance_name(m, instance);
  ti->nwheel = tire_count_wheels(m, instance);
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
    if (add_wheel(m, iname, b, radius_attr, ti, w)) return -1;
    w++;
  }
  return 0;
}


// The floors: the world body's planes and heightfields.  0, or -1 after a warning.
static int find_floors(const mjModel* m, int instance, tireInstance* ti) {
  ti->nfloor = 0;
  ti->floor_geom = calloc(m->body_geomnum[0] > 0 ? m->body_geomnum[0] : 1, sizeof(int));
  for (int g = m->body_geomadr[0]; g < m->body_geomadr[0] + m->body_geomnum[0]; g++) {
    if (m->geom_type[g] == mjGEOM_PLANE || m->geom_type[g] == mjGEOM_HFIELD) {
      ti->floor_geom[ti->nfloor++] = g;
    }
  }
  if (ti->nfloor == 0) {
    mju_warning("%s instance '%s': no floor; the tire law needs a plane or hfield geom in "
                "the worldbody", TIRE_PLUGIN_NAME, tire_instance_name(m, instance));
    return -1;
  }
  return 0;
}


// The address in sensordata of the sensor that names the instance, -1 if none.
static int find_sensor(const mjModel* m, int instance) {
  int adr = -1;
  for (int s = 0; s < m->nsensor; s++) {
    if (m->sensor_type[s] == mjSENS_PLUGIN && m->sensor_plugin[s] == instance) {
      adr = m->sensor_adr[s];
    }
  }
  return adr;
}


// The buffers the couplings write each step, and the tree's branches (which
// dofs the step matrix may couple); 0, or -1 when out of memory.
static int allocate_buffers(const mjModel* m, tireInstance* ti) {
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
  ti->scratch_size = tire_implicit_scratch_size(m->nv, 2 * ti->nwheel, ti->max_equality_rows,
                                                ti->nwheel);
  ti->scratch = calloc(ti->scratch_size, sizeof(mjtNum));
  ti->rows = calloc(2 * ti->nwheel, sizeof(int));
  if (!ti->touching || !ti->kinematics || !ti->jacobian || !ti->force || !ti->same_branch ||
      !ti->scratch || !ti->rows) {
    mju_warning("%s: out of memory", TIRE_PLUGIN_NAME);
    return -1;
  }
  return 0;
}


tireInstance* tire_instance_new(const mjModel* m, int instance) {
  tireInstance* ti = calloc(1, sizeof(tireInstance));
  if (!ti) {
    mju_warning("%s: out of memory", TIRE_PLUGIN_NAME);
    return NULL;
  }
  mjtNum radius_attr = 0;
  if (tire_read_params(m, instance, &ti->params, &radius_attr, &ti->implicit, &ti->lug_count,
                       &ti->lug_depth, &ti->cubic_floor, &ti->surface_normal) ||
      find_wheels(m, instance, radius_attr, ti) || find_floors(m, instance, ti) ||
      tire_floor_splines(m, ti) || allocate_buffers(m, ti)) {
    tire_instance_free(ti);
    return NULL;
  }
  ti->sensor_adr = find_sensor(m, instance);
  return ti;
}
