"""Synthetic "measured" datasets: a truth model seen through the measurement chain.

The truth is our model plus at most one effect, a candidate cause
(diagnosis.causes) or an effect outside them (OUTSIDE_EFFECTS), with seeded
parameters.  Each command is run ``trials`` times, each trial from where a previous
swivel left the robot (simulation.run.trial_start) with its tires' residual deflections
(simulation.perturbed), and recorded through sensor_chain.SensorChain.record:
the sensor's bandwidth, noise, 60 Hz hum, one zero-g offset error per axis for
the whole dataset, volts in LabVIEW xlsx files.  Nothing in the dataset names
the effect; the truth goes to a separate file when asked for.
"""

from __future__ import annotations

import zlib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Callable, Mapping

import mujoco
import numpy as np

from skidsteer.data.dataset import RunInfo, run_file_name, write_runs_csv
from skidsteer.data.files import write_json
from skidsteer.data.recording import write_run
from skidsteer.diagnosis import causes
from skidsteer.diagnosis.comparison import model_factory
from skidsteer.robot import Setup, resolve, roles
from skidsteer.simulation.run import run_from_settled, trial_start
from skidsteer.simulation.sensor_chain import SensorChain

# ------------------------------------------------------------ outside effects

FAN_FREQUENCY_HZ = 33.0  # assumed: a laptop cooling fan at ~2000 rpm
FAN_IMBALANCE_KG_M = 2e-5  # assumed: 2 g of imbalance 1 cm off a small fan's axis


def unbalanced_fan(spec: mujoco.MjSpec, params: Mapping[str, float], seed: int = 0) -> None:
    """A spinning imbalance in the laptop, at a fixed frequency whatever the command:
    no candidate cause has a source that does not scale with the wheels."""
    laptop = roles.spec_part(spec, "payload")
    if laptop is None:
        raise causes.NotApplicable("unbalanced_fan needs the model's payload part (a laptop)")
    mass = 0.02
    fan = laptop.add_body(name="fan", pos=[0.08, 0.1, 0.0])
    fan.add_geom(name="fan_imbalance", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.005],
                 pos=[params["imbalance_kg_m"] / mass, 0, 0], mass=mass, contype=0,
                 conaffinity=0, group=3)
    fan.add_joint(name="fan", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1], armature=1e-5)
    omega = 2 * np.pi * params["frequency_hz"]
    kv = 0.01  # N m s/rad: a speed loop that holds the fan within 1 % against its imbalance
    spec.add_actuator(name="fan_motor", target="fan", trntype=mujoco.mjtTrn.mjTRN_JOINT,
                      gaintype=mujoco.mjtGain.mjGAIN_FIXED, gainprm=[0] * 10,
                      biastype=mujoco.mjtBias.mjBIAS_AFFINE,
                      biasprm=[kv * omega, 0, -kv] + [0] * 7, ctrlrange=[0, 1])


OUTSIDE_EFFECTS: dict[str, tuple[Callable, dict[str, float]]] = {
    "unbalanced_fan": (unbalanced_fan, {"frequency_hz": FAN_FREQUENCY_HZ,
                                        "imbalance_kg_m": FAN_IMBALANCE_KG_M}),
}

# data/sample's recipe (scripts/make_sample_dataset.py writes it; bench_diagnose.py times
# diagnose on it with longer records): the extended robot swivelling on concrete at 15, 30
# and 60 deg/s, three trials of 10 s each, with a frame of 250 N m/rad hidden in it
SAMPLE_RECIPE = {
    "effect": "mast_compliance",
    "params": {"stiffness_n_m_per_rad": 250.0},
    "seed": 2012,
    "omegas": (15.0, 30.0, 60.0),
    "trials": 3,
    "duration_s": 10.0,
    "build": "extended",
    "floor": "concrete",
    "file_format": "csv",
}
EFFECTS = (None, *causes.CAUSES, *OUTSIDE_EFFECTS)


