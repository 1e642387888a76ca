"""Offscreen OpenGL for MuJoCo's renderer: EGL, then OSMesa (then a hidden GLFW window).

MuJoCo renders through an OpenGL context that the caller makes current. Headless machines
have EGL (GPU or Mesa's software driver) or OSMesa (pure software). Which one works can only
be told by trying, and a failed try leaves the process unable to use the next one (the GL
loader stays bound to the first library it found), so each candidate is tried in a short
child process first and only the first that works is loaded here. ``MUJOCO_GL=egl|osmesa|glfw``
skips the trial and uses that backend alone.
"""

from __future__ import annotations

import functools
import importlib
import os
import subprocess
import sys
from collections.abc import Mapping
from typing import Any

OFFSCREEN = ("egl", "osmesa")
_PROBE = """
import mujoco
from mujoco.{backend} import GLContext
context = GLContext(16, 16)
context.make_current()
mujoco.MjrContext(mujoco.MjModel.from_xml_string("<mujoco/>"), 100).free()
context.free()
"""
_PROBE_TIMEOUT_S = 60.0
_INSTALL_HINT = ("install an offscreen OpenGL backend, e.g. on Debian/Ubuntu `apt-get install "
                 "libegl1 libegl-mesa0 libgl1-mesa-dri` (EGL) or `apt-get install libosmesa6` "
                 "(OSMesa), or set MUJOCO_GL to one that works")


class OffscreenUnavailable(RuntimeError):
    """No OpenGL backend for offscreen rendering works on this machine."""


def has_display(env: Mapping[str, str] = os.environ) -> bool:
    """Whether a window can be opened: always on Windows and macOS, else an X or Wayland display."""
    if sys.platform in ("win32", "darwin"):
        return True
    return bool(env.get("DISPLAY") or env.get("WAYLAND_DISPLAY"))


def backend_order(env: Mapping[str, str] = os.environ) -> tuple[str, ...]:
    """The backends to try, in order.

    ``MUJOCO_GL`` naming a backend (egl, osmesa, glfw) gives that one alone; otherwise EGL,
    then OSMesa, then a hidden GLFW window where a display exists.

    Raises:
        OffscreenUnavailable: MUJOCO_GL names something else.
    """
    requested = env.get("MUJOCO_GL", "").strip().lower()
    if requested in (*OFFSCREEN, "glfw"):
        return (requested,)
    if requested not in ("", "enable", "enabled", "on", "true", "1"):
        raise OffscreenUnavailable(f"MUJOCO_GL={requested!r} is not an OpenGL backend that "
                                   "offscreen rendering can use (egl, osmesa or glfw)")
    return (*OFFSCREEN, "glfw") if has_display(env) else OFFSCREEN


def probe(backend: str, timeout: float = _PROBE_TIMEOUT_S) -> str | None:
    """Tries ``backend`` in a child process; None if it works, else the reason it failed."""
    env = {**os.environ, "MUJOCO_GL": backend}
    env.pop("PYOPENGL_PLATFORM", None)
    try:
        done = subprocess.run([sys.executable, "-c", _PROBE.format(backend=backend)], env=env,
                              capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return f"no answer within {timeout:g} s"
    if done.returncode == 0:
        return None
    lines = [line for line in done.stderr.strip().splitlines() if line.strip()]
    return lines[-1] if lines else f"exit status {done.returncode}"


@functools.cache
def select_backend() -> str:
    """The first backend of :func:`backend_order` that works here (decided once per process).

    Raises:
        OffscreenUnavailable: none works; the message gives each one's reason and the fix.
    """
    order = backend_order()
    if len(order) == 1:  # chosen by MUJOCO_GL: no trial, a failure is reported when used
        return order[0]
    reasons = []
    for backend in order:
        reason = probe(backend)
        if reason is None:
            return backend
        reasons.append(f"{backend}: {reason}")
    raise OffscreenUnavailable("no offscreen OpenGL backend works here ("
                               + "; ".join(reasons) + f"); {_INSTALL_HINT}")


def gl_context(width: int, height: int) -> tuple[Any, str]:
    """A current OpenGL context of at least ``width`` x ``height`` pixels, and its backend.

    Raises:
        OffscreenUnavailable: no backend works, or this process already committed PyOpenGL to
            another platform.
    """
    backend = select_backend()
    platform = os.environ.get("PYOPENGL_PLATFORM")
    if backend in OFFSCREEN and platform and platform != backend:
        raise OffscreenUnavailable(f"PYOPENGL_PLATFORM={platform!r} is set, so this process "
                                   f"cannot use the {backend} backend; unset it")
    try:
        module = importlib.import_module(f"mujoco.{backend}")
        context = module.GLContext(width, height)
        context.make_current()
    except Exception as err:  # the GL stacks raise ImportError, RuntimeError, OSError, ...
        raise OffscreenUnavailable(f"offscreen OpenGL through {backend} failed: {err}; "
                                   f"{_INSTALL_HINT}") from err
    return context, backend
