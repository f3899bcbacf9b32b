"""Pioneer 3-AT domain: swivel in place at a commanded yaw rate (Sec. 3.2 of the thesis).

Actions are the left and right wheel speed commands, rad/s, of the velocity
servos `left_motor` and `right_motor` (action_spec from their ctrlrange,
+-11.16 rad/s, the firmware's top speed).  The episode starts with the robot at
rest on its tires (settled once per Physics, then restored), with small random
residual tire deflections.

Tasks (factory keyword arguments in `_make`):
  swivel         track the commanded yaw rate omega* (body z gyro).
  swivel_smooth  the same, times a factor that penalises horizontal vibration
                 of the accelerometer cube in the thesis's 1-50 Hz band.

Observations (OrderedDict): accelerometer (3, m/s^2, specific force, cube axes),
gyro (3, rad/s, cube axes), wheel_speeds (2, rad/s, left and right drive
tendons: the mean of each side's axles), yaw_rate_error (1, rad/s, gyro z -
omega*), orientation (9, the chassis's rotation matrix, row major) and
vibration (1, m/s^2, the running 1-50 Hz RMS that swivel_smooth penalises; it
is in both tasks so that their observations are the same).
"""

from __future__ import annotations

import collections
import math
import numbers

import mujoco as mj
import numpy as np
from dm_control import mujoco
from dm_control.mujoco import wrapper
from dm_control.rl import control
from dm_control.suite import base
from dm_control.utils import containers, rewards
from scipy import signal

from skidsteer.features import signals
from skidsteer.robot import Setup, load_model, load_robot, roles, tire
from skidsteer.simulation.drive import ROT_ACCEL_DEG_S2, DriveGeometry, firmware_ramp
from skidsteer.simulation.run import FULLPHYSICS, LOG_RATE_HZ, TRIAL_DEFLECTION_M, settle

SUITE = containers.TaggedTasks()

# The thesis's swivel runs: 20 s each (Sec. 3.2), omega* from 2 to 64 deg/s.
DEFAULT_TIME_LIMIT_S = 20.0
OMEGA_RANGE_DEG_S = (2.0, 64.0)
# 100 physics steps of 0.1 ms (the model's step, models/pioneer3at/parts/setup.xml) and 10
# accelerometer samples at the thesis's 1 kHz log rate per action.  100 Hz is
# ten times the chassis's slowest modes (pitch ~3, roll ~6, yaw ~7 Hz, Table
# 5.2) and the whole "low" band (< 10 Hz, Sec. 3.2), so a policy can act on the
# rocking it excites; the 20-50 Hz tire stick-slip is beyond any wheel-speed
# loop and only the commands that cause it can be shaped.  2000 actions per
# 20 s episode; the physics dominates the cost of a step, not Python.
DEFAULT_CONTROL_TIMESTEP_S = 0.01
SETTLE_S = 2.0  # simulation.settle's default: the robot is at rest on its tires

# Yaw-rate reward, dm_control.utils.rewards.tolerance on the error e = r - omega*:
# 1 inside +-max(TRACK_REL_TOL |omega*|, TRACK_ABS_TOL_DEG_S), a Gaussian
# fall-off outside, TRACK_VALUE_AT_MARGIN at a further max(TRACK_MARGIN_REL
# |omega*|, TRACK_MARGIN_MIN_DEG_S).  Relative, so that a random omega* per
# episode gives comparable returns.  10 %: the thesis's own feed-forward,
# which ignores slip (Sec. 6.1), undershoots by 12 % at 60 deg/s in this model
# (53.0 deg/s on concrete) and by a third at 10 deg/s (6.7): the band counts
# "turns at about the commanded rate" as done and leaves the slow commands,
# where slip eats most of the command, to a policy that closes the loop.
# 0.5 deg/s floor: the yaw-rate ripple at the slowest commands (2 deg/s:
# std 0.08 deg/s at 100 Hz) must not decide the reward.  The margin: turning at
# half the commanded rate earns 0.1.
TRACK_REL_TOL = 0.10
TRACK_ABS_TOL_DEG_S = 0.5
TRACK_MARGIN_REL = 0.5
TRACK_MARGIN_MIN_DEG_S = 1.0
TRACK_VALUE_AT_MARGIN = 0.1

