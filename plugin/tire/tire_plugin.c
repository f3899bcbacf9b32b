// MuJoCo engine plugin "skidsteer.tire": the thesis's tire law (tire_law.c) in
// place of native wheel/floor contacts.
//
// One instance serves every wheel that names it (<plugin instance="..."/>
// inside the wheel body).  Per wheel it finds the floor under the wheel,
// builds the contact frame, applies [N, f_x, f_y] at the contact point as a
// passive force, integrates the contact-point states in `advance`, and, when a
// <sensor><plugin instance="..."/></sensor> names it, reports the forces.
//
// This file holds the MuJoCo callbacks and the registration; the units they call
// are listed in tire_internal.h.

#include <stdint.h>

#include <mujoco/mujoco.h>

#include "tire.h"
#include "tire_internal.h"


static int tire_nstate(const mjModel* m, int instance) {
  return TIRE_NSTATE_WHEEL * tire_count_wheels(m, instance);
}


static int tire_nsensordata(const mjModel* m, int instance, int sensor_id) {
  (void)sensor_id;
  return 3 * tire_count_wheels(m, instance);
}


static int tire_init(const mjModel* m, mjData* d, int instance) {
  tireInstance* ti = tire_instance_new(m, instance);
  if (!ti) return -1;
  d->plugin_data[instance] = (uintptr_t)ti;
  return 0;
}


static void tire_destroy(mjData* d, int instance) {
  tire_instance_free((tireInstance*)d->plugin_data[instance]);
  d->plugin_data[instance] = 0;
}


static void tire_reset(const mjModel* m, mjtNum* plugin_state, void* plugin_data,
                       int instance) {
  (void)plugin_data;
  int nwheel = tire_count_wheels(m, instance);
  for (int w = 0; w < nwheel; w++) {
    tire_reset_state(plugin_state + TIRE_NSTATE_WHEEL * w);
  }
}


static void tire_compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  tireInstance* ti = (tireInstance*)d->plugin_data[instance];
  if (capability_bit & mjPLUGIN_PASSIVE) {
    if (ti->implicit) {
      tire_implicit_forces(m, d, instance, ti);
    } else {
      tire_explicit_forces(m, d, instance, ti, 1);
    }
    ti->fresh = 1;
  }
  if ((capability_bit & mjPLUGIN_SENSOR) && ti->sensor_adr >= 0) {
    // the forces applied at this step; without passive forces (disabled), the
    // forces the law would apply
    if (!ti->fresh) tire_explicit_forces(m, d, instance, ti, 0);
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
      touching = tire_wheel_contact(m, d, ti, w, &k, frame, point);
    }
    if (touching) {
      tire_advance(&ti->params, &k, m->opt.timestep, st);
    } else {
      tire_reset_state(st);
      if (!ti->warned_off_floor && tire_beyond_every_floor(m, d, ti, w)) {
        const char* name = mj_id2name(m, mjOBJ_BODY, ti->wheel_body[w]);
        mju_warning("%s instance '%s': wheel '%s' is beyond every floor at t = %.4g s (off "
                    "the edge of every heightfield, no plane): it gets no tire force; "
                    "warned once per mjData", TIRE_PLUGIN_NAME, tire_instance_name(m, instance),
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
  plugin.nattribute = tire_config_attribute_names(&plugin.attributes);
  plugin.nstate = tire_nstate;
  plugin.nsensordata = tire_nsensordata;
  plugin.init = tire_init;
  plugin.destroy = tire_destroy;
  plugin.reset = tire_reset;
  plugin.compute = tire_compute;
  plugin.advance = tire_advance_cb;
  mjp_registerPlugin(&plugin);
}
