"""Datasets: a directory of run files described by runs.csv or by the thesis's file names.

docs/data-format.md is the contract.  ``read_dataset(root, robot=...)`` reads every
run's description (its command, its setup on the robot, its trial) and its
recording; a run that cannot be used is listed in ``Dataset.skipped`` with a
message naming the file and place, and never sinks the others.  ``group_runs``
is the one grouping of runs into commands on one setup (the repeated trials)
that every analysis and comparison uses.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Sequence, TypeVar

from skidsteer.data.files import INCOMPLETE_MARKER, write_atomically
from skidsteer.data.recording import DataError, Recording, _number, read_run
from skidsteer.robot import PLATFORM_MOUNT, Robot, Setup, load_robot

RUNS_FILE = "runs.csv"
# runs.csv columns; each may also be given by the name the thesis layout used (ALIASES)
RUNS_REQUIRED = ("file", "v_mps", "omega_deg_s", "floor", "build", "mount", "trial")
RUNS_ACCEL = ("accel_x_m", "accel_y_m", "accel_z_m")
RUNS_OPTIONAL = RUNS_ACCEL + ("notes",)
ALIASES = {"surface": "floor", "config": "build"}  # the names the thesis layout used


@dataclass(frozen=True)
class RunInfo:
    """One run: its file, the command (v_x* m/s, omega_z* deg/s), the setup it was
    recorded on, the trial number and notes."""

    file: str
    v_mps: float
    omega_deg_s: float
    setup: Setup
    trial: int
    notes: str = ""

    @property
    def group(self) -> "Group":
        return Group(self.v_mps, self.omega_deg_s, self.setup)


@dataclass(frozen=True)
class Group:
    """A command on one setup: what repeated trials share."""

    v_mps: float
    omega_deg_s: float
    setup: Setup

    @property
    def command(self) -> str:
        """The command alone, as the label starts: "v0-w60"."""
        return f"v{self.v_mps:g}-w{self.omega_deg_s:g}"

    @property
    def label(self) -> str:
        s = self.setup
        return (f"{self.command} {s.floor} {s.build}"
                + (f" on-{s.mount}" if s.mount != PLATFORM_MOUNT else ""))

    def sort_key(self) -> tuple:
        s = self.setup
        return (str(s.floor), str(s.build), s.mount, self.v_mps, self.omega_deg_s)


@dataclass
class Dataset:
    """The usable runs of a directory and, with the reason, every run that is not."""

    root: Path
    runs: list[tuple[RunInfo, Recording | None]] = field(default_factory=list)
    skipped: list[dict] = field(default_factory=list)


T = TypeVar("T")


def group_runs(items: Iterable[T], info_of=lambda item: item) -> list[tuple[Group, list[T]]]:
    """Items (runs, or anything info_of maps to a RunInfo) grouped by command and setup,
    groups sorted by floor, build, mount, v and omega; items keep their order."""
    groups: dict[Group, list[T]] = {}
    for item in items:
        groups.setdefault(info_of(item).group, []).append(item)
    return sorted(groups.items(), key=lambda kv: kv[0].sort_key())


# --------------------------------------------------------------------------- file names

_NUMBER = r"-?\d+(?:\.\d+)?"
_THESIS_NAME = re.compile(rf"v(?P<v>{_NUMBER})-w(?P<w>{_NUMBER})-t(?P<t>{_NUMBER})(?P<conf>-.*)?")
# the thesis's build and mount tokens (Appendix A): the Pioneer's builds and mounts
THESIS_TOKENS = {"onwheel": ("mount", "wheel"), "noframe": ("build", "platform")}
THESIS_DEFAULTS = {"build": "extended", "mount": PLATFORM_MOUNT}


def run_file_name(v_mps: float, omega_deg_s: float, duration_s: float, setup: Setup,
                  trial: int | None = None, suffix: str = ".csv") -> str:
    """The thesis's file name v{v}-w{omega}-t{duration}-{conf} (Appendix A), conf with
    its OnWheel / noFrame tokens, the floor and the trial number."""
    conf = (["OnWheel"] if setup.mount == "wheel" else []) + \
        (["noFrame"] if setup.build == "platform" else []) + [str(setup.floor)]
    if trial is not None:
        conf.append(str(trial))
    num = lambda x: f"{x:g}"  # noqa: E731
    return f"v{num(v_mps)}-w{num(omega_deg_s)}-t{num(duration_s)}-{'-'.join(conf)}{suffix}"


def parse_thesis_name(name: str, floors: Sequence[str]) -> dict:
    """Fields of a thesis file name, e.g. 'v0-w10-t20-OnWheel-noFrame-concrete.xlsx' (Appendix A).

    ``OnWheel`` sets mount wheel (default platform), ``noFrame`` build platform (default
    extended), a floor's name the floor (required); a trailing integer token is the trial.
    """
    stem = re.sub(r"\.(xlsx|csv)$", "", Path(name).name, flags=re.IGNORECASE)
    m = _THESIS_NAME.fullmatch(stem)
    if not m:
        raise DataError(f"{name}: not a thesis run name v{{v}}-w{{omega}}-t{{duration}}-{{conf}}")
    fields = {"v_mps": float(m["v"]), "omega_deg_s": float(m["w"]), "duration_s": float(m["t"]),
              **THESIS_DEFAULTS, "trial": 1}
    tokens = (m["conf"] or "").split("-")[1:]
    if tokens and tokens[-1].isascii() and tokens[-1].isdigit() and int(tokens[-1]) > 0:
        fields["trial"] = int(tokens.pop())
    known = {**THESIS_TOKENS, **{f.lower(): ("floor", f) for f in floors}}
    seen = set()
    for token in tokens:
        if token.lower() not in known:
            raise DataError(f"{name}: unknown token {token!r} in the file name (known: OnWheel, "
                            f"noFrame, {', '.join(floors)}, and a trailing trial number)")
        key, value = known[token.lower()]
        if key in seen:
            raise DataError(f"{name}: two {key} tokens in the file name")
        seen.add(key)
        fields[key] = value
    if "floor" not in fields:
        raise DataError(f"{name}: no floor token ({', '.join(floors)}) in the file name")
    return fields


# --------------------------------------------------------------------------- reading

def read_dataset(root, *, robot: str | Robot | None = None, load: bool = True) -> Dataset:
    """The runs of a dataset directory, their setups on `robot` (a name, folder or MJCF
    path; default: the package's default robot).  A run whose floor, build or mount the
    robot does not have is skipped with the reason.  With load=False the recordings are
    None (not read)."""
    root = Path(root)
    if not root.is_dir():
        raise DataError(f"{root}: not a directory")
    if (root / INCOMPLETE_MARKER).is_file():
        raise DataError(f"{root}: an unfinished dataset ({INCOMPLETE_MARKER}: "
                        f"{(root / INCOMPLETE_MARKER).read_text().strip()})")
    description = load_robot(robot) if robot is not None else load_robot()
    robot_ref = str(robot) if robot is not None and not isinstance(robot, Robot) \
        else description.name
    files = sorted(p.relative_to(root).as_posix() for p in root.rglob("*")
                   if p.is_file() and p.suffix.lower() in (".csv", ".xlsx")
                   and p.relative_to(root).as_posix() != RUNS_FILE
                   and not any(part.startswith((".", "~$")) for part in p.relative_to(root).parts))
    context = _Context(description, robot_ref)
    if (root / RUNS_FILE).is_file():
        infos, skipped = _read_runs_csv(root, files, context)
    else:
        infos, skipped = _infos_from_names(files, context)
    dataset = Dataset(root, [], skipped)
    for info in infos:
        try:
            dataset.runs.append((info, read_run(root / info.file) if load else None))
        except DataError as e:
            dataset.skipped.append({"file": info.file, "reason": str(e)})
    return dataset


@dataclass(frozen=True)
class _Context:
    robot: Robot
    ref: str  # how setups name the robot

    def choices(self, what: str) -> tuple[str, ...]:
        if what == "floor":
            return tuple(self.robot.floors)
        if what == "mount":
            return (PLATFORM_MOUNT, *self.robot.mounts)
        return tuple(self.robot.builds) if self.robot.single_file is None else ()

    def setup(self, build: str, floor: str, mount: str,
              position: tuple[float, float, float] | None) -> Setup:
        return Setup(self.ref, build, floor, mount, position)


def _infos_from_names(files: list[str], context: _Context) -> tuple[list[RunInfo], list[dict]]:
    infos, skipped = [], []
    for file in files:
        try:
            f = parse_thesis_name(file, context.choices("floor"))
            for what in ("build", "mount"):
                allowed = context.choices(what)
                if allowed and f[what] not in allowed:
                    raise DataError(f"{file}: {what} {f[what]!r} (from the file name) is not one "
                                    f"of robot {context.robot.name!r}'s: {', '.join(allowed)}")
        except DataError as e:
            skipped.append({"file": file, "reason": f"{e} (and there is no {RUNS_FILE})"})
            continue
        infos.append(RunInfo(file, f["v_mps"], f["omega_deg_s"],
                             context.setup(f["build"], f["floor"], f["mount"], None), f["trial"]))
    return infos, skipped


def _read_runs_csv(root: Path, files: list[str], context: _Context
                   ) -> tuple[list[RunInfo], list[dict]]:
    infos, skipped, described = [], [], {}
    unread = ""  # why a file no row describes may have no row: runs.csv itself unusable
    try:
        text = (root / RUNS_FILE).read_bytes().decode("utf-8-sig")
        reader = csv.reader(io.StringIO(text, newline=""))
        header = [c.strip() for c in next(reader, [])]
        canonical = [ALIASES.get(c, c) for c in header]
        missing = [c for c in RUNS_REQUIRED if c not in canonical]
        unknown = [c for c in header if ALIASES.get(c, c) not in RUNS_REQUIRED + RUNS_OPTIONAL]
        if missing or unknown or len(set(canonical)) != len(canonical):
            raise DataError(f"{RUNS_FILE} row 1: missing column(s) {missing}, unknown column(s) "
                            f"{unknown} (required {','.join(RUNS_REQUIRED)}; optional "
                            f"{','.join(RUNS_OPTIONAL)}; each once; surface and config are "
                            "accepted for floor and build)")
        written = dict(zip(canonical, header))  # canonical name -> the column as written
        for row in reader:
            k = reader.line_num
            if not "".join(row).strip():
                continue
            cells = dict(zip(canonical, (c.strip() for c in row)))
            try:
                if len(row) != len(header):
                    raise DataError(f"{len(row)} fields, the header has {len(header)}")
                info = _run_info(cells, written, context)
                if not (root / info.file).is_file():
                    raise DataError(f"file {info.file!r} not found in {root}")
                if info.file in described:
                    raise DataError(f"file {info.file!r} already described in row "
                                    f"{described[info.file]}")
            except DataError as e:
                skipped.append({"file": _relative(cells.get("file", "")) or RUNS_FILE,
                                "reason": f"{RUNS_FILE} row {k}: {e}"})
                continue
            described[info.file] = k
            infos.append(info)
    except (OSError, UnicodeDecodeError, csv.Error, DataError) as e:
        skipped.append({"file": RUNS_FILE, "reason": f"{root / RUNS_FILE}: unusable: {e}"})
        unread = f" ({RUNS_FILE} is unusable: see its own entry)"
    skipped += [{"file": f, "reason": f"{f}: no row of {RUNS_FILE} describes this file{unread}"}
                for f in files if f not in described and f not in {s["file"] for s in skipped}]
    return infos, skipped


def _relative(file: str) -> str:
    """A runs.csv file entry in the form read_dataset lists files ('./a.xlsx' is 'a.xlsx')."""
    return os.path.normpath(file).replace(os.sep, "/") if file else ""


def _run_info(cells: dict, written: dict, context: _Context) -> RunInfo:
    """A RunInfo from one runs.csv row (stripped strings, canonical column names); a
    DataError names the column as the file writes it."""
    file = _relative(cells.get("file", ""))
    if not file:
        raise DataError("no file given")

    def number(column: str) -> float:
        return _number(cells.get(column, ""), written.get(column, column), text=True)

    def choice(column: str) -> str:
        value = cells.get(column, "").lower()
        allowed = context.choices(column)
        if allowed and value not in allowed:
            raise DataError(f"{written.get(column, column)} {cells.get(column, '')!r} has no "
                            f"simulation counterpart (known: {', '.join(allowed)})")
        return value

    trial = cells.get("trial", "")
    if not (trial.isascii() and trial.isdigit() and int(trial) > 0):
        raise DataError(f"trial {trial!r} is not a positive integer")
    given = [c for c in RUNS_ACCEL if cells.get(c, "")]
    if given and len(given) != 3:
        raise DataError(f"{', '.join(RUNS_ACCEL)} must be given together "
                        f"(row has {', '.join(given)})")
    position = tuple(number(c) for c in RUNS_ACCEL) if given else None
    setup = context.setup(choice("build"), choice("floor"), choice("mount"), position)
    return RunInfo(file, number("v_mps"), number("omega_deg_s"), setup, int(trial),
                   cells.get("notes", ""))


# --------------------------------------------------------------------------- writing

def write_runs_csv(root, infos: list[RunInfo]) -> Path:
    """Writes root/runs.csv atomically; accel_*_m and notes columns only if some run sets them."""
    with_accel = any(i.setup.accel_position_m is not None for i in infos)
    with_notes = any(i.notes for i in infos)
    header = list(RUNS_REQUIRED) + (list(RUNS_ACCEL) if with_accel else []) + \
        (["notes"] if with_notes else [])

    def row(i: RunInfo) -> list:
        s = i.setup
        cells = [i.file, f"{i.v_mps:.12g}", f"{i.omega_deg_s:.12g}", s.floor, s.build,
                 s.mount, i.trial]
        if with_accel:
            position = s.accel_position_m
            cells += [f"{x:.12g}" for x in position] if position else ["", "", ""]
        return cells + ([i.notes] if with_notes else [])

    def write(tmp: Path) -> None:
        with open(tmp, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(header)
            w.writerows(row(i) for i in infos)

    return write_atomically(Path(root) / RUNS_FILE, write)


def with_setup(info: RunInfo, **changes) -> RunInfo:
    """info with its setup's fields changed (e.g. robot=, variant=)."""
    return dataclasses.replace(info, setup=dataclasses.replace(info.setup, **changes))
