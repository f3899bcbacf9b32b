"""The `skidsteer` command's numeric options: their physical ranges and checks.

Each option's type is a :class:`Bounded` range: argparse refuses a value that is
not a finite number in it with a message naming the option, the value, the range
and why it is the range.  What depends on the robot (is known once --model and
--build are parsed) is :func:`check_after_parse`'s: a command the robot's wheel
servos cannot follow warns (straight refuses it), and so does a time step the
tire law is not stable at.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import math
import sys

import numpy as np

from skidsteer.diagnosis.evaluate import STARTS
from skidsteer.experiments.sweep import THESIS_OMEGAS_DEG_S
from skidsteer.robot import (BASE_VARIANT, DEFAULT_ROBOT, Setup, load_model, load_robot,
                             resolve, robot_names)
from skidsteer.simulation.backends import BACKENDS, make_backend
from skidsteer.simulation.drive import DriveGeometry


@dataclasses.dataclass(frozen=True)
class Bounded:
    """An argparse type: a finite number (an integer if integer) in [low, high] unit
    ((low, high] if low_open; |value| in it if magnitude), and why that is the range."""

    low: float
    high: float
    unit: str
    reason: str
    integer: bool = False
    magnitude: bool = False
    low_open: bool = False

    @property
    def __name__(self) -> str:  # argparse names a type by it
        return "integer" if self.integer else "number"

    @property
    def allowed(self) -> str:
        """The range as the messages give it: '[1, 600] s: why'."""
        num = (lambda x: f"{int(x)}") if self.integer else (lambda x: f"{x:g}")  # noqa: E731
        low, high = num(self.low), num(self.high)
        if self.magnitude:
            interval = f"[-{high}, -{low}] or [{low}, {high}]"
        else:
            interval = f"{'(' if self.low_open else '['}{low}, {high}]"
        return f"{interval}{' ' + self.unit if self.unit else ''}: {self.reason}"

    def __call__(self, text: str) -> float | int:
        kind = "an integer" if self.integer else "a finite number"
        try:
            value = int(text) if self.integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"invalid value {text!r}: not {kind}; allowed: {self.allowed}") from None
        size = abs(value) if self.magnitude else value
        above_low = size > self.low if self.low_open else size >= self.low
        if not (math.isfinite(value) and above_low and size <= self.high):
            raise argparse.ArgumentTypeError(
                f"invalid value {text!r}: must be {kind} in {self.allowed}")
        return value


# ---------------------------------------------------------------- the ranges

# plugin/tire/README.md, "Time step" (scripts/timestep_study.py): stable to 1 ms with
# the explicit coupling (the models' own), to 2 ms with coupling="implicit"
STABLE_TIMESTEP_S = 1e-3
TIMESTEP = Bounded(1e-6, 2e-3, "s", "the tire law is unstable above 2 ms under either "
                   "coupling, plugin/tire/README.md 'Time step'; at 1 us a 20 s run would "
                   "keep ~15 GB of steps")
# a run keeps every step: ~7.5 MB per simulated second at the models' 0.1 ms (swivel,
# 2 s against 20 s: 198 MB against 334 MB peak memory)
DURATION = Bounded(1.0, 600.0, "s", "from 1 s: the swivel analysis reads from 1 Hz and "
                   "straight's steady values are its last second; to 600 s: a run keeps "
                   "every step, ~4.5 GB at 0.1 ms")
SETTLE = Bounded(0.0, 600.0, "s", "0 commands at once; the default 2 s rests the robot "
                 "on its tires, simulation.settle; a run's 600 s at most")
OMEGA = Bounded(-360.0, 360.0, "deg/s", "one turn a second, 5.6 times the thesis's "
                "fastest swivel, 64 deg/s; a warning says where the robot's wheels "
                "reach less")
# skidsteer.tasks.pioneer3at.OMEGA_RANGE_DEG_S, the tasks' own check
RENDER_OMEGA = Bounded(2.0, 64.0, "deg/s", "the thesis's swivel commands, the "
                       "pioneer3at tasks' range", magnitude=True)
# both modelled robots' wheels reach 1.2 m/s (models/*: the servos' ctrlrange x radius)
SPEED = Bounded(0.1, 5.0, "m/s", "forward, as Fig. 6.8; straight reads slip once the "
                "rims pass 5 cm/s, and the wheel servos droop up to ~2 cm/s; 5 m/s is 4 "
                "times the modelled robots' 1.2 m/s")
SLIP_VELOCITY = Bounded(0.0, 5.0, "m/s", "0: locked; 5 m/s is 4 times the modelled "
                        "robots' 1.2 m/s; a warning says where the wheels reach less")
PULL_HEIGHT = Bounded(0.0, 1.5, "m", "the cable's height above the floor: "
                      "experiments.pull's range")
PULL_DISTANCE = Bounded(0.0, 0.1, "m", "the machine moves 1 mm/s, Sec. 3.3: 0.1 m is "
                        "100 s of pulling, 10 times the default 10 mm", low_open=True)
TRIALS = Bounded(1, 100, "", "repeats of each command: 100 of the thesis's 16 omegas "
                 "on 3 floors are 4,800 runs", integer=True)
SEED = Bounded(0, 2**32 - 1, "", "NumPy's seed range", integer=True)
THREADS = Bounded(1, 256, "", "threads on this machine: past its cores they only "
                  "queue", integer=True)
SEARCH_STARTS = Bounded(1, STARTS, "", "the simulated starts of each command, "
                        "diagnosis.evaluate.STARTS", integer=True)
# the models' offscreen buffer (<visual><global offwidth/offheight>), skidsteer.tasks.video;
# that the sizes are even (H.264) is checked there
VIDEO_WIDTH = Bounded(16, 1280, "pixels", "the models' offscreen buffer", integer=True)
VIDEO_HEIGHT = Bounded(16, 720, "pixels", "the models' offscreen buffer", integer=True)
VIDEO_FPS = Bounded(1.0, 100.0, "frames/s", "one frame per action at most: the tasks' "
                    "100 Hz control")
VIDEO_SECONDS = Bounded(0.0, 600.0, "s", "a run's 600 s at most", low_open=True)


# ---------------------------------------------------------------- after parsing

@dataclasses.dataclass(frozen=True)
class WheelReach:
    """What a robot's wheel servos allow: their largest speed both ways (rad/s, the
    ctrlrange), its rim speed (m/s) and the swivel rate it gives without slip (deg/s)."""

    robot: str
    wheel_rad_s: float
    rim_mps: float
    swivel_deg_s: float

    @classmethod
    def of(cls, model: str, build: str | None) -> "WheelReach | None":
        """None where a drive actuator has no ctrlrange (nothing saturates)."""
        m = load_model(resolve(Setup(robot=model, build=build)))
        drive = DriveGeometry.from_model(m)
        ids = list(drive.left_actuators + drive.right_actuators)
        if not m.actuator_ctrllimited[ids].all():
            return None
        low, high = m.actuator_ctrlrange[ids].T
        wheel = float(np.min(np.minimum(-low, high)))
        return cls(load_robot(model).name, wheel,
                   wheel * drive.wheel_radius,
                   math.degrees(wheel * drive.wheel_radius / drive.half_track))

    @property
    def servos(self) -> str:
        return f"{self.robot}'s wheel servos (ctrlrange +-{self.wheel_rad_s:g} rad/s)"


def subcommand(parser: argparse.ArgumentParser, name: str) -> argparse.ArgumentParser:
    """The parser of a subcommand (whose usage its errors show)."""
    [sub] = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return sub.choices[name]


def _warn(text: str) -> None:
    print(f"skidsteer: warning: {text}", file=sys.stderr)


def check_after_parse(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """What the ranges cannot check before the robot is known: a yaw rate (--omega of
    swivel and sweep) or slip velocity (pull) beyond the wheels warns and runs with
    the servos at their limit; straight's --speed beyond them is refused (straight
    measures how the robot follows a command it can follow); a --timestep above the
    stable one warns."""
    timestep = getattr(args, "timestep", None)
    if timestep is not None and timestep > STABLE_TIMESTEP_S:
        _warn(f"--timestep {timestep:g} s is above {STABLE_TIMESTEP_S:g} s, the largest "
              "step the tire law is stable at with the models' explicit coupling "
              "(plugin/tire/README.md, 'Time step'): unless the model's tire plugin sets "
              "coupling=\"implicit\", expect a numerical limit cycle")
    if args.command in ("swivel", "sweep"):
        _check_omegas(args)
    elif args.command == "pull" and args.wheels == "spinning":
        reach = WheelReach.of(args.model, args.build)
        if reach and args.slip_velocity > reach.rim_mps:
            _warn(f"--slip-velocity {args.slip_velocity:g} m/s: the wheels cannot follow; "
                  f"{reach.servos} spin the rims at {reach.rim_mps:.3g} m/s at most, and "
                  "that is the slip velocity the pull will have")
    elif args.command == "straight":
        reach = WheelReach.of(args.model, args.build)
        if reach and args.speed > reach.rim_mps:
            subcommand(parser, "straight").error(
                f"argument --speed: {args.speed:g} m/s is beyond {reach.servos}: "
                f"{reach.rim_mps:.3g} m/s at most; straight measures how the robot follows a "
                "command its wheels can follow")


def _check_omegas(args: argparse.Namespace) -> None:
    """Warns of each --omega beyond the swivel the robot's wheels reach (per build);
    sweep's default omegas are the thesis's."""
    omegas = (args.omega if isinstance(args.omega, list)
              else list(THESIS_OMEGAS_DEG_S) if args.omega is None else [args.omega])
    builds = args.build if isinstance(args.build, list) else [args.build]
    for build in builds:
        reach = WheelReach.of(args.model, build)
        for omega in omegas:
            if reach and abs(omega) > reach.swivel_deg_s:
                _warn(f"--omega {omega:g} deg/s: the robot cannot follow; {reach.servos} "
                      f"reach {reach.swivel_deg_s:.0f} deg/s in a swivel without slip: the "
                      f"wheels will run at their limit, a swivel commanded at "
                      f"{math.copysign(reach.swivel_deg_s, omega):.0f} deg/s (less its "
                      "slip); the run is still named and logged as commanded")


# ------------------------------------------------------------------ the options commands share

DEFAULT = load_robot(DEFAULT_ROBOT)


class Deprecated(argparse.Action):
    """An option of an earlier release: stores into the new option's dest and says so."""

    def __init__(self, option_strings, dest, replacement: str, append: bool = False,
                 **kwargs):
        self.replacement, self.append = replacement, append
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"skidsteer: {option_string} is deprecated, use {self.replacement}",
              file=sys.stderr)
        if self.append:
            setattr(namespace, self.dest, (getattr(namespace, self.dest, None) or []) + [values])
        else:
            setattr(namespace, self.dest, values)


