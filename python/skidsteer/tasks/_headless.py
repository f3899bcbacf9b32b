"""Offscreen OpenGL on a machine without a display: MUJOCO_GL=egl by default.

mujoco and dm_control choose their OpenGL backend from MUJOCO_GL when they are
imported.  Unset, mujoco takes GLFW, which needs an X display: without one
every mujoco.Renderer fails (and a failed GLFW attempt leaves the process
unable to make another context).  default_to_egl() sets MUJOCO_GL=egl when it
is unset and there is no display; call it before importing dm_control.
`import skidsteer` has imported mujoco already, so use_egl_if_headless() also
points mujoco's offscreen renderer at EGL when mujoco picked GLFW for want of
the variable.  An explicit MUJOCO_GL is always respected.
"""

from __future__ import annotations

import os
import sys

_DEFAULTED = False


def _no_display() -> bool:
    return (sys.platform.startswith("linux") and not os.environ.get("DISPLAY")
            and not os.environ.get("WAYLAND_DISPLAY"))


def default_to_egl() -> bool:
    """Sets MUJOCO_GL=egl if it is unset and there is no display; True if it did (ever)."""
    global _DEFAULTED
    if "MUJOCO_GL" not in os.environ and _no_display():
        os.environ["MUJOCO_GL"] = "egl"
        _DEFAULTED = True
    return _DEFAULTED


def use_egl_if_headless() -> None:
    """Makes mujoco.Renderer use EGL if MUJOCO_GL was unset (or defaulted here) and
    mujoco, imported before, chose GLFW without a display to open it on."""
    default_to_egl()
    if not _DEFAULTED:
        return
    from mujoco.rendering.classic import gl_context

    if getattr(gl_context, "_MUJOCO_GL", "egl") in ("", "glfw"):  # mujoco saw no MUJOCO_GL
        from mujoco.egl import GLContext

        gl_context.GLContext = GLContext