# Vibration factor of swivel_smooth: tolerance(rms, bounds=(0, 0),
# margin=VIBRATION_MARGIN_M_S2, value_at_margin=0.5, gaussian), where rms is the
# horizontal (cube x and y) accelerometer signal band-passed causally to the
# thesis's 1-50 Hz analysis band (Appendix A: fRange low edge 1 Hz, low-pass at
# 50 Hz) and averaged over VIBRATION_TAU_S.  No dead band: any vibration costs,
# so a smoother policy always scores higher.  The scale is assumed: 0.315 m/s^2
# RMS is where ISO 2631-1 (Annex C) stops calling vibration "not
# uncomfortable"; the factor halves there.  Under the feed-forward the
# start is what shakes: the rms peaks at 0.31-0.42 m/s^2 (30-60 deg/s on
# concrete, factor ~0.4-0.6) while the yaw rate ramps in, and falls to
# 0.02-0.03 m/s^2 (factor > 0.99) once the swivel is steady.
VIBRATION_BAND_HZ = signals.BAND_HZ
VIBRATION_FILTER_ORDER = 2  # 4th-order band-pass: the reward needs the band's power, not sharp edges
VIBRATION_TAU_S = 1.0  # one period of the band's lowest frequency
VIBRATION_MARGIN_M_S2 = 0.315
VIBRATION_VALUE_AT_MARGIN = 0.5

# The episode ends (discount 0) when the chassis tilts beyond 60 degrees: past
# the extended robot's static roll limit atan(c / h) = atan(0.18 / 0.23) = 38
# degrees, so it is falling over.
TIPPED_COS = math.cos(math.radians(60.0))

ROBOT = load_robot("pioneer3at")  # the domain's robot (models/pioneer3at/)
_SAMPLE_BUFFER = 100_000  # accelerometer samples kept if nobody consumes them (100 s)


