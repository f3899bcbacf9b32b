// A heightfield floor as the interpolating cubic B-spline through its samples
// (floor_interpolation="cubic"): the elevation is continuous to its curvature
// between the samples, where MuJoCo's triangles break its slope at every grid
// line.  Coefficients by the recursive filter of Unser, Aldroubi & Eden (IEEE
// Trans. Signal Process. 41, 1993), with the mirror-symmetric extension of
// scipy.ndimage's mode="mirror" (d c b | a b c d | c b a), so that the samples'
// spline is the one ndimage.map_coordinates(order=3, mode="mirror") evaluates.

#include <math.h>
#include <stdlib.h>

#include <mujoco/mujoco.h>

#include "tire_internal.h"

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


int tire_floor_splines(const mjModel* m, tireInstance* ti) {
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


// The spline's elevation (m) and slope at (x, y) of floor geom f (tire_internal.h).
int tire_spline_elevation(const mjModel* m, int f, const mjtNum* coef, mjtNum x, mjtNum y,
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
