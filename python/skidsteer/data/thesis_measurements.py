"""The thesis's measurements as data: thesis_measurements.toml beside this module.

One file holds every measured figure the reproduction report compares with
(Table 5.2, the pull tests), every Sec. 3.2 feature with its source, the rule and
the named thresholds that decide it, and the statements no rule decides, with why.
`load()` reads and checks it; every problem names the entry and the field.
"""

from __future__ import annotations

import importlib.resources
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    import tomli as tomllib

FILE_NAME = "thesis_measurements.toml"
AXES = ("roll", "pitch", "yaw")
FLOORS = ("concrete", "tile", "carpet")
BUILDS = ("extended", "platform")
MOUNTS = ("platform", "wheel")
OMEGA_SPANS = ("below_split", "above_split", "all", "lift")


class MeasurementsError(ValueError):
    """The measurements file is malformed; the message names the file, entry and field."""


@dataclass(frozen=True)
class Feature:
    """One Sec. 3.2 feature: `key` may hold {floor}, expanded over `floors`."""

    key: str
    floors: tuple[str, ...]
    build: str
    mount: str
    statement: str
    source: str
    decider: str
    rule: str
    thresholds: tuple[str, ...]
    omegas: str  # the swivel rates of the runs its rule reads: one of OMEGA_SPANS

    def keys(self) -> list[tuple[str, str]]:
        """(expanded key, floor) for each floor."""
        return [(self.key.format(floor=f), f) for f in self.floors]

    def statement_for(self, floor: str) -> str:
        return self.statement.format(floor=floor)


@dataclass(frozen=True)
class Calibration:
    """The runs a mechanism may be fitted on (the measurements file's [calibration])."""

    build: str
    mount: str
    floors: tuple[str, ...]
    max_omega_deg_s: float
    source: str

    def fitted(self, feature: Feature, floor: str, omega_split_deg_s: float) -> bool:
        """Whether every run the feature's rule reads on this floor is a calibration run
        (then the feature is in the fitted set; otherwise it is predicted)."""
        return (feature.build == self.build and feature.mount == self.mount
                and floor in self.floors and feature.omegas == "below_split"
                and omega_split_deg_s <= self.max_omega_deg_s)


@dataclass(frozen=True)
class Measurements:
    path: Path
    document: dict
    free_response: dict  # axis -> {peak_hz, std_hz, decay_per_s, source}; "targets"
    pull: dict
    thresholds: dict  # name -> {"value": ..., "reason": ...}
    features: tuple[Feature, ...]
    undecided: tuple[dict, ...]
    calibration: Calibration

    def threshold(self, name: str):
        return self.thresholds[name]["value"]

    def feature(self, key: str) -> tuple[Feature, str]:
        """The feature entry and floor an expanded key (e.g. dominance_switch_tile) is of."""
        for f in self.features:
            for k, floor in f.keys():
                if k == key:
                    return f, floor
        raise KeyError(f"{self.path.name}: no feature {key!r}")

    def feature_keys(self) -> list[str]:
        return [k for f in self.features for k, _ in f.keys()]

    def fitted(self, key: str) -> bool:
        """Whether the expanded feature key is in the calibration (fitted) set."""
        feature, floor = self.feature(key)
        return self.calibration.fitted(feature, floor, self.threshold("omega_split_deg_s"))


def default_path() -> Path:
    return Path(str(importlib.resources.files("skidsteer.data") / FILE_NAME))