class Physics(mujoco.Physics):
    """The robot's physics with named quantities, a cached settled state and the
    accelerometer sampled at the thesis's 1 kHz inside each (multi-step) step."""

    # --- named quantities ---------------------------------------------------
    @property
    def roles(self) -> roles.Roles:
        """The model's wheels, chassis, drive and sensors, read from the model once."""
        if "_roles" not in self.__dict__:
            self.__dict__["_roles"] = roles.roles_of(self.model.ptr)
        return self.__dict__["_roles"]

    def _slice(self, role: str) -> slice:
        slices = self.__dict__.setdefault("_slices", {})
        if role not in slices:
            r = self.roles
            slices[role] = r.sensor_slice(self.model.ptr, getattr(r, role), role)
        return slices[role]

    def accelerometer(self) -> np.ndarray:
        """Specific force at the cube, cube axes, m/s^2 (+9.81 on z at rest)."""
        return self.data.sensordata[self._slice("accelerometer")].copy()

    def gyro(self) -> np.ndarray:
        """Angular velocity of the cube, cube axes (the robot's), rad/s."""
        return self.data.sensordata[self._slice("gyro")].copy()

    def yaw_rate(self) -> float:
        """Body z angular velocity from the gyro, rad/s (the yaw rate when level)."""
        return float(self.data.sensordata[self._slice("gyro")][2])

    def wheel_speeds(self) -> np.ndarray:
        """(left, right) wheel speeds, rad/s: the velocities of the side's first drive
        actuator's transmission (a side's mean axle speed on the Pioneer's tendons)."""
        r = self.roles
        return self.data.actuator_velocity[[r.left[0], r.right[0]]].copy()

    def orientation(self) -> np.ndarray:
        """The chassis's rotation matrix (body to world), 9 values, row major."""
        return self.data.xmat[self.roles.chassis].copy()

    def upright(self) -> float:
        """Cosine of the chassis's tilt: the world z component of its z axis."""
        return float(self.data.xmat[self.roles.chassis][8])

    @property
    def drive(self) -> DriveGeometry:
        """Wheel radius, half track and motor ids, read from the model once."""
        if "_drive" not in self.__dict__:
            self.__dict__["_drive"] = DriveGeometry.from_model(self.model.ptr)
        return self.__dict__["_drive"]

    # --- the settled initial state ----------------------------------------------
    def settled_state(self) -> np.ndarray:
        """mjSTATE_FULLPHYSICS (tire plugin state included) of the robot at rest on
        its tires, settled once per Physics in a scratch MjData."""
        if self.__dict__.get("_settled") is None:
            m = self.model.ptr
            scratch = mj.MjData(m)
            self.__dict__["_settled"] = settle(m, scratch, SETTLE_S)
        return self.__dict__["_settled"]

    def restore_settled(self, random: np.random.RandomState | None = None,
                        deflection_m: float = 0.0) -> None:
        """Puts the robot at rest on the floor, time 0; with random, adds residual tire
        deflections N(0, deflection_m) per wheel and direction (the way a robot set
        down by hand never starts twice from the same tire state,
        simulation.perturbed).  Call inside reset_context()."""
        m, d = self.model.ptr, self.data.ptr
        mj.mj_setState(m, d, self.settled_state(), FULLPHYSICS)
        d.time = 0.0
        if random is not None and deflection_m > 0:
            deflection = tire.TireState(m, d.plugin_state, tire.instance_id(m)).deflection
            # one draw per wheel and direction, in the state's order (wheel, then x, y)
            deflection += random.normal(0.0, deflection_m, deflection.size).reshape(
                deflection.shape)
        self.reset_samples()

    # --- accelerometer samples at the log rate ------------------------------------
    def sample_every(self) -> int:
        """Physics steps per accelerometer sample (10 at 0.1 ms: 1 kHz)."""
        return max(1, int(round(1.0 / (LOG_RATE_HZ * self.model.opt.timestep))))

    def sample_rate_hz(self) -> float:
        return 1.0 / (self.sample_every() * self.model.opt.timestep)

    def reset_samples(self) -> None:
        self.__dict__["_samples"] = collections.deque(maxlen=_SAMPLE_BUFFER)
        self.__dict__["_steps"] = 0

    def pop_accelerometer_samples(self) -> np.ndarray:
        """(n, 3) accelerometer samples taken since the last call, oldest first."""
        if "_samples" not in self.__dict__:
            self.reset_samples()
        samples = self.__dict__["_samples"]
        out = np.array(samples).reshape(-1, 3)
        samples.clear()
        return out

    def step(self, nstep: int = 1) -> None:
        """nstep physics steps, in chunks that end on the 1 kHz sample instants."""
        if "_samples" not in self.__dict__:
            self.reset_samples()
        every, accel = self.sample_every(), self._slice("accelerometer")
        while nstep > 0:
            n = min(nstep, every - self.__dict__["_steps"] % every)
            super().step(n)
            nstep -= n
            self.__dict__["_steps"] += n
            if self.__dict__["_steps"] % every == 0:
                self.__dict__["_samples"].append(self.data.sensordata[accel].copy())


class VibrationMeter:
    """Causal 1-50 Hz band-pass of the cube's horizontal accelerations (x, y) at the
    sample rate, then an exponentially weighted mean square of the filtered signal
    (time constant VIBRATION_TAU_S), bias-corrected like Adam's moments so that it
    is the plain mean square early in an episode.  State: the filter's sos
    delay line and the running mean square; reset() starts an episode."""

    def __init__(self, sample_rate_hz: float, band=VIBRATION_BAND_HZ,
                 order: int = VIBRATION_FILTER_ORDER, tau_s: float = VIBRATION_TAU_S):
        self.sample_rate_hz = sample_rate_hz
        high = min(band[1], 0.45 * sample_rate_hz)  # below Nyquist at low sample rates
        self._sos = signal.butter(order, (band[0], high), btype="bandpass",
                                  fs=sample_rate_hz, output="sos")
        self._zi_unit = signal.sosfilt_zi(self._sos)  # steady state for a unit input
        self._decay = math.exp(-1.0 / (sample_rate_hz * tau_s))
        self.reset(np.zeros(2))

    def reset(self, first_sample: np.ndarray) -> None:
        """Starts from steady state at first_sample (x, y): a tilt's gravity
        component or a constant offset gives no start-up transient."""
        self._zi = self._zi_unit[:, :, None] * np.asarray(first_sample, float)[None, None, :]
        self._mean_square = 0.0
        self._weight = 0.0  # 1 - decay^n: the bias correction

    def update(self, samples_xy: np.ndarray) -> None:
        if len(samples_xy) == 0:
            return
        y, self._zi = signal.sosfilt(self._sos, samples_xy, axis=0, zi=self._zi)
        power = (y * y).sum(axis=1)  # x^2 + y^2 per sample
        n = len(power)
        weights = (1 - self._decay) * self._decay ** np.arange(n - 1, -1, -1)
        self._mean_square = self._decay ** n * self._mean_square + float(weights @ power)
        self._weight = self._decay ** n * self._weight + float(weights.sum())

    @property
    def rms(self) -> float:
        """Horizontal 1-50 Hz RMS, m/s^2 (0 before the first sample)."""
        return math.sqrt(self._mean_square / self._weight) if self._weight > 0 else 0.0


