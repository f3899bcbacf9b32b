// The explicit coupling (coupling="explicit", the default): each wheel's forces
// from the law at the state of the start of the step (tire_forces, eq. 4.9,
// 4.13, 4.15), applied as passive forces; the step then moves the robot under them.

#include <mujoco/mujoco.h>

#include "tire.h"
#include "tire_internal.h"

void tire_explicit_forces(const mjModel* m, mjData* d, int instance, tireInstance* ti,
                          int passive) {
  const mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  for (int w = 0; w < ti->nwheel; w++) {
    tireKinematics k;
    mjtNum frame[9], point[3], force[3] = {0, 0, 0};
    if (tire_wheel_contact(m, d, ti, w, &k, frame, point)) {
      tire_forces(&ti->params, &k, state + TIRE_NSTATE_WHEEL * w, force);
    }
    mju_copy3(ti->force + 3 * w, force);
    if (passive && force[0] > 0) tire_apply_force(m, d, ti->wheel_body[w], frame, point, force);
  }
}
