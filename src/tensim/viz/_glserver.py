"""OpenGL's half of offscreen rendering: a prepared MuJoCo scene painted into an image.

This module imports numpy and MuJoCo only, never the tensim package, so that it can also run
in a small child process (``python -P _glchild.py FD BACKEND``, started by
:class:`tensim.viz._gl.GLServer`, which loads MuJoCo's compiled bindings without the rest of
its package): it makes a context of ``BACKEND`` current (the trial of
that backend), says whether that worked, then paints the scenes it is sent over the socket
``FD`` until the socket closes. A run folder's ``frame.png`` is painted there, so the command's
own process never loads the OpenGL driver (with Mesa's software driver, 60-180 MiB). The
scene itself (MuJoCo's geoms, the cables, the ground grid, the camera) is made by the caller
(:class:`tensim.viz.render.FrameScene`); what crosses the socket is plain data: the model and
its data (MuJoCo pickles them), the option and camera fields, the added geoms and the legend.
"""

from __future__ import annotations

import importlib
import traceback
from typing import Any

import mujoco
import numpy as np

# a failed backend leaves nothing behind but this message
_EMPTY = "<mujoco/>"


def fields(obj: Any) -> dict[str, Any]:
    """The public data fields of a MuJoCo struct (``MjvGeom``, ``MjvOption``, ``MjvCamera``)
    as plain values (arrays copied)."""
    values = {}
    for name in _field_names(obj):
        value = getattr(obj, name)
        values[name] = value.copy() if isinstance(value, np.ndarray) else value
    return values


# struct type -> its public data fields, in ``dir`` order (``dir`` on each of a frame's
# thousand geoms was most of packing the scene: it is asked once per type)
_FIELDS: dict[type, tuple[str, ...]] = {}


def _field_names(obj: Any) -> tuple[str, ...]:
    """The public data fields of ``obj``'s struct type: its attributes that are not methods."""
    names = _FIELDS.get(type(obj))
    if names is None:
        names = _FIELDS[type(obj)] = tuple(
            name for name in dir(obj)
            if not name.startswith("_") and not callable(getattr(obj, name)))
    return names


def set_fields(obj: Any, values: dict[str, Any]) -> None:
    """Sets the fields :func:`fields` read."""
    for name, value in values.items():
        if isinstance(value, np.ndarray):
            getattr(obj, name)[...] = value
        else:  # not read first: a geom not yet used holds no valid text
            setattr(obj, name, value)


def context(backend: str, width: int, height: int) -> Any:
    """A current OpenGL context of ``backend`` (``egl``, ``osmesa``, ``glfw``)."""
    module = importlib.import_module(f"mujoco.{backend}")
    ctx = module.GLContext(width, height)
    ctx.make_current()
    return ctx


def trial(backend: str, width: int = 640, height: int = 480) -> Any:
    """A current context of ``backend`` in which MuJoCo's rendering context can be made (the
    trial of a backend; raises if it fails). The caller frees it."""
    ctx = context(backend, width, height)
    try:
        model = mujoco.MjModel.from_xml_string(_EMPTY)
        # no 4096 x 4096 shadow map, no multisampled 640 x 480 buffer for a trial
        model.vis.quality.shadowsize = model.vis.quality.offsamples = 0
        model.vis.global_.offwidth = model.vis.global_.offheight = 16
        mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100).free()
    except BaseException:
        ctx.free()
        raise
    return ctx


def rendering_context(model: mujoco.MjModel, shadows: bool, samples: int | None = None
                      ) -> mujoco.MjrContext:
    """MuJoCo's rendering context for ``model`` in the current OpenGL context, drawing into
    its offscreen buffer; without ``shadows``, with no shadow map (MuJoCo's default is
    4096 x 4096: 64 MiB that a software driver keeps in memory); ``samples``: the offscreen
    buffer's multisample anti-aliasing samples per pixel (None: the model's, MuJoCo's default
    4; 0: none, which with Mesa's software driver saves 17 MiB and half the painting time)."""
    quality = model.vis.quality
    size, offsamples = quality.shadowsize, quality.offsamples
    if not shadows:
        quality.shadowsize = 0
    if samples is not None:
        quality.offsamples = samples
    try:
        mjr = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100)
    finally:
        quality.shadowsize, quality.offsamples = size, offsamples
    mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, mjr)
    return mjr


