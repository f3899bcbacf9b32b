// A wheel's contact with the floor: which floor compresses it most, the contact
// frame (normal, rolling and lateral directions) and point, the kinematics the
// law reads (compression and its rate, the rim's slips, the rolling speed), and
// a contact-frame force applied at the point.

#include <math.h>

#include <mujoco/mujoco.h>

#include "tire.h"
#include "tire_internal.h"

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


// The rolling radius of wheel w: with a lugged tread, that of a polygon of
// lug_count sides, scaled to lug_depth, at the angle alpha of the wheel from its
// nearest lug, and in *drop_rate how fast it shrinks (m/s); else the radius, 0.
static mjtNum rolling_radius(const mjModel* m, const mjData* d, const tireInstance* ti, int w,
                             mjtNum* drop_rate) {
  mjtNum radius = ti->radius[w];
  *drop_rate = 0;
  if (ti->lug_count > 0 && ti->lug_depth > 0) {
    mjtNum angle, angle_rate;
    wheel_angle(m, d, ti, w, &angle, &angle_rate);
    mjtNum pitch = 2 * mjPI / ti->lug_count;
    mjtNum alpha = angle - pitch * floor(angle / pitch + 0.5);
    mjtNum scale = ti->lug_depth / (1 - cos(pitch / 2));
    radius -= scale * (1 - cos(alpha));
    *drop_rate = scale * sin(alpha) * angle_rate;
  }
  return radius;
}


// The height of the wheel centre (of `body`) above floor i, along the contact
// normal, and that normal: the floor's up, or on a cubic heightfield with
// floor_normal="surface" its own normal under the centre.  *profile_rate: how fast
// a cubic heightfield rises under the moving centre (0 elsewhere).  Returns 0 when
// the centre is not above the floor.
static int floor_height(const mjModel* m, const mjData* d, const tireInstance* ti, int i,
                        int body, const mjtNum center[3], mjtNum* height, mjtNum normal[3],
                        mjtNum* profile_rate) {
  int f = ti->floor_geom[i];
  const mjtNum* mat = d->geom_xmat + 9 * f;
  mjtNum up[3] = {mat[2], mat[5], mat[8]};
  mju_copy3(normal, up);
  *profile_rate = 0;
  if (m->geom_type[f] == mjGEOM_PLANE) {
    mjtNum rel[3];
    mju_sub3(rel, center, d->geom_xpos + 3 * f);
    *height = mju_dot3(rel, up);
  } else if (ti->floor_spline[i]) {
    // the spline's elevation under the centre, and how fast it rises under the
    // centre's motion across the floor: d(delta)/dt = -(approach) + slope . v
    mjtNum rel[3], elevation, slope[2], v_center[3];
    mju_sub3(rel, center, d->geom_xpos + 3 * f);
    mjtNum x_axis[3] = {mat[0], mat[3], mat[6]}, y_axis[3] = {mat[1], mat[4], mat[7]};
    if (!tire_spline_elevation(m, f, ti->floor_spline[i], mju_dot3(rel, x_axis),
                               mju_dot3(rel, y_axis), &elevation, slope)) {
      return 0;  // not above this heightfield
    }
    *height = mju_dot3(rel, up) - elevation;
    if (ti->surface_normal) {
      // n = (up - h_x x - h_y y) / |.|; the centre's distance to the floor's tangent
      // plane is height n.up; the floor's rise under the moving centre is in the
      // approach along n (-v.n), so no separate profile rate
      mju_addToScl3(normal, x_axis, -slope[0]);
      mju_addToScl3(normal, y_axis, -slope[1]);
      mju_normalize3(normal);
      *height *= mju_dot3(normal, up);
    } else {
      point_velocity(m, d, body, center, v_center);
      *profile_rate =
          slope[0] * mju_dot3(v_center, x_axis) + slope[1] * mju_dot3(v_center, y_axis);
    }
  } else {
    mjtNum down[3] = {-up[0], -up[1], -up[2]};
    *height = mj_rayHfield(m, d, f, center, down, NULL);
    if (*height < 0) return 0;  // not above this heightfield
  }
  return 1;
}


// The contact point, the lowest rim point: one radius from the center along -n
// with its axle component removed, (cos_tilt axle - n) / sin_tilt, sin_tilt being
// `spread`; and the contact frame's rows n, t_x = axle x n (normalised), t_y = n x t_x.
static void contact_frame(const mjtNum normal[3], const mjtNum axle[3], mjtNum spread,
                          mjtNum radius, const mjtNum center[3], mjtNum frame[9],
                          mjtNum point[3]) {
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
}


// Contact of wheel w with the floor that compresses it most (tire_internal.h).
int tire_wheel_contact(const mjModel* m, const mjData* d, const tireInstance* ti, int w,
                       tireKinematics* k, mjtNum frame[9], mjtNum point[3]) {
  int body = ti->wheel_body[w];
  int geom = ti->wheel_geom[w];
  const mjtNum* center = geom >= 0 ? d->geom_xpos + 3 * geom : d->xpos + 3 * body;
  const mjtNum* axle = d->xaxis + 3 * ti->wheel_joint[w];
  mjtNum drop_rate;
  mjtNum radius = rolling_radius(m, d, ti, w, &drop_rate);

  int found = 0;
  mjtNum best = -mjMAXVAL, normal[3] = {0, 0, 1}, spread = 1, profile_rate = 0;
  for (int i = 0; i < ti->nfloor; i++) {
    mjtNum height, floor_normal[3], rate;
    if (!floor_height(m, d, ti, i, body, center, &height, floor_normal, &rate)) continue;
    mjtNum cos_tilt = mju_dot3(floor_normal, axle);
    // |n - (n.axle) axle|: 1 for an upright wheel, 0 for one lying flat
    mjtNum sin_tilt = mju_sqrt(mjMAX(0, 1 - cos_tilt * cos_tilt));
    if (sin_tilt < 1e-9) continue;  // wheel lying flat: no rolling contact
    // distance from the wheel center down to its lowest rim point, along n
    mjtNum rim = radius * sin_tilt;
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
  contact_frame(normal, axle, spread, radius, center, frame, point);

  const mjtNum* n = frame;
  const mjtNum* tx = frame + 3;
  const mjtNum* ty = frame + 6;
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
int tire_beyond_every_floor(const mjModel* m, const mjData* d, const tireInstance* ti, int w) {
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



// Applies [N, f_x, f_y] (contact frame rows n, t_x, t_y) at `point` of `body`.
void tire_apply_force(const mjModel* m, mjData* d, int body, const mjtNum frame[9],
                      const mjtNum point[3], const mjtNum force[3]) {
  mjtNum world[3];
  mju_scl3(world, frame, force[0]);
  mju_addToScl3(world, frame + 3, force[1]);
  mju_addToScl3(world, frame + 6, force[2]);
  mj_applyFT(m, d, world, NULL, point, body, d->qfrc_passive);
}
