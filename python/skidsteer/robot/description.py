"""Robots as data: a folder of MJCF builds described by its robot.toml.

A robot is ``models/<name>/`` (shipped with the package) or any folder of yours
holding a ``robot.toml``: its builds (MJCF files), the floors it runs on (named
sets of tire-plugin attributes with their sources), where else its
accelerometer can be mounted, and variants of the model.  A single MJCF file
given by path is a robot too: one build, which every run uses, the tire
plugin's own floors, nothing else.  The schema is in
docs/architecture.md#adding-a-robot; what a compiled model says about itself
(drive, sensors, parts) is in ``skidsteer.robot.roles``.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.resources
import sys
from pathlib import Path
from typing import Mapping

from skidsteer.robot import tire

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

DEFAULT_ROBOT = "pioneer3at"
DESCRIPTION_FILE = "robot.toml"
BASE_VARIANT = "ours"  # the model as its MJCF files have it


@dataclasses.dataclass(frozen=True)
class Build:
    name: str
    file: Path
    summary: str = ""


@dataclasses.dataclass(frozen=True)
class FloorSet:
    """A floor: the tire-plugin attributes it sets (strings, as in MJCF)."""

    name: str
    attributes: Mapping[str, str]
    source: str = ""


@dataclasses.dataclass(frozen=True)
class Mount:
    """Where the accelerometer (and gyro) can be moved: a site on `body` at `pos_m`."""

    name: str
    body: str
    pos_m: tuple[float, float, float]


@dataclasses.dataclass(frozen=True)
class Variant:
    """A variant of the model: tire attributes, and optionally the composite inertia
    about the CoM set on the compiled model (principal moments, kg m^2) for some
    builds."""

    name: str
    summary: str
    tire: Mapping[str, str]
    composite_inertia_kg_m2: tuple[float, float, float] | None = None
    inertia_builds: tuple[str, ...] = ()


@dataclasses.dataclass(frozen=True)
class Robot:
    name: str
    folder: Path | None
    summary: str
    builds: Mapping[str, Build]
    default_build: str
    floors: Mapping[str, FloorSet]
    default_floor: str | None  # the floor its MJCF files set; None: not one of `floors`
    mounts: Mapping[str, Mount]
    variants: Mapping[str, Variant]
    # a single MJCF file given by path: every build name of a dataset maps to it
    single_file: Path | None = None
    # what a diagnosis identified of this robot (diagnosis.extended_robot): its
    # parameters with intervals, the terrains they came from, the rigid rolling current
    identified: Mapping = dataclasses.field(default_factory=dict)

    @property
    def variant_names(self) -> tuple[str, ...]:
        return (BASE_VARIANT, *self.variants)

    def build(self, name: str | None) -> Build:
        """The build called `name` (None: the default)."""
        if self.single_file is not None:
            return Build(name or self.default_build, self.single_file)
        name = name or self.default_build
        if name not in self.builds:
            raise ValueError(f"robot {self.name!r} has no build {name!r}: use one of "
                             f"{list(self.builds)}")
        return self.builds[name]

    def floor(self, name: str) -> FloorSet:
        if name not in self.floors:
            raise ValueError(f"unknown floor {name!r}: robot {self.name!r} has the floors "
                             f"{list(self.floors)}")
        return self.floors[name]

    def mount(self, name: str) -> Mount:
        if name not in self.mounts:
            raise ValueError(f"unknown accelerometer mount {name!r}: robot {self.name!r} "
                             f"has {['platform', *self.mounts]} (platform: where its model "
                             "puts the accelerometer)")
        return self.mounts[name]

    def variant(self, name: str) -> Variant | None:
        """The variant called `name`; None for the base model ("ours")."""
        if name == BASE_VARIANT:
            return None
        if name not in self.variants:
            raise ValueError(f"unknown model variant {name!r}: use one of "
                             f"{list(self.variant_names)}")
        return self.variants[name]


def models_dir() -> Path:
    """models/ shipped in the package (pip install .), else the source checkout's
    (pip install -e . and running from the repository)."""
    marker = Path(DEFAULT_ROBOT) / DESCRIPTION_FILE
    installed = importlib.resources.files("skidsteer") / "models"
    if (installed / str(marker)).is_file():
        return Path(str(installed))
    checkout = Path(__file__).resolve().parents[3] / "models"
    if (checkout / marker).is_file():
        return checkout
    raise FileNotFoundError("skidsteer: the models/ directory was not installed with the "
                            "package; reinstall with `pip install .`")


def robot_names() -> tuple[str, ...]:
    """The robots shipped with the package (folders of models/ with a robot.toml)."""
    return tuple(sorted(p.parent.name for p in models_dir().glob(f"*/{DESCRIPTION_FILE}")))


def load_robot(robot: str | Path | Robot = DEFAULT_ROBOT) -> Robot:
    """A robot by name (models/<name>/), by its folder, or by the path of one MJCF file."""
    if isinstance(robot, Robot):
        return robot
    text = str(robot)
    if "/" not in text and "\\" not in text and not text.lower().endswith(".xml"):
        folder = models_dir() / text
        if (folder / DESCRIPTION_FILE).is_file():
            return _read(folder / DESCRIPTION_FILE)
    path = Path(text)
    if path.is_dir() and (path / DESCRIPTION_FILE).is_file():
        return _read((path / DESCRIPTION_FILE).resolve())
    if path.suffix.lower() == ".xml":
        if not path.is_file():
            raise FileNotFoundError(f"model file {path} does not exist")
        sibling = path.parent / DESCRIPTION_FILE
        if sibling.is_file():  # a robot folder's build, e.g. a diagnosis's extended robot
            robot = _read(sibling.resolve())
            for build in robot.builds.values():
                if build.file.resolve() == path.resolve():
                    return dataclasses.replace(robot, default_build=build.name)
        return _single_file(path.resolve())
    raise ValueError(f"unknown robot {text!r}: use one of {list(robot_names())}, a folder "
                     f"with a {DESCRIPTION_FILE}, or a path to an MJCF .xml file")


@functools.lru_cache(maxsize=None)
def _single_file(path: Path) -> Robot:
    floors = {name: FloorSet(name, {"floor": name}, f"the tire plugin's floor: {f.source}")
              for name, f in tire.floors().items()}
    return Robot(path.stem, path.parent, f"the MJCF file {path}", {}, path.stem, floors, None,
                 {}, {}, single_file=path)


def _fail(path: Path, message: str):
    raise ValueError(f"{path}: {message}")


def _table(data: dict, key: str, path: Path) -> dict:
    value = data.get(key, {})
    if not isinstance(value, dict):
        _fail(path, f"[{key}] must be a table")
    return value


@functools.lru_cache(maxsize=None)
def _read(path: Path) -> Robot:
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise ValueError(f"{path}: not a readable robot description ({err})") from None
    known = {"name", "summary", "default_build", "default_floor", "builds", "floors", "mounts",
             "variants", "identified"}
    unknown = sorted(set(data) - known)
    if unknown:
        _fail(path, f"unknown key(s) {unknown} (known: {sorted(known)})")
    folder = path.parent
    builds = {}
    for name, entry in _table(data, "builds", path).items():
        if "file" not in entry:
            _fail(path, f"[builds.{name}] has no file")
        file = folder / entry["file"]
        if not file.is_file():
            _fail(path, f"[builds.{name}] file {entry['file']!r} does not exist")
        builds[name] = Build(name, file, entry.get("summary", ""))
    if not builds:
        _fail(path, "no [builds]")
    default_build = data.get("default_build", next(iter(builds)))
    if default_build not in builds:
        _fail(path, f"default_build {default_build!r} is not one of {list(builds)}")
    attributes = tire.attributes()
    floors = {}
    for name, entry in _table(data, "floors", path).items():
        entry = dict(entry)
        source = str(entry.pop("source", ""))
        for key, value in entry.items():
            if key not in attributes:
                _fail(path, f"[floors.{name}] sets {key!r}, which is not a tire attribute "
                            f"({list(attributes)})")
            if not attributes[key].valid(value):
                _fail(path, f"[floors.{name}] {key} = {value!r}: {attributes[key].rule}")
        if "floor" in entry and not source:
            source = f"the tire plugin's floor: {tire.floors()[entry['floor']].source}"
        floors[name] = FloorSet(name, {k: str(v) for k, v in entry.items()}, source)
    default_floor = data.get("default_floor")
    if default_floor is not None and default_floor not in floors:
        _fail(path, f"default_floor {default_floor!r} is not one of {list(floors)}")
    mounts = {}
    for name, entry in _table(data, "mounts", path).items():
        if name == "platform":
            _fail(path, "[mounts.platform]: 'platform' names the model's own accelerometer place")
        try:
            mounts[name] = Mount(name, str(entry["body"]), tuple(float(x) for x in entry["pos_m"]))
        except (KeyError, TypeError, ValueError):
            _fail(path, f"[mounts.{name}] needs body = \"...\" and pos_m = [x, y, z]")
    variants = {}
    for name, entry in _table(data, "variants", path).items():
        if name == BASE_VARIANT:
            _fail(path, f"[variants.{BASE_VARIANT}]: {BASE_VARIANT!r} is the model as written")
        inertia = entry.get("composite_inertia_kg_m2")
        variants[name] = Variant(
            name, entry.get("summary", ""), {k: str(v) for k, v in entry.get("tire", {}).items()},
            tuple(float(x) for x in inertia) if inertia else None,
            tuple(entry.get("inertia_builds", builds)))
    return Robot(str(data.get("name", folder.name)), folder, str(data.get("summary", "")),
                 builds, default_build, floors, default_floor, mounts, variants,
                 identified=_table(data, "identified", path))