class Swivel(base.Task):
    """Swivel in place at omega* deg/s; optionally penalise vibration (smooth)."""

    def __init__(self, omega_deg_s: float | None = None, smooth: bool = False,
                 init_deflection_m: float = TRIAL_DEFLECTION_M, random=None):
        """
        Args:
          omega_deg_s: commanded yaw rate, deg/s; None draws one per episode,
            uniformly in OMEGA_RANGE_DEG_S (the thesis's 2 to 64 deg/s).
          smooth: multiply the reward by the vibration factor (swivel_smooth).
          init_deflection_m: std of the random residual tire deflections at the
            start of an episode (0: every episode starts from the same state).
          random: seed or numpy RandomState (dm_control's convention).
        """
        self._fixed_omega = omega_deg_s
        self._omega_deg_s = omega_deg_s if omega_deg_s is not None else float("nan")
        self._smooth = smooth
        self._init_deflection_m = init_deflection_m
        self._meter: VibrationMeter | None = None
        self._chassis_rgba = None
        super().__init__(random=random)

    @property
    def omega_deg_s(self) -> float:
        """The commanded yaw rate of the current episode, deg/s."""
        return self._omega_deg_s

    def initialize_episode(self, physics: Physics) -> None:
        physics.restore_settled(self.random, self._init_deflection_m)
        if self._fixed_omega is None:
            self._omega_deg_s = float(self.random.uniform(*OMEGA_RANGE_DEG_S))
        rate = physics.sample_rate_hz()
        if self._meter is None or self._meter.sample_rate_hz != rate:
            self._meter = VibrationMeter(rate)
        mj.mj_forward(physics.model.ptr, physics.data.ptr)
        self._meter.reset(physics.accelerometer()[:2])
        super().initialize_episode(physics)

    def after_step(self, physics: Physics) -> None:
        self._meter.update(physics.pop_accelerometer_samples()[:, :2])
        if self._visualize_reward:
            self._tint(physics, float(np.clip(self.get_reward(physics), 0.0, 1.0)))

    def _tint(self, physics: Physics, reward: float) -> None:
        """The chassis from its own colour (reward 0) to green (reward 1)."""
        rgba = physics.named.model.mat_rgba
        if self._chassis_rgba is None:
            self._chassis_rgba = rgba["chassis"].copy()
        blend = reward ** 4  # as dm_control's suite: tells high rewards apart
        rgba["chassis"] = (1 - blend) * self._chassis_rgba + blend * np.array([0.1, 0.75, 0.1, 1])

    def yaw_rate_error(self, physics: Physics) -> float:
        """Gyro z minus omega*, rad/s."""
        return physics.yaw_rate() - math.radians(self._omega_deg_s)

    def vibration_rms(self) -> float:
        return self._meter.rms if self._meter is not None else 0.0

    def get_observation(self, physics: Physics) -> collections.OrderedDict:
        obs = collections.OrderedDict()
        obs["accelerometer"] = physics.accelerometer()
        obs["gyro"] = physics.gyro()
        obs["wheel_speeds"] = physics.wheel_speeds()
        obs["yaw_rate_error"] = np.array([self.yaw_rate_error(physics)])
        obs["orientation"] = physics.orientation()
        obs["vibration"] = np.array([self.vibration_rms()])
        return obs

    def tracking_reward(self, physics: Physics) -> float:
        omega = abs(self._omega_deg_s)
        bound = max(TRACK_REL_TOL * omega, TRACK_ABS_TOL_DEG_S)
        margin = max(TRACK_MARGIN_REL * omega, TRACK_MARGIN_MIN_DEG_S)
        error = math.degrees(self.yaw_rate_error(physics))
        return rewards.tolerance(error, bounds=(-bound, bound), margin=margin,
                                 sigmoid="gaussian", value_at_margin=TRACK_VALUE_AT_MARGIN)

    def smoothness_factor(self) -> float:
        return rewards.tolerance(self.vibration_rms(), bounds=(0.0, 0.0),
                                 margin=VIBRATION_MARGIN_M_S2, sigmoid="gaussian",
                                 value_at_margin=VIBRATION_VALUE_AT_MARGIN)

    def get_reward(self, physics: Physics) -> float:
        reward = self.tracking_reward(physics)
        if self._smooth:
            reward *= self.smoothness_factor()
        return reward

    def get_termination(self, physics: Physics):
        if physics.upright() < TIPPED_COS:
            return 0.0  # tipped over
        return None