def add_build_floor(p: argparse.ArgumentParser, build: str | None = "extended",
                     floor: str | None = "concrete", repeat: bool = False) -> None:
    """--build and --floor (of the default robot; any name of --model's robot is checked
    when the model loads), with their deprecated aliases --config and --surface."""
    action = "append" if repeat else "store"
    extra = " (repeatable)" if repeat else ""
    p.add_argument("--build", action=action, default=None if repeat else build,
                   help=f"the robot's build{extra}; {DEFAULT.name}: "
                        f"{', '.join(DEFAULT.builds)} (default {build or 'all'})")
    p.add_argument("--floor", action=action, default=None if repeat else floor,
                   help=f"the floor{extra}; {DEFAULT.name}: {', '.join(DEFAULT.floors)} "
                        f"(default {floor or 'all'})")
    p.add_argument("--config", dest="build", action=Deprecated, replacement="--build",
                   append=repeat, help=argparse.SUPPRESS)
    p.add_argument("--surface", dest="floor", action=Deprecated, replacement="--floor",
                   append=repeat, help=argparse.SUPPRESS)


def add_model(p: argparse.ArgumentParser, default=DEFAULT_ROBOT) -> None:
    p.add_argument("--model", default=default,
                   help=f"the robot: a name ({', '.join(robot_names())}), a folder with a "
                        "robot.toml, or an MJCF .xml file")


