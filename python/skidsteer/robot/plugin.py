"""Finds the compiled skidsteer.tire plugin and registers it with MuJoCo."""

from __future__ import annotations

import importlib.resources
import os
from pathlib import Path

import mujoco

PLUGIN_NAME = "skidsteer.tire"
_LIBRARY_NAME = "libskidsteer_tire.so"
_loaded: Path | None = None


def library_path() -> Path:
    """Path of the plugin library installed with the package.

    Found through importlib.resources so that editable installs work too;
    SKIDSTEER_PLUGIN_LIBRARY overrides it (e.g. a sanitizer build).
    """
    override = os.environ.get("SKIDSTEER_PLUGIN_LIBRARY")
    if override:
        return Path(override)
    for entry in importlib.resources.files("skidsteer").iterdir():
        if entry.name == _LIBRARY_NAME:
            return Path(str(entry))
    raise FileNotFoundError(
        f"{_LIBRARY_NAME} is not installed next to the skidsteer package; "
        "reinstall with `pip install .` (it builds the C plugin with CMake)"
    )


def register() -> Path:
    """Loads the plugin library once per process; returns its path."""
    global _loaded
    if _loaded is None:
        path = library_path()
        mujoco.mj_loadPluginLibrary(str(path))
        _loaded = path
    return _loaded
