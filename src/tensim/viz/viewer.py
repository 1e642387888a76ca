"""Real-time viewer: MuJoCo's own viewer in passive mode, watching a loop that tensim owns.

The simulation (:class:`tensim.sim.Simulation`, cables and controller included) steps at its
fixed physics step; :class:`~tensim.viz.pacing.Pacer` keeps it in step with the wall clock and
the window is redrawn at 60 Hz. The window shows a copy of the simulation's ``MjData``, so a
reset simply starts a fresh simulation. Cables are drawn by
:class:`~tensim.viz.cables.CableArtist` into the viewer's user scene (coloured by tension, slack
ones sagging); a mouse push (ctrl + right drag on a body, MuJoCo's perturbation) is copied back
into the simulation as an external force on that body.

Keys: space pauses, the right arrow steps once while paused, backspace resets, enter toggles
faster than real time.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Sequence
from typing import Any, Protocol

import mujoco
import numpy as np

from tensim.model import CompiledModel
from tensim.sim import Controller, NodeLoad, Simulation
from tensim.viz import _gl
from tensim.viz._scene import grid_spacing, ground_grid, ground_height, robot_size
from tensim.viz.cables import CableArtist, TensionColors, hide_model_tendons
from tensim.viz.pacing import KEY_HELP, Pacer, ViewerControls
from tensim.viz.render import CameraView

_BAR = (200, 12)  # legend colour bar [px]


class DisplayUnavailable(RuntimeError):
    """No screen to open a window on."""


class Window(Protocol):
    """What the loop needs of a viewer window (MuJoCo's passive viewer handle has it)."""

    user_scn: mujoco.MjvScene

    def lock(self) -> Any: ...
    def sync(self) -> None: ...
    def is_running(self) -> bool: ...
    def set_texts(self, texts: list[tuple[Any, Any, str, str]]) -> None: ...


class ViewerSession:
    """A simulation and what the window shows of it, one :meth:`frame` at a time.

    Args:
        compiled: the compiled model.
        controller: sets up the cable drive (again at every reset).
        loads: external node forces.
        colors: the tension colour map (default: scaled to the strongest motor).
        pacer: the real-time clock (default: 60 Hz drawing at the model's physics step).
    """

    def __init__(self, compiled: CompiledModel, *, controller: Controller | None = None,
                 loads: Sequence[NodeLoad] = (), colors: TensionColors | None = None,
                 pacer: Pacer | None = None):
        # the model with the loads' force inputs, so the window's data matches the simulation's
        compiled = compiled.with_load_nodes(tuple(ld.node for ld in loads))
        self.compiled, self.controller, self.loads = compiled, controller, tuple(loads)
        self.model = compiled.model
        self.artist = CableArtist(compiled, colors)
        self.controls = ViewerControls()
        self.pacer = pacer or Pacer(float(self.model.opt.timestep))
        self.data = mujoco.MjData(self.model)  # what the window shows
        self._ground = ground_height(self.model)  # the grid is drawn on the ground plane, if any
        self.size = robot_size(compiled.structure)
        self._grid = grid_spacing(self.size)
        self.sim = self._start()

    def _start(self) -> Simulation:
        sim = Simulation(self.compiled, controller=self.controller, loads=self.loads)
        mujoco.mj_copyData(self.data, self.model, sim.data)
        return sim

    def reset(self) -> None:
        """Starts again from the build pose with a fresh simulation."""
        self.sim.close()
        self.sim = self._start()

    def close(self) -> None:
        """Closes the simulation."""
        self.sim.close()

    def frame(self, window: Window) -> int:
        """Steps this frame's share, redraws and syncs the window; returns the steps taken."""
        if self.controls.take_reset():
            self.reset()
        steps = self.pacer.advance(self.controls, self.sim.step)
        drive = self.sim.drive
        with window.lock():
            mujoco.mj_copyData(self.data, self.model, self.sim.data)
            scene = window.user_scn
            scene.ngeom = 0
            if self._ground is not None:
                ground_grid(scene, self.data.subtree_com[0], self._grid, self._ground)
            self.artist.draw(scene, self.data, drive.tension, drive.rest)
        window.set_texts(self.texts())
        window.sync()  # the viewer writes the mouse push (or zeros) into self.data.xfrc_applied
        # the push acts until the next frame (scheduled node loads are ctrl inputs, apart)
        self.sim.data.xfrc_applied[:] = self.data.xfrc_applied
        return steps

    def texts(self) -> list[tuple[Any, Any, str, str]]:
        """The overlay: time and speed, the legend, the keys."""
        c, pacer = self.controls, self.pacer
        mode = "paused" if c.paused else ("fast" if c.fast else "real time")
        com = self.data.subtree_com[0]
        status = (f"t = {self.sim.time:8.3f} s\n{pacer.speed:5.2f}x real time ({mode})\n"
                  f"max tension {self.sim.drive.tension.max(initial=0.0):6.2f} N\n"
                  f"centre of mass x, y = {com[0]:+.3f}, {com[1]:+.3f} m")
        font = mujoco.mjtFontScale.mjFONTSCALE_150
        grid = mujoco.mjtGridPos
        return [(font, grid.mjGRID_TOPLEFT, status, ""),
                (font, grid.mjGRID_BOTTOMLEFT, self.artist.colors.legend(), ""),
                (font, grid.mjGRID_TOPRIGHT, KEY_HELP.replace("   ", "\n"), "")]

    def run(self, window: Window) -> None:
        """Frames until the window closes."""
        while window.is_running():
            self.frame(window)
            time.sleep(self.pacer.wait())


def check_display() -> None:
    """Raises :class:`DisplayUnavailable`, pointing to ``tensim render``, if no window can open.

    A child process tries GLFW first: a failed start inside MuJoCo's viewer thread would hang.
    """
    hint = ("the viewer needs a screen; on a machine without one, `tensim render MODEL --out "
            "video.mp4` writes the same view as a video")
    if not _gl.has_display():
        raise DisplayUnavailable(f"no display found (DISPLAY and WAYLAND_DISPLAY are unset): "
                                 f"{hint}")
    probe = "import glfw, sys; sys.exit(0 if glfw.init() else 1)"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, timeout=60,
                          check=False)
    if done.returncode != 0:
        raise DisplayUnavailable(f"cannot open a window on the display (GLFW failed to start): "
                                 f"{hint}")


