// The plugin's internal units and what they share: the per-instance data and the
// functions one unit (file) calls in another.  Not part of the contract
// (tire_contract.h); tire.h is the law itself.
//
//   tire_config.c    the attribute and floor tables, an instance's attributes read
//   tire_instance.c  an instance's wheels, floors and buffers: made and freed
//   tire_floor.c     a heightfield floor as a cubic B-spline: its elevation and slope
//   tire_contact.c   a wheel's contact: floor under it, frame, point, kinematics
//   tire_explicit.c  the explicit coupling: forces of the start-of-step state
//   tire_implicit.c  the implicit coupling: the slips at the end of the step
//   tire_plugin.c    the MuJoCo callbacks and the plugin's registration

#ifndef SKIDSTEER_PLUGIN_TIRE_TIRE_INTERNAL_H_
#define SKIDSTEER_PLUGIN_TIRE_TIRE_INTERNAL_H_

#include <stddef.h>

#include <mujoco/mujoco.h>

#include "tire.h"

#define TIRE_PLUGIN_NAME "skidsteer.tire"

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

// ---------------------------------------------------------------- tire_config.c

// Fills the tables derived from the attribute and floor tables (the floor
// attribute's words and rule, the attribute names MuJoCo's compiler accepts);
// returns the attribute count and points *names at the names.  Called once, when
// the library registers the plugin.
int tire_config_attribute_names(const char* const** names);

// Reads and validates an instance's attributes into the law's parameters and the
// plugin's own settings; 0 on success, -1 after a warning naming the instance,
// attribute, value and rule.
int tire_read_params(const mjModel* m, int instance, tireParams* p, mjtNum* radius,
                     int* implicit, int* lug_count, mjtNum* lug_depth, int* cubic_floor,
                     int* surface_normal);

// The instance's name as the model gives it, or "(unnamed)".
const char* tire_instance_name(const mjModel* m, int instance);

// ---------------------------------------------------------------- tire_instance.c

// The wheel bodies that name the instance.
int tire_count_wheels(const mjModel* m, int instance);

// A new instance for the model: attributes read, wheels and floors found, buffers
// allocated; NULL after a warning saying why.
tireInstance* tire_instance_new(const mjModel* m, int instance);

void tire_instance_free(tireInstance* ti);

// ---------------------------------------------------------------- tire_floor.c

// The B-spline coefficients of every heightfield floor when floor_interpolation is
// cubic (ti->floor_spline, NULL entries otherwise); 0, or -1 after a warning.
int tire_floor_splines(const mjModel* m, tireInstance* ti);

// The spline's elevation (m) at the heightfield coordinates (x, y) of floor geom f
// (its frame, origin at its centre) and its slope (dh/dx, dh/dy).  Returns 0 when
// (x, y) lies outside the heightfield, as mj_rayHfield misses it.
int tire_spline_elevation(const mjModel* m, int f, const mjtNum* coef, mjtNum x, mjtNum y,
                          mjtNum* elevation, mjtNum slope[2]);

// ---------------------------------------------------------------- tire_contact.c

// Contact of wheel w with the floor that compresses it most.  Fills the
// kinematics, the contact frame (rows: normal n, rolling direction t_x,
// lateral t_y) and the contact point.  Returns 0 when no floor is under the
// wheel (then nothing else is filled).
int tire_wheel_contact(const mjModel* m, const mjData* d, const tireInstance* ti, int w,
                       tireKinematics* k, mjtNum frame[9], mjtNum point[3]);

// 1 when wheel w's centre lies beyond every floor (no plane, outside every
// heightfield's extent).
int tire_beyond_every_floor(const mjModel* m, const mjData* d, const tireInstance* ti, int w);

// Applies [N, f_x, f_y] (contact frame rows n, t_x, t_y) at `point` of `body`.
void tire_apply_force(const mjModel* m, mjData* d, int body, const mjtNum frame[9],
                      const mjtNum point[3], const mjtNum force[3]);

// ---------------------------------------------------------------- tire_explicit.c

// The forces of the start-of-step state into ti->force; applied when `passive`.
void tire_explicit_forces(const mjModel* m, mjData* d, int instance, tireInstance* ti,
                          int passive);

// ---------------------------------------------------------------- tire_implicit.c

// Numbers of the implicit solve's work space for nv dofs, n contact rows, ne
// equality rows and nw wheels.
size_t tire_implicit_scratch_size(int nv, int n, int ne, int nw);

// The forces at the slips the step ends with, applied; ti->force, ->touching,
// ->kinematics and ->jacobian for the sensor and advance.
void tire_implicit_forces(const mjModel* m, mjData* d, int instance, tireInstance* ti);

#endif  // SKIDSTEER_PLUGIN_TIRE_TIRE_INTERNAL_H_