@lru_cache(maxsize=None)
def load(path: str | Path | None = None) -> Measurements:
    """The measurements in path (default: the package's file), checked."""
    path = Path(path) if path is not None else default_path()
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise MeasurementsError(f"{path}: cannot read: {err}") from err
    where = path.name
    if data.get("schema") != 1:
        raise MeasurementsError(f"{where}: schema must be 1, got {data.get('schema')!r}")
    fr = _table(data, "free_response", where)
    for axis in AXES:
        entry = _table(fr, axis, f"{where}: free_response")
        for field in ("peak_hz", "std_hz", "decay_per_s"):
            _positive(entry, field, f"{where}: free_response.{axis}")
        _text(entry, "source", f"{where}: free_response.{axis}")
    targets = _table(fr, "targets", f"{where}: free_response")
    for field in ("frequency_relative_error", "decay_factor"):
        _positive(targets, field, f"{where}: free_response.targets")
    pull = _table(data, "pull", where)
    for name in ("lateral_first_peak_N", "lateral_slope_over_stiffness", "spinning_steady_N",
                 "longitudinal_slope_N_per_m"):
        entry = _table(pull, name, f"{where}: pull")
        _text(entry, "source", f"{where}: pull.{name}")
        ranges = {k: v for k, v in entry.items() if isinstance(v, list)}
        if not ranges:
            raise MeasurementsError(f"{where}: pull.{name} has no [low, high] range")
        for k, v in ranges.items():
            _range(v, f"{where}: pull.{name}.{k}")
    pull_targets = _table(pull, "targets", f"{where}: pull")
    _positive(pull_targets, "first_peak_relative_to_mu_s_N", f"{where}: pull.targets")
    _text(pull_targets, "source", f"{where}: pull.targets")
    _text(targets, "source", f"{where}: free_response.targets")
    thresholds = _table(data, "thresholds", where)
    for name, entry in thresholds.items():
        at = f"{where}: thresholds.{name}"
        if not isinstance(entry, dict) or "value" not in entry:
            raise MeasurementsError(f"{at}: needs a value")
        values = entry["value"] if isinstance(entry["value"], list) else [entry["value"]]
        if not values or not all(_finite(v) for v in values):
            raise MeasurementsError(f"{at}.value must be finite numbers, got {entry['value']!r}")
        _text(entry, "reason", at)
    features, seen = [], set()
    for i, entry in enumerate(data.get("features", [])):
        at = f"{where}: features[{i}]" + (f" ({entry.get('key')})" if "key" in entry else "")
        for field in ("key", "build", "mount", "omegas", "statement", "source", "decider",
                      "rule"):
            _text(entry, field, at)
        floors = tuple(entry.get("floors") or ())
        if not floors or any(f not in FLOORS for f in floors):
            raise MeasurementsError(f"{at}.floors must be some of {FLOORS}, got {floors!r}")
        if len(floors) > 1 and "{floor}" not in entry["key"]:
            raise MeasurementsError(f"{at}.key must hold {{floor}} to name {len(floors)} floors")
        if entry["build"] not in BUILDS:
            raise MeasurementsError(f"{at}.build must be one of {BUILDS}, got {entry['build']!r}")
        if entry["mount"] not in MOUNTS:
            raise MeasurementsError(f"{at}.mount must be one of {MOUNTS}, got {entry['mount']!r}")
        if entry["omegas"] not in OMEGA_SPANS:
            raise MeasurementsError(f"{at}.omegas must be one of {OMEGA_SPANS}, got "
                                    f"{entry['omegas']!r}")
        named = tuple(entry.get("thresholds") or ())
        unknown = [t for t in named if t not in thresholds]
        if unknown:
            raise MeasurementsError(f"{at}.thresholds: no threshold named {unknown}")
        feature = Feature(entry["key"], floors, entry["build"], entry["mount"],
                          entry["statement"], entry["source"], entry["decider"], entry["rule"],
                          named, entry["omegas"])
        for key, _ in feature.keys():
            if key in seen:
                raise MeasurementsError(f"{at}.key: {key!r} appears twice")
            seen.add(key)
        features.append(feature)
    if not features:
        raise MeasurementsError(f"{where}: no [[features]]")
    undecided = []
    for i, entry in enumerate(data.get("undecided", [])):
        for field in ("statement", "source", "reason"):
            _text(entry, field, f"{where}: undecided[{i}]")
        undecided.append(dict(entry))
    cal = _table(data, "calibration", where)
    at = f"{where}: calibration"
    cal_floors = tuple(cal.get("floors") or ())
    if not cal_floors or any(f not in FLOORS for f in cal_floors):
        raise MeasurementsError(f"{at}.floors must be some of {FLOORS}, got {cal_floors!r}")
    if cal.get("build") not in BUILDS:
        raise MeasurementsError(f"{at}.build must be one of {BUILDS}, got {cal.get('build')!r}")
    if cal.get("mount") not in MOUNTS:
        raise MeasurementsError(f"{at}.mount must be one of {MOUNTS}, got {cal.get('mount')!r}")
    calibration = Calibration(cal["build"], cal["mount"], cal_floors,
                              _positive(cal, "max_omega_deg_s", at), _text(cal, "source", at))
    return Measurements(path, dict(_table(data, "document", where)), fr, pull, thresholds,
                        tuple(features), tuple(undecided), calibration)


def _table(data: dict, name: str, where: str) -> dict:
    value = data.get(name)
    if not isinstance(value, dict):
        raise MeasurementsError(f"{where}: missing table [{name}]")
    return value


def _text(entry: dict, field: str, where: str) -> str:
    value = entry.get(field)
    if not isinstance(value, str) or not value.strip():
        raise MeasurementsError(f"{where}.{field}: missing (a non-empty text)")
    return value


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _positive(entry: dict, field: str, where: str) -> float:
    value = entry.get(field)
    if not _finite(value) or value <= 0:
        raise MeasurementsError(f"{where}.{field} must be a positive number, got {value!r}")
    return float(value)


def _range(value, where: str) -> None:
    if (len(value) != 2 or not all(_finite(v) for v in value) or value[0] > value[1]):
        raise MeasurementsError(f"{where} must be [low, high] with low <= high, got {value!r}")
