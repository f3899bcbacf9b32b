"""The simulation stage: wheel commands, runs on the tire plugin, where they run, what
the sensor makes of them.

``run_commanded(m, v, omega, duration)`` settles a model and drives it;
``run_batch`` and ``runs_from_rest`` step many runs in one ``mujoco.rollout``;
``SensorChain`` turns a simulated run into what an accelerometer records;
``backends`` run many simulations on threads or Ray; ``cache`` keeps their
features on disk.
"""

from skidsteer.simulation.drive import (ROT_ACCEL_DEG_S2, TRANS_ACCEL_MPS2, DriveGeometry,
                                        firmware_ramp, step_times)
from skidsteer.simulation.run import (FULLPHYSICS, LOG_RATE_HZ, TRIAL_DEFLECTION_M, Run,
                                      get_state, perturbed, rollout, run_batch, run_commanded,
                                      run_from_settled, runs_from_rest, sensor_slice,
                                      set_state, settle, swivel)

__all__ = ["FULLPHYSICS", "LOG_RATE_HZ", "ROT_ACCEL_DEG_S2", "TRANS_ACCEL_MPS2",
           "TRIAL_DEFLECTION_M", "DriveGeometry", "Run", "firmware_ramp", "get_state",
           "perturbed", "rollout", "run_batch", "run_commanded", "run_from_settled",
           "runs_from_rest", "sensor_slice", "set_state", "settle", "step_times", "swivel"]
