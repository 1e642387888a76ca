"""Offscreen OpenGL for MuJoCo's renderer: EGL, then OSMesa (then a hidden GLFW window).

MuJoCo renders through an OpenGL context that the caller makes current. Headless machines
have EGL (GPU or Mesa's software driver) or OSMesa (pure software). Which one works can only
be told by trying, and a failed try leaves the process unable to use the next one (the GL
loader stays bound to the first library it found), so each candidate is tried in a short
child process first and only the first that works is loaded here. ``MUJOCO_GL=egl|osmesa|glfw``
skips the trial and uses that backend alone.
"""

from __future__ import annotations

import concurrent.futures
import functools
import importlib
import importlib.util
import multiprocessing
import os
import subprocess
import sys
import threading
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from tensim.viz._child import helper_env

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
    _load_triton_first()
    try:
        module = importlib.import_module(f"mujoco.{backend}")
        context = module.GLContext(width, height)
        context.make_current()
    except Exception as err:  # the GL stacks raise ImportError, RuntimeError, OSError, ...
        raise OffscreenUnavailable(f"offscreen OpenGL through {backend} failed: {err}; "
                                   f"{_INSTALL_HINT}") from err
    return context, backend


def _load_triton_first() -> None:
    """Imports Triton, where it is installed and not yet loaded, before an OpenGL driver.

    Mesa's software drivers and Triton (which PyTorch's CUDA builds bring, and which PyTorch
    imports when it makes its first optimizer) each carry their own LLVM; loaded in the order
    driver first, Triton second, the process crashes (a segmentation fault in Triton's import),
    so rendering and then training an RL policy in one process would die. Triton first is safe.
    Without Triton (PyTorch's CPU builds, or no PyTorch) this costs one lookup."""
    if "triton" in sys.modules or importlib.util.find_spec("triton") is None:
        return
    try:
        importlib.import_module("triton")
    except Exception:  # a broken Triton is PyTorch's business, not the renderer's
        pass


class GLServer:
    """A child process that holds a working offscreen OpenGL backend and paints scenes.

    The child (:mod:`tensim.viz._glserver`, run by the script :mod:`tensim.viz._glchild` so
    that it loads numpy and MuJoCo's compiled bindings but not tensim) first makes a context
    of ``backend`` current, which is the trial :func:`select_backend` runs; where that works
    it stays, and :meth:`paint` sends it a :meth:`tensim.viz.render.FrameScene.job`. So a
    run folder's ``frame.png`` costs one child's start, and the command's own process never
    loads the OpenGL driver.

    Raises:
        OffscreenUnavailable: the backend does not work here (the message gives the reason).
    """

    def __init__(self, backend: str, timeout: float = _PROBE_TIMEOUT_S):
        self.backend = backend
        ours, theirs = multiprocessing.Pipe()
        env = helper_env(MUJOCO_GL=backend)
        env.pop("PYOPENGL_PLATFORM", None)
        script = Path(__file__).with_name("_glchild.py")
        try:
            # -P: the script's folder (tensim/viz) is not put on the path
            self._process = subprocess.Popen(
                [sys.executable, "-P", str(script), str(theirs.fileno()), backend],
                pass_fds=(theirs.fileno(),), env=env, stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        except OSError as err:
            ours.close()
            raise OffscreenUnavailable(f"{backend}: no child process ({err})") from err
        finally:
            theirs.close()
        self._conn = ours
        try:
            if not ours.poll(timeout):
                raise OffscreenUnavailable(f"{backend}: no answer within {timeout:g} s")
            reason = ours.recv()
        except (EOFError, OSError):
            reason = self._stderr_line()
        except OffscreenUnavailable:
            self.close()
            raise
        if reason is not None:
            self.close()
            raise OffscreenUnavailable(f"{backend}: {reason}")

    def _stderr_line(self) -> str:
        """The child's last line of error output (it died without an answer)."""
        self._process.kill()
        _, err = self._process.communicate()
        lines = [line for line in err.decode(errors="replace").splitlines() if line.strip()]
        return lines[-1] if lines else f"exit status {self._process.returncode}"

    def paint(self, job: dict[str, Any]) -> np.ndarray:
        """The (height, width, 3) uint8 image of a scene job.

        Raises:
            OffscreenUnavailable: the child failed (its traceback) or died.
        """
        try:
            self._conn.send(job)
            kind, value = self._conn.recv()
        except (EOFError, OSError) as err:
            raise OffscreenUnavailable(f"the {self.backend} drawing process ended ({err}: "
                                       f"{self._stderr_line()})") from err
        if kind != "image":
            raise OffscreenUnavailable(f"offscreen OpenGL through {self.backend} failed:\n"
                                       f"{value}")
        return np.asarray(value)

    def close(self) -> None:
        """Ends the child."""
        try:
            self._conn.send(None)
        except (OSError, ValueError):
            pass
        self._conn.close()
        try:
            self._process.wait(timeout=5.0)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        if self._process.stderr is not None:
            self._process.stderr.close()

    def __enter__(self) -> GLServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def start_server() -> GLServer:
    """A :class:`GLServer` of the first backend of :func:`backend_order` that works here.

    Raises:
        OffscreenUnavailable: none works; the message gives each one's reason and the fix.
    """
    reasons = []
    for backend in backend_order():
        try:
            return GLServer(backend)
        except OffscreenUnavailable as err:
            reasons.append(str(err))
    raise OffscreenUnavailable("no offscreen OpenGL backend works here ("
                               + "; ".join(reasons) + f"); {_INSTALL_HINT}")


_prepared: concurrent.futures.Future[GLServer] | None = None
_prepared_lock = threading.Lock()


def prepare_server() -> None:
    """Starts :func:`start_server` in a background thread, for :func:`take_server` to
    collect (the child starts and tries the backends while the caller goes on)."""
    global _prepared
    with _prepared_lock:
        if _prepared is not None:
            return
        future: concurrent.futures.Future[GLServer] = concurrent.futures.Future()

        def start() -> None:
            try:
                future.set_result(start_server())
            except BaseException as err:  # handed to take_server
                future.set_exception(err)

        threading.Thread(target=start, name="tensim-gl-server", daemon=True).start()
        _prepared = future


def take_server() -> GLServer:
    """The server :func:`prepare_server` started (waiting for it), else a new one; the caller
    closes it.

    Raises:
        OffscreenUnavailable: no backend works here.
    """
    global _prepared
    with _prepared_lock:
        future, _prepared = _prepared, None
    return future.result() if future is not None else start_server()
