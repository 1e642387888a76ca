"""Extra drawings added to a MuJoCo scene: line pieces and a ground grid."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from tensim.structure import Structure

_IDENTITY = np.eye(3).ravel()
GRID_RGBA = np.array([0.45, 0.45, 0.42, 1.0], dtype=np.float32)


def add_connector(scene: mujoco.MjvScene, kind: mujoco.mjtGeom, width: float,
                  start: np.ndarray, end: np.ndarray, rgba: np.ndarray) -> bool:
    """Appends a capsule or line from ``start`` to ``end`` [m]; False if the scene is full.

    ``width`` is a radius [m] for a capsule and a thickness [px] for a line.
    """
    if scene.ngeom >= scene.maxgeom:
        return False  # a full scene drops the rest, as MuJoCo itself does
    geom = scene.geoms[scene.ngeom]
    mujoco.mjv_initGeom(geom, kind, np.zeros(3), np.zeros(3), _IDENTITY, rgba)
    mujoco.mjv_connector(geom, kind, width, start, end)
    scene.ngeom += 1
    return True


def robot_size(structure: Structure) -> float:
    """Diagonal of the box around the structure's nodes [m] (the terrain not included)."""
    positions = np.array([structure.position(n.name) for n in structure.nodes])
    return float(np.linalg.norm(np.ptp(positions, axis=0))) if len(positions) else 1.0


def grid_spacing(extent: float) -> float:
    """A round grid spacing (1, 2 or 5 x a power of ten) of about a quarter of ``extent`` [m]."""
    raw = max(extent, 1e-6) / 4
    power = 10.0 ** math.floor(math.log10(raw))
    return min((s * power for s in (1, 2, 5, 10)), key=lambda s: abs(math.log(s / raw)))


def ground_height(model: mujoco.MjModel) -> float | None:
    """Height of the model's ground plane (the geom named ``ground``) [m]; None without one."""
    ground = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "ground")
    return float(model.geom_pos[ground, 2]) if ground >= 0 else None


def ground_grid(scene: mujoco.MjvScene, center: np.ndarray, spacing: float, height: float = 0.0,
                lines: int = 16) -> None:
    """Grid lines on the ground plane around ``center``, fixed to the world so motion shows.

    Args:
        scene: the scene to add to.
        center: (3,) point the grid is centred near [m].
        spacing: distance between lines [m].
        height: the ground plane's height [m].
        lines: lines in each direction.
    """
    half = spacing * lines / 2
    x0, y0 = (np.round(np.asarray(center[:2]) / spacing) * spacing).tolist()
    z = height + 2e-3  # 2 mm above the plane, so the lines are not lost in it at grazing angles
    for k in range(lines + 1):
        offset = -half + k * spacing
        add_connector(scene, mujoco.mjtGeom.mjGEOM_LINE, 1.0, np.array([x0 + offset, y0 - half, z]),
                      np.array([x0 + offset, y0 + half, z]), GRID_RGBA)
        add_connector(scene, mujoco.mjtGeom.mjGEOM_LINE, 1.0, np.array([x0 - half, y0 + offset, z]),
                      np.array([x0 + half, y0 + offset, z]), GRID_RGBA)
