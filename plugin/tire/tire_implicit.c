// The implicit coupling (coupling="implicit").  Unknown: the 2 nwheel rim slips u
// at the end of the step.  MuJoCo's step maps forces to velocities through
// H = M + h B (see step_matrix), so with J the contact rows and f the tire forces
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
//
// tire_implicit_forces runs it as named steps: find_contacts, normal_forces,
// other_forces, equality_reaction, slip_map, solve_slips (newton_matrix,
// line_search), stopped_forces when it stops short, apply_forces.

#include <math.h>
#include <stddef.h>

#include <mujoco/mujoco.h>

#include "tire.h"
#include "tire_internal.h"

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


// Tendon damping, treated implicitly: h b J_t^T J_t added to H on one branch.
static void add_tendon_damping(const mjModel* m, const mjData* d, const char* same_branch,
                               mjtNum h, mjtNum* H) {
  int nv = m->nv;
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


// Actuator velocity gains, treated implicitly: -h slope g^T g added to H on one
// branch, g an actuator's moment arm (transmission) row.
static void add_actuator_damping(const mjModel* m, const mjData* d, const char* same_branch,
                                 mjtNum h, mjtNum* H) {
  int nv = m->nv;
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
  if (implicit && damper) add_tendon_damping(m, d, same_branch, h, H);
  if (implicit && actuation) add_actuator_damping(m, d, same_branch, h, H);
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
// the allocations of tire_implicit_forces's steps, in their order.
size_t tire_implicit_scratch_size(int nv, int n, int ne, int nw) {
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




// One implicit step's sizes and what its steps hand on; the blocks come from the
// instance's scratch, each step taking its own in the order of
// tire_implicit_scratch_size.
typedef struct {
  int nv, nw, n;        // dofs, wheels, contact rows (x, y per wheel)
  mjtNum h;             // time step, s
  const mjtNum* state;  // the instance's plugin_state at the start of the step
  mjtNum* cursor;       // the scratch not yet taken
  mjtNum* frame;        // contact frames, 9 per wheel (rows n, t_x, t_y)
  mjtNum* point;        // contact points, 3 per wheel
  mjtNum* normal;       // the normal forces' generalized force (nv)
  mjtNum* other;        // q_other, every other generalized force of the step (nv)
  mjtNum* B;            // generalized force per unit tire force (n x nv)
  mjtNum* A;            // J H^-1 B^T (n x n)
  mjtNum* slip_free;    // the slips the step would end with without the tires (n)
  mjtNum* slip;         // the slips solved for (n)
  mjtNum* force;        // the tire forces at them (n)
  mjtNum* slope;        // their slopes d f_i / d u_i (n)
  mjtNum* residual;     // u_free + h A f(u) - u (n)
  mjtNum* trial;        // a line search's slips, forces, slopes, residual (4 n)
  mjtNum* G;            // Newton's matrix (n x n)
  mjtNum* step;         // Newton's step (n)
} implicitStep;


// Each wheel's contact (ti->touching, ->kinematics, s->frame, s->point) and, for
// the loaded ones, its contact rows t_x^T J_p, t_y^T J_p (ti->jacobian); zeroes
// ti->force.  Returns 1 when some wheel is loaded.
static int find_contacts(const mjModel* m, const mjData* d, tireInstance* ti,
                         implicitStep* s) {
  int nv = s->nv, nw = s->nw, n = s->n;
  mjtNum* J = ti->jacobian;
  s->frame = take(&s->cursor, 9 * nw);
  s->point = take(&s->cursor, 3 * nw);
  mjtNum* jacp = take(&s->cursor, 3 * nv);
  mju_zero(J, n * nv);
  mju_zero(ti->force, 3 * nw);
  int loaded = 0;
  for (int w = 0; w < nw; w++) {
    ti->touching[w] = tire_wheel_contact(m, d, ti, w, ti->kinematics + w, s->frame + 9 * w,
                                         s->point + 3 * w);
    if (ti->touching[w] && tire_normal_force(&ti->params, ti->kinematics + w) > 0) {
      mj_jac(m, d, jacp, NULL, s->point + 3 * w, ti->wheel_body[w]);
      mju_mulMatTVec(J + 2 * w * nv, jacp, s->frame + 9 * w + 3, 3, nv);
      mju_mulMatTVec(J + (2 * w + 1) * nv, jacp, s->frame + 9 * w + 6, 3, nv);
      loaded = 1;
    }
  }
  return loaded;
}


// The normal forces' generalized force (explicit: eq. 4.15 at the start of the
// step), which joins the other forces.
static void normal_forces(const mjModel* m, mjData* d, const tireInstance* ti,
                          implicitStep* s) {
  s->normal = take(&s->cursor, s->nv);
  mju_zero(s->normal, s->nv);
  for (int w = 0; w < s->nw; w++) {
    mjtNum f[3] = {ti->touching[w] ? tire_normal_force(&ti->params, ti->kinematics + w) : 0,
                   0, 0};
    if (f[0] <= 0) continue;
    mjtNum world[3];
    mju_scl3(world, s->frame + 9 * w, f[0]);
    mj_applyFT(m, d, world, NULL, s->point + 3 * w, ti->wheel_body[w], s->normal);
  }
}


// q_other: every other generalized force of the step, the equality constraints'
// reaction apart (equality_reaction adds it).  Computes the actuator forces,
// which MuJoCo computes again after this stage.
static void other_forces(const mjModel* m, mjData* d, implicitStep* s) {
  int nv = s->nv;
  s->other = take(&s->cursor, nv);
  mjtNum* bias = take(&s->cursor, nv);
  mjtNum* other = s->other;
  mju_add(other, d->qfrc_passive, s->normal, nv);  // passive so far (not the tires') + N
  mj_fwdActuation(m, d);
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
}


// The equality rows' system S = E M^-1 E^T + R (ne x ne) and its right-hand sides
// (ne x (n + 1)): column 0 for the tire-free multipliers, column 1 + c per unit
// tire force c.
static void equality_system(const mjModel* m, mjData* d, const mjtNum* J,
                            const implicitStep* s, int ne, mjtNum* E, mjtNum* EMinv,
                            mjtNum* S, mjtNum* rhs, mjtNum* JMinv, mjtNum* accel) {
  int nv = s->nv, n = s->n;
  for (int i = 0; i < ne; i++) constraint_row(m, d, i, E + i * nv);
  mj_solveM(m, d, EMinv, E, ne);
  mj_solveM(m, d, JMinv, J, n);
  mj_solveM(m, d, accel, s->other, 1);
  for (int i = 0; i < ne; i++) {
    for (int j = 0; j < ne; j++) S[i * ne + j] = mju_dot(E + i * nv, EMinv + j * nv, nv);
    S[i * ne + i] += d->efc_R[i];
    const mjtNum* kbip = d->efc_KBIP + 4 * i;
    mjtNum velocity = mju_dot(E + i * nv, d->qvel, nv);
    mjtNum aref = -kbip[1] * velocity - kbip[0] * kbip[2] * d->efc_pos[i];
    rhs[i * (n + 1)] = aref - mju_dot(E + i * nv, accel, nv);
    for (int c = 0; c < n; c++) rhs[i * (n + 1) + 1 + c] = -mju_dot(EMinv + i * nv, J + c * nv, nv);
  }
}


// B: the generalized force per unit tire force, rows J plus the reaction of
// the equality constraints (e.g. the belts that make same-side wheels turn
// together), which MuJoCo's solver gives, for rows without bounds, as
//   lambda = (E M^-1 E^T + R)^-1 (a_ref - E M^-1 q),
// linear in the tire forces; its tire-free part joins q_other.  Inequality
// rows (limits, contacts other than the tires) are left out.
static void equality_reaction(const mjModel* m, mjData* d, const tireInstance* ti,
                              implicitStep* s) {
  int nv = s->nv, n = s->n;
  const mjtNum* J = ti->jacobian;
  s->B = take(&s->cursor, n * nv);
  mju_copy(s->B, J, n * nv);
  int ne = d->ne;
  if (ne > ti->max_equality_rows) {  // cannot happen: a weld, the largest, has 6 rows
    mju_warning("%s: %d equality rows, room for %d", TIRE_PLUGIN_NAME, ne,
                ti->max_equality_rows);
    ne = 0;
  }
  if (ne == 0) return;
  mjtNum* E = take(&s->cursor, ne * nv);
  mjtNum* EMinv = take(&s->cursor, ne * nv);
  mjtNum* S = take(&s->cursor, ne * ne);
  mjtNum* rhs = take(&s->cursor, ne * (n + 1));
  mjtNum* JMinv = take(&s->cursor, n * nv);
  mjtNum* accel = take(&s->cursor, nv);
  equality_system(m, d, J, s, ne, E, EMinv, S, rhs, JMinv, accel);
  mju_cholFactor(S, ne, mjMINVAL);
  mjtNum* column = take(&s->cursor, ne);
  mjtNum* solved = take(&s->cursor, ne);
  for (int c = 0; c < n + 1; c++) {
    for (int i = 0; i < ne; i++) column[i] = rhs[i * (n + 1) + c];
    mju_cholSolve(solved, S, column, ne);
    mjtNum* target = c == 0 ? s->other : s->B + (c - 1) * nv;
    for (int i = 0; i < ne; i++) mju_addToScl(target, E + i * nv, solved[i], nv);
  }
}


// A = J H^-1 B^T and u_free = J (v + h H^-1 q_other), the slips the step would
// end with without the tires.
static void slip_map(const mjModel* m, const mjData* d, const tireInstance* ti,
                     implicitStep* s) {
  int nv = s->nv, n = s->n;
  const mjtNum* J = ti->jacobian;
  mjtNum* H = take(&s->cursor, nv * nv);
  step_matrix(m, d, ti->same_branch, s->h, H);
  mju_cholFactor(H, nv, mjMINVAL);
  mjtNum* Y = take(&s->cursor, n * nv);
  for (int r = 0; r < n; r++) mju_cholSolve(Y + r * nv, H, s->B + r * nv, nv);
  s->A = take(&s->cursor, n * n);
  for (int r = 0; r < n; r++) {
    for (int c = 0; c < n; c++) s->A[r * n + c] = mju_dot(J + r * nv, Y + c * nv, nv);
  }
  mjtNum* velocity = take(&s->cursor, nv);
  mju_cholSolve(velocity, H, s->other, nv);
  mju_scl(velocity, velocity, s->h, nv);
  mju_addTo(velocity, d->qvel, nv);
  s->slip_free = take(&s->cursor, n);
  mju_mulMatVec(s->slip_free, J, velocity, n, nv);
}


// Newton's matrix, the Jacobian of g(u) = u - u_free - h A f(u): I - h A diag(slope).
static void newton_matrix(implicitStep* s) {
  int n = s->n;
  for (int r = 0; r < n; r++) {
    for (int c = 0; c < n; c++) s->G[r * n + c] = (r == c) - s->h * s->A[r * n + c] * s->slope[c];
  }
}


// Backtracking along the Newton step from the slips: the first of steps 1, 1/2,
// ... 1/64 that lowers |g|^2 enough (Armijo) becomes the slips, forces, slopes and
// residual; returns 0 when none does.
static int line_search(const tireInstance* ti, implicitStep* s, mjtNum* merit) {
  int n = s->n;
  mjtNum* trial = s->trial;
  for (mjtNum t = 1; t >= TIRE_SMALLEST_STEP; t *= 0.5) {
    for (int r = 0; r < n; r++) trial[r] = s->slip[r] + t * s->step[r];
    mjtNum trial_merit = tire_residual(ti, s->state, s->h, s->A, s->slip_free, trial, n,
                                       trial + n, trial + 2 * n, trial + 3 * n);
    if (trial_merit <= (1 - 1e-4 * t) * *merit) {
      mju_copy(s->slip, trial, n);
      mju_copy(s->force, trial + n, n);
      mju_copy(s->slope, trial + 2 * n, n);
      mju_copy(s->residual, trial + 3 * n, n);
      *merit = trial_merit;
      return 1;
    }
  }
  return 0;
}


// Newton on g(u) = u - u_free - h A f(u) from the start-of-step slips, with a
// backtracking line search on |g|^2: f jumps where a contact point breaks
// away (static above kinetic friction), and plain Newton can cycle there.
// Returns 1 when the slips converged (|g| within TIRE_SLIP_TOLERANCE).
static int solve_slips(const tireInstance* ti, implicitStep* s) {
  int n = s->n;
  s->slip = take(&s->cursor, n);
  s->force = take(&s->cursor, n);
  s->slope = take(&s->cursor, n);
  s->residual = take(&s->cursor, n);
  s->trial = take(&s->cursor, 4 * n);  // slips, forces, slopes, residual
  s->G = take(&s->cursor, n * n);
  s->step = take(&s->cursor, n);
  for (int w = 0; w < s->nw; w++) {
    s->slip[2 * w] = ti->kinematics[w].slip_x;
    s->slip[2 * w + 1] = ti->kinematics[w].slip_y;
  }
  mjtNum merit = tire_residual(ti, s->state, s->h, s->A, s->slip_free, s->slip, n, s->force,
                               s->slope, s->residual);
  for (int it = 0; it < TIRE_MAX_ITERATIONS; it++) {
    if (max_abs(s->residual, n) <= TIRE_SLIP_TOLERANCE) return 1;
    newton_matrix(s);
    mju_copy(s->step, s->residual, n);
    if (solve_dense(s->G, s->step, n)) break;
    if (!line_search(ti, s, &merit)) break;
  }
  return 0;
}


// Stopped at a jump of f: the force that moves the slips to where the search
// stopped, h A f = u - u_free, on the loaded rows, becomes s->force.
static void stopped_forces(tireInstance* ti, implicitStep* s) {
  int nv = s->nv, n = s->n;
  const mjtNum* J = ti->jacobian;
  int* rows = ti->rows;
  int nl = 0;
  for (int r = 0; r < n; r++) {
    if (mju_norm(J + r * nv, nv) > 0) rows[nl++] = r;
  }
  for (int i = 0; i < nl; i++) {
    s->step[i] = s->slip[rows[i]] - s->slip_free[rows[i]];
    for (int j = 0; j < nl; j++) s->G[i * nl + j] = s->h * s->A[rows[i] * n + rows[j]];
  }
  if (nl > 0 && !solve_dense(s->G, s->step, nl)) {
    for (int i = 0; i < nl; i++) s->force[rows[i]] = s->step[i];
  }
}


// Each loaded wheel's [N, f_x, f_y] (N at the start of the step, f_x, f_y
// solved) into ti->force, and applied.
static void apply_forces(const mjModel* m, mjData* d, tireInstance* ti,
                         const implicitStep* s) {
  for (int w = 0; w < s->nw; w++) {
    if (!ti->touching[w]) continue;
    mjtNum* f = ti->force + 3 * w;
    f[0] = tire_normal_force(&ti->params, ti->kinematics + w);
    if (f[0] <= 0) continue;
    f[1] = s->force[2 * w];
    f[2] = s->force[2 * w + 1];
    tire_apply_force(m, d, ti->wheel_body[w], s->frame + 9 * w, s->point + 3 * w, f);
  }
}


void tire_implicit_forces(const mjModel* m, mjData* d, int instance, tireInstance* ti) {
  implicitStep s = {
      .nv = m->nv, .nw = ti->nwheel, .n = 2 * ti->nwheel, .h = m->opt.timestep,
      .state = d->plugin_state + m->plugin_stateadr[instance], .cursor = ti->scratch};
  int loaded = find_contacts(m, d, ti, &s);
  normal_forces(m, d, ti, &s);
  if (!loaded) return;
  other_forces(m, d, &s);
  equality_reaction(m, d, ti, &s);
  slip_map(m, d, ti, &s);
  if (!solve_slips(ti, &s)) stopped_forces(ti, &s);
  apply_forces(m, d, ti, &s);
}
