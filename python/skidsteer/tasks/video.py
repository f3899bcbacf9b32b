"""Videos of the tasks: a policy run in a skidsteer.tasks environment, rendered
offscreen through mujoco.Renderer from the model's "track" camera (mode
trackcom in models/pioneer3at/parts/platform.xml: it follows the robot's centre of mass,
without turning with it) and written with mediapy, plus a still PNG of the
last frame.

Headless machines: MUJOCO_GL defaults to egl when it is unset and there is no
display (skidsteer._headless).
"""

from __future__ import annotations

from skidsteer.tasks._headless import default_to_egl, use_egl_if_headless

default_to_egl()  # before anything below imports dm_control's rendering

import math  # noqa: E402
import numbers  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Callable  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from skidsteer import tasks  # noqa: E402
from skidsteer.data.files import write_atomically  # noqa: E402
from skidsteer.tasks.pioneer3at import feedforward_action  # noqa: E402

CAMERA = "track"
DEFAULT_SIZE = (640, 360)  # width, height: within the models' 1280 x 720 offscreen buffer
# 25 fps divides the 100 Hz control rate: a frame every 4th action, no jitter
DEFAULT_FPS = 25
DEFAULT_SECONDS = 5.0  # the 0.6 s ramp to 60 deg/s and a good part of a turn


def _check_video_options(seconds, width, height, fps, control_timestep, model) -> None:
    if not (isinstance(seconds, numbers.Real) and math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"seconds={seconds!r} must be > 0")
    for name, value, limit in (("width", width, model.vis.global_.offwidth),
                               ("height", height, model.vis.global_.offheight)):
        if not isinstance(value, numbers.Integral) or not 16 <= value <= limit:
            raise ValueError(f"{name}={value!r} must be an integer in [16, {limit}] pixels "
                             "(the model's offscreen buffer, <visual><global offwidth/offheight>)")
        if value % 2:
            raise ValueError(f"{name}={value} must be even (H.264 video, yuv420p)")
    rate = 1.0 / control_timestep
    if not (isinstance(fps, numbers.Real) and 1 <= fps <= rate + 1e-9):
        raise ValueError(f"fps={fps!r} must lie in [1, {rate:g}] (one frame per action at most)")
    if int(round(seconds * fps)) < 1:
        raise ValueError(f"seconds={seconds!r} at fps={fps!r} gives no frame")


def render_episode(env, policy: Callable, seconds: float, out: str | Path,
                   width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1],
                   fps: float = DEFAULT_FPS, camera: str = CAMERA) -> dict:
    """Runs policy(time_step, env) -> action in env from reset, and renders frame k
    after the action that ends nearest to k / fps, for round(seconds * fps) frames
    (frame 0 is the initial state).  Writes out (.mp4) and the last frame as a PNG
    of the same stem.  Returns {"video", "still", "frames", "width", "height", "fps"}.
    The episode must last at least seconds (its time limit): it is not reset.
    """
    out = Path(out)
    if out.suffix.lower() != ".mp4":
        raise ValueError(f"out={str(out)!r} must be an .mp4 file")
    physics = env.physics
    model, data = physics.model.ptr, physics.data.ptr
    control_dt = env.control_timestep()
    _check_video_options(seconds, width, height, fps, control_dt, model)
    if camera not in [model.camera(i).name for i in range(model.ncam)]:
        raise ValueError(f"camera {camera!r} is not in the model")
    import imageio_ffmpeg
    import mediapy

    use_egl_if_headless()
    nframes = int(round(seconds * fps))
    frames = []
    time_step = env.reset()
    with mujoco.Renderer(model, height, width) as renderer:
        for k in range(nframes):
            while data.time < k / fps - 0.5 * control_dt:
                if time_step.last():
                    raise ValueError(f"the episode ended at {data.time:.3f} s, before the "
                                     f"video's {seconds:g} s: raise its time_limit")
                time_step = env.step(policy(time_step, env))
            renderer.update_scene(data, camera=camera)
            frames.append(renderer.render().copy())
    out.parent.mkdir(parents=True, exist_ok=True)
    still = out.with_suffix(".png")
    mediapy.set_ffmpeg(imageio_ffmpeg.get_ffmpeg_exe())
    write_atomically(out, lambda tmp: mediapy.write_video(tmp, np.stack(frames), fps=fps),
                     keep_suffix=True)
    write_atomically(still, lambda tmp: mediapy.write_image(tmp, frames[-1]))
    return {"video": out, "still": still, "frames": nframes, "width": width,
            "height": height, "fps": fps}


def render_swivel(task: str = "swivel", omega_deg_s: float = 60.0,
                  seconds: float = DEFAULT_SECONDS, out: str | Path = "swivel.mp4",
                  width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1],
                  fps: float = DEFAULT_FPS, floor: str = "concrete", build: str = "extended",
                  seed: int = 0) -> dict:
    """The thesis's feed-forward swivel (feedforward_action, ramped in at the
    firmware's 100 deg/s^2) in task `task` of the pioneer3at domain, rendered;
    see render_episode.  Bad options raise ValueError naming them."""
    if not (isinstance(seconds, numbers.Real) and math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"seconds={seconds!r} must be > 0")
    env = tasks.load("pioneer3at", task, task_kwargs=dict(
        omega_deg_s=omega_deg_s, floor=floor, build=build, time_limit=seconds, random=seed))

    def policy(time_step, env):
        return feedforward_action(env.physics, env.task.omega_deg_s)

    result = render_episode(env, policy, seconds, out, width, height, fps)
    result.update(task=task, omega_deg_s=omega_deg_s, floor=floor, build=build)
    return result