def add_variant(p: argparse.ArgumentParser) -> None:
    p.add_argument("--variant", default=BASE_VARIANT,
                   help=f"{BASE_VARIANT} (the model as written) or one of the robot's "
                        f"variants ({DEFAULT.name}: thesis = the thesis's model as published, "
                        "eq. 5.10 inertia and eq. 6.4 contact point)")


def add_timestep(p: argparse.ArgumentParser, default=None, what="the model's") -> None:
    p.add_argument("--timestep", type=TIMESTEP, default=default, metavar="DT",
                   help=f"simulation time step, s (default: {what})")


def add_backend_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--threads", type=THREADS, default=2, help="threads of the local backend")
    p.add_argument("--backend", choices=BACKENDS, default="local",
                   help="where the runs step: threads on this machine, or one Ray task per "
                        "run (pip install 'skidsteer[ray]'); the numbers are the same")
    p.add_argument("--address", default=None,
                   help="the Ray cluster: 'auto' (the one running on this machine), "
                        "'ray://HOST:10001' (Ray Client) or a head node's HOST:6379; "
                        "default: start a Ray instance on this machine")


@contextlib.contextmanager
def backend_of(args: argparse.Namespace):
    backend = make_backend(args.backend, nthread=args.threads, address=args.address)
    try:
        yield backend
    finally:
        backend.close()


def setup_of(args: argparse.Namespace, **fields) -> Setup:
    values = {"robot": args.model, "build": args.build, "floor": args.floor,
              "variant": getattr(args, "variant", BASE_VARIANT)}
    values.update(fields)
    return Setup(**values)
