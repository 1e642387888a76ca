"""The solid shapes a terrain is made of, and the height of their top surface.

A terrain is built from at most an infinite ground plane, a set of boxes and one height field.
:meth:`Geometry.height` gives the surface height above any point, computed from the same shapes
that are added to the MuJoCo model (the height field triangulated as MuJoCo does), so tests and
the robot's placement see the surface the simulation sees.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np


@dataclasses.dataclass(frozen=True)
class Box:
    """A solid box, optionally pitched about the y axis.

    Attributes:
        center: (3,) centre [m].
        half_size: (3,) half lengths along the box's own x, y, z [m].
        pitch: rotation about +y that raises the box's +x end [rad].
    """

    center: tuple[float, float, float]
    half_size: tuple[float, float, float]
    pitch: float = 0.0

    def top(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Height of the top face above (x, y) [m]; -inf where the box is not."""
        (cx, cy, cz), (hx, hy, hz) = self.center, self.half_size
        c, s = math.cos(self.pitch), math.sin(self.pitch)
        # top face: center + u (c, 0, s) + hz (-s, 0, c), |u| <= hx
        u = (x - cx + hz * s) / c
        z = cz + u * s + hz * c
        inside = (np.abs(u) <= hx) & (np.abs(y - cy) <= hy)
        return np.where(inside, z, -np.inf)

    def quat(self) -> list[float]:
        """MuJoCo orientation (w, x, y, z) of the box's frame."""
        # a rotation of -pitch about +y turns +x up toward +z
        return [math.cos(self.pitch / 2), 0.0, -math.sin(self.pitch / 2), 0.0]


@dataclasses.dataclass(frozen=True, eq=False)
class Grid:
    """Heights sampled on a regular grid centred at the origin.

    Attributes:
        heights: (n_rows, n_columns) surface heights [m]; row 0 at y = -half_y, column 0 at
            x = -half_x (MuJoCo's height-field layout).
        half_x: half extent along x [m].
        half_y: half extent along y [m].
    """

    heights: np.ndarray
    half_x: float
    half_y: float

    def __post_init__(self) -> None:
        heights = np.array(self.heights, dtype=float)  # a private, read-only copy
        heights.setflags(write=False)
        object.__setattr__(self, "heights", heights)
        if self.heights.ndim != 2 or min(self.heights.shape) < 2:
            raise ValueError(f"a height grid needs at least 2 x 2 samples, got shape "
                             f"{self.heights.shape}")
        if not np.all(np.isfinite(self.heights)):
            raise ValueError("a height grid must hold finite heights")

    def at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Height above (x, y) [m] on MuJoCo's triangulation; -inf outside the grid."""
        rows, cols = self.heights.shape
        u = (np.asarray(x, dtype=float) + self.half_x) / (2 * self.half_x) * (cols - 1)
        v = (np.asarray(y, dtype=float) + self.half_y) / (2 * self.half_y) * (rows - 1)
        inside = (u >= 0) & (u <= cols - 1) & (v >= 0) & (v <= rows - 1)
        c = np.clip(np.floor(u), 0, cols - 2).astype(int)
        r = np.clip(np.floor(v), 0, rows - 2).astype(int)
        fu, fv = np.clip(u - c, 0, 1), np.clip(v - r, 0, 1)
        h = self.heights
        h00, h10, h01, h11 = h[r, c], h[r, c + 1], h[r + 1, c], h[r + 1, c + 1]
        # each cell is split along its (0, 0)-(1, 1) diagonal
        lower = h00 + fu * (h10 - h00) + fv * (h11 - h10)
        upper = h00 + fv * (h01 - h00) + fu * (h11 - h01)
        return np.where(inside, np.where(fu >= fv, lower, upper), -np.inf)


@dataclasses.dataclass(frozen=True, eq=False)
class Geometry:
    """What a terrain is made of.

    Attributes:
        plane: height of an infinite ground plane [m], or None for none.
        boxes: solid boxes.
        grid: a height field, or None.
    """

    plane: float | None = None
    boxes: tuple[Box, ...] = ()
    grid: Grid | None = None

    def height(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Surface height above (x, y) [m]: the highest top of all shapes; -inf over nothing."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        z = np.full(x.shape, -np.inf if self.plane is None else self.plane)
        for box in self.boxes:
            z = np.maximum(z, box.top(x, y))
        if self.grid is not None:
            z = np.maximum(z, self.grid.at(x, y))
        return z
