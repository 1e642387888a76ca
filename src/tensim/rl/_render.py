"""Offscreen images of environment robots, with the renderer ``tensim render`` uses."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from tensim.model import CompiledModel


class Renders:
    """Draws robots of one compiled model (cables coloured by tension), 480 x 360 px.

    Args:
        compiled: the robot.
        stiffness: (n_cables,) cable stiffness [N/m], for the load-cell tensions.

    Raises:
        tensim.viz._gl.OffscreenUnavailable: no offscreen OpenGL backend works here.
    """

    def __init__(self, compiled: CompiledModel, stiffness: np.ndarray, width: int = 480,
                 height: int = 360):
        from tensim.viz.render import OffscreenRenderer  # OpenGL only when images are asked

        self.compiled, self.stiffness = compiled, stiffness
        self.renderer = OffscreenRenderer(compiled, width, height)

    def image(self, data: mujoco.MjData | Any) -> np.ndarray:
        """(height, width, 3) uint8 image of ``data``."""
        idx = self.compiled.index
        rest = idx.cable_act(data.act)
        length = data.ten_length[idx.tendon]
        tension = np.where(length > rest, self.stiffness * (length - rest), 0.0)
        return self.renderer.render(data, tension, rest, f"t = {data.time:.2f} s")

    def close(self) -> None:
        """Frees the OpenGL context."""
        self.renderer.close()
