"""The README's Python example runs as written (from the repository root)."""

from __future__ import annotations

import os
import re

from conftest import REPO


def test_readme_python_example_runs():
    text = (REPO / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "README has no python example"
    cwd = os.getcwd()
    os.chdir(REPO)  # the example loads models/ by relative path, as a reader would
    try:
        namespace: dict = {}
        exec(compile(blocks[0], "README.md", "exec"), namespace)
    finally:
        os.chdir(cwd)
    assert namespace["accel"].shape == (20000, 3)  # 20 s at 1 kHz


def test_readme_tasks_example_runs_an_episode():
    text = (REPO / "README.md").read_text()
    blocks = [b for b in re.findall(r"```python\n(.*?)```", text, flags=re.S)
              if "tasks.load" in b]
    assert blocks, "README has no skidsteer.tasks example"
    namespace: dict = {}
    exec(compile(blocks[0], "README.md", "exec"), namespace)
    step, env = namespace["step"], namespace["env"]
    assert step.last() and env.physics.data.time >= 20.0 - 1e-9  # the thesis's 20 s run
    assert 0.9 <= step.reward <= 1.0  # the soft start turns at about the commanded rate