def paint(mjr: mujoco.MjrContext, scene: mujoco.MjvScene, width: int, height: int,
          legend: dict[str, Any]) -> np.ndarray:
    """Renders ``scene`` into the offscreen buffer of ``mjr`` with its legend; the
    (height, width, 3) uint8 image, top row first.

    ``legend``: ``texts`` (text, x, y as fractions of the image), ``label`` (top left, may be
    empty), ``bar`` (h, w, 3) uint8 pixels, bottom row first, and its ``bar_at`` (left,
    bottom) [px].
    """
    rect = mujoco.MjrRect(0, 0, width, height)
    mujoco.mjr_render(rect, scene, mjr)
    font = mujoco.mjtFont.mjFONT_NORMAL
    for text, x, y in legend["texts"]:
        mujoco.mjr_text(font, text, mjr, x, y, 0.1, 0.1, 0.1)
    if legend["label"]:
        mujoco.mjr_overlay(font, mujoco.mjtGridPos.mjGRID_TOPLEFT, rect, legend["label"], "",
                           mjr)
    # the bar goes after the text: drawn straight after mjr_render it did not show
    bar = np.ascontiguousarray(legend["bar"])
    left, bottom = legend["bar_at"]
    mujoco.mjr_drawPixels(bar.ravel(), None, mujoco.MjrRect(left, bottom, bar.shape[1],
                                                            bar.shape[0]), mjr)
    image = np.empty((height, width, 3), dtype=np.uint8)
    mujoco.mjr_readPixels(image, None, rect, mjr)
    return np.flipud(image)


def paint_job(job: dict[str, Any]) -> np.ndarray:
    """Paints a scene sent by :meth:`tensim.viz.render.FrameScene.job`, in the current
    OpenGL context (MuJoCo draws into its own offscreen buffer, whatever the context's size).

    MuJoCo's own geoms, lights and camera come from ``mjv_updateScene`` on the job's model and
    data (as where the job was made); the geoms added there (cables, grid) are appended.
    """
    model, data = job["model"], job["data"]
    mjr = rendering_context(model, job["shadows"], job["samples"])
    try:
        scene = mujoco.MjvScene(model, job["maxgeom"])
        scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = job["shadows"]
        scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = job["shadows"]
        option, camera = mujoco.MjvOption(), mujoco.MjvCamera()
        set_fields(option, job["option"])
        set_fields(camera, job["camera"])
        mujoco.mjv_updateScene(model, data, option, None, camera, mujoco.mjtCatBit.mjCAT_ALL,
                               scene)
        for values in job["geoms"]:
            if scene.ngeom >= scene.maxgeom:
                break
            set_fields(scene.geoms[scene.ngeom], values)
            scene.ngeom += 1
        return paint(mjr, scene, job["width"], job["height"], job["legend"])
    finally:
        mjr.free()


def serve(fd: int, backend: str) -> None:
    """The child: tries ``backend``, answers None (it works) or the reason it does not, then
    paints each job it receives, answering ``("image", pixels)`` or ``("error", traceback)``,
    until the socket closes or sends None."""
    from multiprocessing.connection import Connection

    conn = Connection(fd)
    try:
        ctx = trial(backend)
    except Exception as err:  # the GL stacks raise ImportError, RuntimeError, OSError, ...
        conn.send(f"{type(err).__name__}: {err}")
        return
    conn.send(None)
    try:
        while (job := conn.recv()) is not None:
            try:
                answer: tuple[str, Any] = ("image", paint_job(job))
            except Exception:
                answer = ("error", traceback.format_exc())
            conn.send(answer)
    except (EOFError, OSError):
        pass  # the parent has gone
    ctx.free()