# ------------------------------------------------------------ trials

def truth_edit(effect: str | None, params: Mapping[str, float] | None, rng: np.random.Generator,
               draw: str = "clear", held: str = "value"
               ) -> tuple[Callable | None, dict[str, float]]:
    """(edit, parameters) of an effect; unless given, a cause's main parameter is drawn
    from its prior (draw="prior") or from the part of it clear of the base model
    (draw="clear", Cause.strong_draw): an effect inside the trials' noise cannot be
    named by any method, and the no-effect dataset already tests that verdict.  Its
    other parameters, unless given, sit at their priors' values (held="value") or are
    drawn from their priors (held="prior": a truth not shaped like the prior's middle)."""
    if held not in ("value", "prior"):
        raise ValueError(f"held must be 'value' or 'prior', got {held!r}")
    if effect is None:
        return None, {}
    realisation = int(rng.integers(2**31))
    if effect in OUTSIDE_EFFECTS:
        apply, defaults = OUTSIDE_EFFECTS[effect]
        values = {**defaults, **(params or {})}
    else:
        cause = causes.get(effect)
        values = dict(params or {})
        main = values.pop(cause.main.name, None)
        if main is None:
            if draw not in ("clear", "prior"):
                raise ValueError(f"draw must be 'clear' or 'prior', got {draw!r}")
            main = cause.strong_draw(rng) if draw == "clear" else cause.main.draw(rng)
        if held == "prior":
            values = {p.name: p.draw(rng) for p in cause.held} | values
        values = cause.parameters(main, values)
        apply = cause.apply
    return (lambda spec: apply(spec, values, realisation)), values


def make_dataset(out_dir, effect: str | None = None, params: Mapping[str, float] | None = None,
                 *, seed: int = 0, omegas=(15.0, 30.0, 60.0), trials: int = 3,
                 duration_s: float = 20.0,
                 setup: Setup = Setup(build="extended", floor="concrete"),
                 chain: SensorChain = SensorChain(),
                 file_format: str = "xlsx", nthread: int = 2, truth_path=None,
                 timestep: float | None = None, draw: str = "clear", held: str = "value"
                 ) -> dict:
    """Writes a dataset directory (run files + runs.csv) of the setup's robot with the
    effect; returns the truth."""
    if effect not in EFFECTS:
        raise ValueError(f"unknown effect {effect!r}: use one of {list(EFFECTS)}")
    if file_format not in ("xlsx", "csv"):
        raise ValueError(f"file_format must be xlsx or csv, got {file_format!r}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    edit, values = truth_edit(effect, params, rng, draw, held)
    offsets = chain.draw_offsets(rng)
    setup = resolve(setup)
    m = model_factory(edit=edit, timestep=timestep)(setup)
    infos = []
    for omega in omegas:
        seeds = [zlib.crc32(repr((seed, float(omega), k)).encode()) for k in range(trials)]
        def trial(k):  # its own start (a seed apart from perturbed's and the chain's)
            start = trial_start(m, np.random.default_rng([seeds[k], 1]))
            return run_from_settled(m, start, 0.0, float(omega), duration_s, seeds[k])

        with ThreadPoolExecutor(max_workers=max(1, nthread)) as pool:
            runs = list(pool.map(trial, range(trials)))
        for k, run in enumerate(runs):
            name = run_file_name(0.0, omega, duration_s, setup, k + 1, "." + file_format)
            time_s, accel = chain.record(run, np.random.default_rng(seeds[k]), offsets)
            write_run(out / name, time_s, accel)
            infos.append(RunInfo(name, 0.0, float(omega), setup, k + 1))
    write_runs_csv(out, infos)
    truth = {"effect": effect, "parameters": values, "seed": seed,
             "main_parameter": (causes.get(effect).main.name
                                if effect in causes.CAUSES else None)}
    if truth_path is not None:
        write_json(Path(truth_path), truth)
    return truth
