"""`skidsteer render`: a video and a still of a task, rendered offscreen with EGL.

As tests/test_rendering.py, rendering runs in a subprocess with MUJOCO_GL=egl
(the backend is fixed when mujoco is imported).  Without a working EGL the
rendering test skips, unless SKIDSTEER_REQUIRE_DISPLAY_TESTS=1 (CI), where it fails.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import imageio_ffmpeg
import mediapy
import pytest

from skidsteer.cli import main
from test_rendering import REQUIRED, not_blank

_EGL_PROBE = textwrap.dedent("""
    import mujoco
    m = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='1'/></worldbody></mujoco>")
    with mujoco.Renderer(m, 16, 16) as renderer:
        renderer.update_scene(mujoco.MjData(m))
        renderer.render()
""")


def _egl_env() -> dict:
    return dict(os.environ, MUJOCO_GL="egl")


def _require_egl() -> None:
    """Skips (fails when required) if this machine cannot render with EGL at all."""
    probe = subprocess.run([sys.executable, "-c", _EGL_PROBE], env=_egl_env(),
                           capture_output=True, text=True, timeout=120)
    if probe.returncode != 0:
        message = f"EGL offscreen rendering is unavailable: {probe.stderr.strip()[-500:]}"
        if REQUIRED:
            pytest.fail(message + " (required: SKIDSTEER_REQUIRE_DISPLAY_TESTS=1)")
        pytest.skip(message)


def test_render_writes_a_readable_video_and_a_still(tmp_path):
    _require_egl()
    out = tmp_path / "clip" / "swivel.mp4"
    # 1 s at 10 fps, 160 x 120: 10 frames, enough to check the file, cheap in CI
    args = ["render", "--task", "swivel_smooth", "--omega", "60", "--out", str(out),
            "--seconds", "1", "--width", "160", "--height", "120", "--fps", "10"]
    script = "import sys; from skidsteer.cli import main; sys.exit(main(sys.argv[1:]))"
    run = subprocess.run([sys.executable, "-c", script, *args], env=_egl_env(),
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    still = out.with_suffix(".png")
    assert run.stdout.split() == [str(out), str(still)]
    mediapy.set_ffmpeg(imageio_ffmpeg.get_ffmpeg_exe())
    video = mediapy.read_video(out)
    assert video.shape == (10, 120, 160, 3)
    assert video.metadata.fps == pytest.approx(10)
    assert not_blank(video[-1])
    image = mediapy.read_image(still)
    assert image.shape[:2] == (120, 160)
    assert not_blank(image)


@pytest.mark.parametrize("args,named", [
    (["--omega", "100"], "argument --omega: invalid value '100'"),
    (["--task", "dance"], "dance"),
    (["--width", "161"], "width"),
    (["--height", "2000"], "argument --height: invalid value '2000'"),
    (["--fps", "500"], "argument --fps: invalid value '500'"),
    (["--seconds", "0"], "argument --seconds: invalid value '0'"),
    (["--out", "clip.gif"], ".mp4"),
])
def test_render_rejects_bad_arguments_with_a_clear_error(tmp_path, capsys, args, named):
    # rejected before any OpenGL context is made: runs in this process.  A value out
    # of its option's range is argparse's (exit 2, its usage line); the rest main's.
    argv = ["render", "--out", str(tmp_path / "x.mp4"), *args]
    try:
        code = main(argv)
    except SystemExit as exit_info:
        code = exit_info.code
    assert code == 2
    err = capsys.readouterr().err
    assert "error:" in err and named in err, err
    assert not list(tmp_path.iterdir())


def test_render_rejects_unknown_floor_through_argparse(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["render", "--floor", "ice"])
    assert exit_info.value.code == 2
    assert "--floor" in capsys.readouterr().err
