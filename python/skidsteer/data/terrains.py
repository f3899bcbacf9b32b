"""Recordings of one robot on several terrains: one dataset per terrain.

A terrain is a folder of IMU runs (the BorealTC layout, docs/data-format.md), a ROS
bag folder, or a .bag/.mcap file; its name is the folder's (a bag file's: its
parent folder's).  ``terrain_paths`` takes what a user names on the command line:
terrain folders, or one folder holding terrain folders.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Iterable

from skidsteer.data.imu import ImuDataset, is_imu_folder, read_bag, read_imu_folder
from skidsteer.data.recording import DataError


@dataclasses.dataclass
class Terrain:
    name: str
    path: Path
    data: ImuDataset


def terrain_paths(paths: Iterable) -> list[Path]:
    """Each path as terrains: itself when it holds recordings (is_imu_folder), else its
    subfolders that do, in name order.  Raises DataError naming a path that holds
    neither, and a terrain named twice."""
    out: list[Path] = []
    for given in paths:
        path = Path(given)
        if not path.exists():
            raise DataError(f"{path}: no such file or folder")
        if is_imu_folder(path):
            out.append(path)
            continue
        inner = sorted(p for p in path.iterdir() if p.is_dir() and is_imu_folder(p)) \
            if path.is_dir() else []
        if not inner:
            raise DataError(f"{path}: neither recordings (imu_NN.csv with pro_NN.csv, a ROS bag "
                            "or MCAP) nor folders of them")
        out.extend(inner)
    names = [terrain_name(p) for p in out]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise DataError(f"terrain(s) {twice} given twice ({', '.join(map(str, out))})")
    return out


def terrain_name(path: Path) -> str:
    path = Path(path)
    return path.name if path.is_dir() and not (path / "metadata.yaml").is_file() \
        else path.parent.name if path.is_file() else path.name


def read_terrain(path, track_m: float) -> Terrain:
    """A terrain's recordings: a folder of runs, or one bag (a dataset of one run)."""
    path = Path(path)
    name = terrain_name(path)
    if path.is_dir() and not (path / "metadata.yaml").is_file():
        return Terrain(name, path, read_imu_folder(path, track_m=track_m))
    data = ImuDataset(path.parent if path.is_file() else path)
    data.runs.append(read_bag(path, terrain=name))
    return Terrain(name, path, data)