def view(compiled: CompiledModel, *, controller: Controller | None = None,
         loads: Sequence[NodeLoad] = (), colors: TensionColors | None = None,
         camera: CameraView | None = None) -> None:
    """Opens the viewer on a fresh simulation and returns when the window is closed.

    Raises:
        DisplayUnavailable: no screen here.
    """
    import mujoco.viewer

    check_display()
    session = ViewerSession(compiled, controller=controller, loads=loads, colors=colors)
    try:
        with mujoco.viewer.launch_passive(session.model, session.data, show_left_ui=False,
                                          show_right_ui=False,
                                          key_callback=session.controls.on_key) as window:
            with window.lock():
                hide_model_tendons(window.opt)
                window.cam.type, window.cam.trackbodyid = mujoco.mjtCamera.mjCAMERA_TRACKING, 0
                fresh = (camera or CameraView()).camera(session.data, session.size)
                window.cam.azimuth, window.cam.elevation = fresh.azimuth, fresh.elevation
                window.cam.distance = fresh.distance
            _legend_image(window, session.artist.colors)
            session.run(window)
    finally:
        session.close()


def _legend_image(window: Any, colors: TensionColors) -> None:
    """The colour bar, above the legend text at the bottom left of the 3D view."""
    viewport = window.viewport
    if viewport is None:
        return
    width, height = _BAR
    rect = mujoco.MjrRect(viewport.left + 10, viewport.bottom + 40, width, height)
    window.set_images((rect, np.ascontiguousarray(colors.colorbar(width, height))))