def feedforward_action(physics: Physics, omega_deg_s: float, ramp: bool = True) -> np.ndarray:
    """The thesis's feed-forward (Sec. 6.1): eq. 2.11 inverted without slip,
    (omega_L*, omega_R*) in rad/s for swivelling at omega_deg_s.  With ramp, the
    yaw rate is ramped in from rest at the firmware's 100 deg/s^2
    (simulation.ROT_ACCEL_DEG_S2) as DriveGeometry.ramp does, timed from the
    episode's start (physics time 0); the action is held for a control step."""
    drive = physics.drive if isinstance(physics, Physics) else \
        DriveGeometry.from_model(physics.model.ptr)
    omega = float(omega_deg_s)
    if ramp:
        t = physics.data.time + physics.model.opt.timestep  # as simulation.step_times
        omega = float(firmware_ramp(t, omega, ROT_ACCEL_DEG_S2))
    return drive.control(physics.model.ptr, 0.0, math.radians(omega))


def _check_options(floor, omega_deg_s, build, lambda_max, time_limit, control_timestep,
                   init_deflection_m) -> None:
    """ValueError naming the first bad option."""
    if floor not in ROBOT.floors:
        raise ValueError(f"floor: unknown floor {floor!r}, use one of {list(ROBOT.floors)}")
    if build not in ROBOT.builds:
        raise ValueError(f"build: unknown build {build!r}, use one of {sorted(ROBOT.builds)}")
    if omega_deg_s is not None:
        low, high = OMEGA_RANGE_DEG_S
        try:
            magnitude = abs(float(omega_deg_s))
        except (TypeError, ValueError):
            raise ValueError(f"omega_deg_s must be a number or None, got {omega_deg_s!r}") \
                from None
        if not low <= magnitude <= high:
            raise ValueError(f"omega_deg_s={omega_deg_s!r} is out of range: |omega| must lie in "
                             f"[{low:g}, {high:g}] deg/s, the thesis's swivel commands "
                             "(either sign), or None for a random one per episode")
    if lambda_max is not None and not (isinstance(lambda_max, numbers.Real)
                                       and 0 < lambda_max <= 1):
        raise ValueError(f"lambda_max={lambda_max!r} must lie in (0, 1] (the tire plugin's "
                         "maximum wheel slip; the thesis suggests 0.01 to 0.1)")
    if not (isinstance(time_limit, numbers.Real) and time_limit > 0):
        raise ValueError(f"time_limit={time_limit!r} must be > 0 s")
    if not (isinstance(init_deflection_m, numbers.Real) and 0 <= init_deflection_m <= 0.01):
        raise ValueError(f"init_deflection_m={init_deflection_m!r} must lie in [0, 0.01] m "
                         "(a small perturbation)")
    if not (isinstance(control_timestep, numbers.Real) and control_timestep > 0):
        raise ValueError(f"control_timestep={control_timestep!r} must be > 0 s")


