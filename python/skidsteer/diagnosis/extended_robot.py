"""The identified robot as a robot folder that ``--model`` takes back.

A diagnosis of real recordings writes ``extended_model.xml`` (the robot's build with
the robot's identified parameters: tire law, tread, centre of mass, drive) and beside
it a ``robot.toml`` (docs/architecture.md#adding-a-robot) whose floors are the robot's
own plus each rigid terrain the diagnosis identified (its friction fitted), and whose
``[identified]`` table says what was identified, from which terrains, with intervals.
``skidsteer diagnose NEW_TERRAIN --model DIR/extended_model.xml`` then runs the robot as
identified: on a terrain it never fitted, its friction is the robot's default floor's
until that terrain's own runs identify it (robot parameters are not fitted again).
"""

from __future__ import annotations

from pathlib import Path

import tomli_w

from skidsteer.data.files import write_text
from skidsteer.diagnosis import motion
from skidsteer.robot import Setup, load_spec

MODEL_FILE = "extended_model.xml"
DESCRIPTION = "robot.toml"
# the floor attributes a terrain's fit sets (motion.apply's names for the terrain's values)
TERRAIN_ATTRIBUTES = ("mu_static", "lateral_friction_ratio")


def write(out: Path, robot, model: str, named, terrains: dict[str, dict],
          rolling_current_a: float | None, dataset: list[str]) -> Path:
    """Writes out/extended_model.xml and out/robot.toml; returns the model's path.

    robot: the diagnosed robot (description.Robot); model: how it was named (--model);
    named: the named fit (identify.MotionFit) or None (the robot as it was);
    terrains: per terrain name, {"floor": the robot's floor it ran on or None,
    "setup_floor": the floor its model used, "rigid": bool, "identified": an unknown
    terrain's own fit (recordings.identify_terrain) or None}."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    spec = load_spec(Setup(robot=str(model), build=robot.default_build,
                           floor=robot.default_floor))
    robot_values = dict(named.robot) if named else {}
    motion.apply(spec, {**robot_values, **(named.settings if named else {})})
    write_text(out / MODEL_FILE, spec.to_xml())
    floors = {name: {**dict(f.attributes), "source": f.source} for name, f in robot.floors.items()}
    for terrain, info in terrains.items():
        fitted = named.terrain.get(terrain, {}) if named else {}
        intervals = {k.split("@")[0]: v for k, v in (named.intervals if named else {}).items()
                     if k.endswith(f"@{terrain}")}
        if info.get("identified"):  # an unknown terrain's own fit
            fitted = dict(info["identified"]["parameters"])
            intervals = dict(info["identified"]["intervals"])
        if not info["rigid"] or (info["floor"] is None and not fitted):
            continue
        name = info["floor"] or terrain.lower()
        base = dict(robot.floors[info["setup_floor"]].attributes) if info["setup_floor"] else {}
        entry = dict(floors.get(name, base))
        entry.pop("source", None)
        spec_floor = load_spec(Setup(robot=str(model), build=robot.default_build,
                                     floor=info["setup_floor"]))
        motion.apply(spec_floor, fitted)
        config = dict(spec_floor.plugins[0].config)
        for key in ("mu_static", "mu_kinetic", "lateral_friction_ratio"):
            if key in config and (key in fitted or key.replace("kinetic", "static") in fitted):
                entry[key] = float(config[key])
        entry["source"] = (
            f"identified by skidsteer diagnose on {terrain} ({', '.join(dataset)}): "
            + (", ".join(f"{k} {fitted[k]:.3g} (interval {intervals[k][0]:.3g}-"
                         f"{intervals[k][1]:.3g})" for k in fitted) if fitted else
               "no terrain parameter needed beyond the robot's")
            + f"; the rest as the floor {info['setup_floor']!r}")
        floors[name] = entry
    identified = {"from_terrains": sorted(t for t, i in terrains.items() if i["rigid"]),
                  "dataset": dataset,
                  "causes": list(named.causes) if named else [],
                  "parameters": {k: {"value": v, "interval": list(named.intervals.get(k, (v, v)))}
                                 for k, v in robot_values.items()},
                  "settings": dict(named.settings) if named else {}}
    if rolling_current_a is not None:
        identified["rolling_current_a"] = rolling_current_a
    description = {
        "name": f"{robot.name}_identified",
        "summary": f"{robot.summary or robot.name}, identified from recordings by skidsteer "
                   "diagnose",
        "default_build": "base", "default_floor": robot.default_floor,
        "builds": {"base": {"file": MODEL_FILE,
                            "summary": f"{robot.name}'s {robot.default_build} build with the "
                                       "identified robot parameters"}},
        "floors": floors, "identified": identified}
    if robot.default_floor is None:
        description.pop("default_floor")
    write_text(out / DESCRIPTION, "# Written by skidsteer diagnose: the robot identified from "
               "recordings (diagnosis.extended_robot).\n" + tomli_w.dumps(description))
    return out / MODEL_FILE
