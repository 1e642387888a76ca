"""Offscreen images of environment robots, with the renderer ``tensim render`` uses."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from tensim.model import CompiledModel
from tensim.sim import MODE_PD, load_cell_reading


class Renders:
    """Draws robots of one compiled model (cables coloured by tension), 480 x 360 px.

    Args:
        compiled: the robot.

    Raises:
        tensim.viz._gl.OffscreenUnavailable: no offscreen OpenGL backend works here.
    """

    def __init__(self, compiled: CompiledModel, width: int = 480, height: int = 360):
        from tensim.viz.render import OffscreenRenderer  # OpenGL only when images are asked

        self.compiled = compiled
        self.renderer = OffscreenRenderer(compiled, width, height)

    def image(self, model: mujoco.MjModel, data: mujoco.MjData | Any) -> np.ndarray:
        """(height, width, 3) uint8 image of ``data``, its cables coloured by the load-cell
        tension with the stiffness of ``model`` (the robot's own, randomised, model)."""
        idx = self.compiled.index
        rest = idx.cable_act(data.act)
        law = self.compiled.law(model)
        tension = load_cell_reading(data.ten_length[idx.tendon], rest, law.stiffness,
                                    law.mode == MODE_PD, data.ctrl[:law.stiffness.size],
                                    law.pd_stiffness, law.max_tension)
        return self.renderer.render(data, tension, rest, f"t = {data.time:.2f} s")

    def close(self) -> None:
        """Frees the OpenGL context."""
        self.renderer.close()
