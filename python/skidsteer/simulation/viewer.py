"""MuJoCo's interactive viewer with the tire plugin loaded.

``python -m skidsteer.simulation.viewer --mjcf models/husky_a200/scene.xml`` is
``python -m mujoco.viewer --mjcf ...`` with the plugin loaded first: MuJoCo's module
has no option to load a plugin library, and loads only its own bundled plugins.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import mujoco
import mujoco.viewer

from skidsteer.robot import Setup, load_model
from skidsteer.robot.plugin import register
from skidsteer.simulation.run import settle


def launch(setup: Setup) -> None:
    """Opens the setup's model (a robot's build, or an MJCF file), settled on its tires."""
    m = load_model(setup)
    d = mujoco.MjData(m)
    settle(m, d, 1.0)
    mujoco.viewer.launch(m, d)


def main(argv: list[str] | None = None) -> int:
    """Opens an MJCF file as MuJoCo's viewer does (unsettled, as the file has it); without
    --mjcf, an empty viewer that takes a file by drag and drop."""
    parser = argparse.ArgumentParser(
        prog="python -m skidsteer.simulation.viewer",
        description="python -m mujoco.viewer with the skidsteer.tire plugin loaded")
    parser.add_argument("--mjcf", help="path to an MJCF file, e.g. models/husky_a200/scene.xml")
    args = parser.parse_args(argv)
    register()  # what this adds to mujoco.viewer (a no-op: importing skidsteer did it)
    if args.mjcf is None:
        mujoco.viewer.launch()
        return 0
    path = Path(args.mjcf).expanduser()
    if not path.is_file():
        print(f"{parser.prog}: error: --mjcf {args.mjcf}: no such file", file=sys.stderr)
        return 2
    mujoco.viewer.launch_from_path(str(path))
    return 0


if __name__ == "__main__":
    sys.exit(main())
