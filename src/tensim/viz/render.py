"""Offscreen rendering of a robot's state to RGB images (no window), cables coloured by tension.

The OpenGL backend (EGL, then OSMesa) is chosen by :mod:`tensim.viz._gl`; the camera follows
the robot's centre of mass (MuJoCo's tracking camera on the world body's subtree). A legend
(tension colour bar) and the time are drawn into each image.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import mujoco
import numpy as np

from tensim.model import CompiledModel
from tensim.viz import _gl, _glserver
from tensim.viz._scene import grid_spacing, ground_grid, ground_height, robot_size
from tensim.viz.cables import CableArtist, TensionColors, hide_model_tendons

_MAX_GEOM = 2000
_BAR = (160, 10)  # colour bar size [px]
# camera mode -> its (azimuth, elevation) [deg]
CAMERA_MODES = {"track": (135.0, -25.0), "top": (90.0, -89.0), "side": (90.0, -8.0),
                "fixed": (135.0, -25.0)}


@dataclasses.dataclass(frozen=True)
class CameraView:
    """Where the camera looks from, relative to the robot's centre of mass.

    Attributes:
        mode: ``track`` (follows the robot), ``top`` (follows it, looking down), ``side``
            (follows it, from the side), ``fixed`` (aimed at the start, never moves).
        azimuth, elevation: viewing angles [deg] (None: the mode's own).
        distance: from the point looked at [m] (None: 1.3 x the robot's size, at least 0.5 m).
    """

    mode: str = "track"
    azimuth: float | None = None
    elevation: float | None = None
    distance: float | None = None

    def __post_init__(self) -> None:
        if self.mode not in CAMERA_MODES:
            raise ValueError(f"camera must be one of {', '.join(CAMERA_MODES)}, got {self.mode!r}")
        if self.distance is not None and not self.distance > 0:
            raise ValueError(f"camera distance must be > 0 m, got {self.distance}")

    def camera(self, data: mujoco.MjData, size: float) -> mujoco.MjvCamera:
        """A MuJoCo camera for this view, aimed at the current centre of mass of ``data``.

        Args:
            data: the state to look at.
            size: the robot's size (:func:`~tensim.viz._scene.robot_size`) [m].
        """
        camera = mujoco.MjvCamera()
        azimuth, elevation = CAMERA_MODES[self.mode]
        camera.azimuth = azimuth if self.azimuth is None else self.azimuth
        camera.elevation = elevation if self.elevation is None else self.elevation
        camera.distance = self.distance or max(1.3 * size, 0.5)
        camera.lookat[:] = data.subtree_com[0]
        if self.mode == "fixed":
            camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        else:  # MuJoCo moves lookat to the tracked subtree's centre of mass every update
            camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
            camera.trackbodyid = 0  # the world body's subtree: the whole robot
        return camera


class FrameScene:
    """The scene of a robot's state, without OpenGL: MuJoCo's geoms, the cables coloured by
    tension, the ground grid, the camera and the legend.

    :class:`OffscreenRenderer` paints it here; :meth:`job` packs it for a process that holds
    an OpenGL context (:class:`tensim.viz._gl.GLServer`).

    Args:
        compiled: the compiled model (not changed, except its offscreen buffer size).
        width, height: image size [px].
        view: the camera.
        colors: tension colour map (default: scaled to the strongest motor).
        shadows: draw shadows and reflections (slow with software OpenGL).
        samples: multisample anti-aliasing samples per pixel (None: the model's, MuJoCo's
            default 4; 0: none, edges a little jagged, for half the painting time and 17 MiB
            less memory with a software OpenGL driver).
    """

    def __init__(self, compiled: CompiledModel, width: int = 640, height: int = 480,
                 view: CameraView | None = None, colors: TensionColors | None = None,
                 shadows: bool = False, samples: int | None = None):
        if samples is not None and samples < 0:
            raise ValueError(f"samples must be 0 or more, got {samples}")
        if width < 16 or height < 16:
            raise ValueError(f"image size must be at least 16 x 16 px, got {width} x {height}")
        model = compiled.model
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        self.model, self.width, self.height, self.shadows = model, width, height, shadows
        self.samples = samples
        self.view = view or CameraView()
        self.artist = CableArtist(compiled, colors)
        self._ground = ground_height(model)  # the grid is drawn on the ground plane, if any
        self._size = robot_size(compiled.structure)
        self._grid = grid_spacing(self._size)
        self.scene = mujoco.MjvScene(model, _MAX_GEOM + self.artist.max_geoms)
        self.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
        self.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = shadows
        self.option = mujoco.MjvOption()
        hide_model_tendons(self.option)
        self.option.sitegroup[:] = 0  # anchor sites lie under the cable drawings
        self._camera: mujoco.MjvCamera | None = None
        self._bar = np.flipud(self.artist.colors.colorbar(*_BAR))

    def camera(self, data: mujoco.MjData) -> mujoco.MjvCamera:
        """The camera, aimed at the robot in ``data`` the first time."""
        if self._camera is None:
            self._camera = self.view.camera(data, self._size)
        return self._camera

    def update(self, data: mujoco.MjData, tension: np.ndarray, rest_length: np.ndarray) -> int:
        """Fills the scene with ``data`` (positions after kinematics), its cables and the grid;
        the number of MuJoCo's own geoms (those before the added ones)."""
        mujoco.mjv_updateScene(self.model, data, self.option, None, self.camera(data),
                               mujoco.mjtCatBit.mjCAT_ALL, self.scene)
        own = self.scene.ngeom
        if self._ground is not None:
            ground_grid(self.scene, data.subtree_com[0], self._grid, self._ground)
        self.artist.draw(self.scene, data, tension, rest_length)
        return own

    def legend(self, label: str = "") -> dict[str, Any]:
        """The legend (:func:`tensim.viz._glserver.paint`): the colour bar, its range, the
        slack-cable line style and ``label`` top left (e.g. the time)."""
        bar_h = _BAR[1]
        left, bottom = 10, 28
        return {"texts": [(f"0 N  cable tension  {self.artist.colors.max_tension:g} N",
                           left / self.width, (bottom + bar_h + 4) / self.height),
                          ("grey dashed: slack", left / self.width, 8 / self.height)],
                "label": label, "bar": self._bar, "bar_at": (left, bottom)}

    def job(self, data: mujoco.MjData, tension: np.ndarray, rest_length: np.ndarray,
            label: str = "") -> dict[str, Any]:
        """The scene of ``data`` as plain data, for :func:`tensim.viz._glserver.paint_job`:
        the model and data, the option and the camera as they were before the update, the
        geoms added after MuJoCo's own, and the scene's size: the geoms it holds (the painting
        process allocates no more than that: 2 MiB less of its peak memory)."""
        camera = _glserver.fields(self.camera(data))
        own = self.update(data, tension, rest_length)
        return {"model": self.model, "data": data, "option": _glserver.fields(self.option),
                "camera": camera, "maxgeom": self.scene.ngeom, "shadows": self.shadows,
                "samples": self.samples,
                "geoms": [_glserver.fields(self.scene.geoms[i])
                          for i in range(own, self.scene.ngeom)],
                "width": self.width, "height": self.height, "legend": self.legend(label)}


class OffscreenRenderer:
    """Renders states of one compiled model to (height, width, 3) uint8 images.

    Args:
        compiled: the compiled model (not changed, except its offscreen buffer size).
        width, height: image size [px] (even numbers suit video encoders).
        view: the camera.
        colors: tension colour map (default: scaled to the strongest motor).
        shadows: draw shadows and reflections (slow with software OpenGL).
        samples: multisample anti-aliasing samples per pixel (:class:`FrameScene`).

    Raises:
        OffscreenUnavailable: no offscreen OpenGL backend works here.
    """

    def __init__(self, compiled: CompiledModel, width: int = 640, height: int = 480,
                 view: CameraView | None = None, colors: TensionColors | None = None,
                 shadows: bool = False, samples: int | None = None):
        self.frame = FrameScene(compiled, width, height, view, colors, shadows, samples)
        self.model, self.width, self.height = self.frame.model, width, height
        self.artist, self.scene = self.frame.artist, self.frame.scene
        self._context, self.backend = _gl.gl_context(width, height)
        self._mjr = _glserver.rendering_context(self.model, shadows, samples)

    def render(self, data: mujoco.MjData, tension: np.ndarray, rest_length: np.ndarray,
               label: str = "") -> np.ndarray:
        """The image of ``data`` (positions after kinematics) with its cables and legend.

        Args:
            data: the state to draw.
            tension: (n_cables,) load-cell tensions [N].
            rest_length: (n_cables,) motor rest lengths [m].
            label: text for the top-left corner (e.g. the time).
        """
        if self._context is None:
            raise RuntimeError("render called after close")
        self._context.make_current()
        self.frame.update(data, tension, rest_length)
        return _glserver.paint(self._mjr, self.scene, self.width, self.height,
                               self.frame.legend(label))

    def close(self) -> None:
        """Frees the OpenGL resources."""
        if self._context is None:
            return
        self._context.make_current()
        self._mjr.free()
        self._context.free()
        self._context = None

    def __enter__(self) -> OffscreenRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