def _check_control_timestep(control_timestep, timestep) -> None:
    steps = control_timestep / timestep
    if steps < 1 - 1e-9 or abs(steps - round(steps)) > 1e-6:
        raise ValueError(f"control_timestep={control_timestep!r} must be a whole multiple of "
                         f"the physics time step {timestep:g} s")


def _make(smooth: bool, floor: str = "concrete", omega_deg_s: float | None = None,
          build: str = "extended", lambda_max: float | None = None,
          init_deflection_m: float = TRIAL_DEFLECTION_M,
          time_limit: float = DEFAULT_TIME_LIMIT_S,
          control_timestep: float = DEFAULT_CONTROL_TIMESTEP_S,
          random=None, environment_kwargs=None) -> control.Environment:
    _check_options(floor, omega_deg_s, build, lambda_max, time_limit, control_timestep,
                   init_deflection_m)
    tire_attributes = {"lambda_max": lambda_max} if lambda_max is not None else None
    m = load_model(Setup(ROBOT.name, build, floor), tire=tire_attributes)
    _check_control_timestep(control_timestep, m.opt.timestep)
    physics = Physics.from_model(wrapper.MjModel(m))
    task = Swivel(omega_deg_s=omega_deg_s, smooth=smooth,
                  init_deflection_m=init_deflection_m, random=random)
    # legacy_step=False: plain mj_step, so an episode replays skidsteer.simulation's
    # physics (mujoco.rollout) bit for bit; dm_control's default mj_step1/mj_step2
    # split differs by ~1e-11 per step, which the tires' stick-slip then grows.
    environment_kwargs = {"legacy_step": False, **(environment_kwargs or {})}
    return control.Environment(physics, task, time_limit=time_limit,
                               control_timestep=control_timestep, **environment_kwargs)


_OPTIONS_DOC = """
    Args:
      floor: "concrete", "tile" or "carpet" (the Pioneer's floors, models/pioneer3at/).
      omega_deg_s: commanded yaw rate, deg/s, |omega| in [2, 64] (either sign);
        None: a random one per episode, uniform in [2, 64].
      build: "extended" (mast, laptop, camera) or "platform".
      lambda_max: the tire law's maximum slip (None: the model's 0.1).
      init_deflection_m: std of the random residual tire deflections at the
        start of an episode, m (0 for a deterministic start).
      time_limit: episode length, s (the thesis's runs: 20 s).
      control_timestep: s, a multiple of the 0.1 ms physics step (default 10 ms).
      random: seed or numpy RandomState.
      environment_kwargs: more keyword arguments of control.Environment.
"""


@SUITE.add("tracking")
def swivel(floor="concrete", omega_deg_s=None, build="extended", lambda_max=None,
           init_deflection_m=TRIAL_DEFLECTION_M, time_limit=DEFAULT_TIME_LIMIT_S,
           control_timestep=DEFAULT_CONTROL_TIMESTEP_S, random=None,
           environment_kwargs=None):
    return _make(False, floor, omega_deg_s, build, lambda_max, init_deflection_m,
                 time_limit, control_timestep, random, environment_kwargs)


@SUITE.add("tracking", "vibration")
def swivel_smooth(floor="concrete", omega_deg_s=None, build="extended", lambda_max=None,
                  init_deflection_m=TRIAL_DEFLECTION_M, time_limit=DEFAULT_TIME_LIMIT_S,
                  control_timestep=DEFAULT_CONTROL_TIMESTEP_S, random=None,
                  environment_kwargs=None):
    return _make(True, floor, omega_deg_s, build, lambda_max, init_deflection_m,
                 time_limit, control_timestep, random, environment_kwargs)


swivel.__doc__ = "Swivel in place tracking a commanded yaw rate.\n" + _OPTIONS_DOC
swivel_smooth.__doc__ = ("Swivel in place tracking a commanded yaw rate, with little "
                         "1-50 Hz horizontal vibration.\n" + _OPTIONS_DOC)
