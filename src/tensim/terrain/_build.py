"""Adds a terrain to a MuJoCo world: ground plane, boxes and a native height field."""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from tensim.terrain._geometry import Geometry
from tensim.terrain._kinds import Terrain

# Robot geoms have priority 1; a terrain that sets its own contact parameters outranks them.
TERRAIN_PRIORITY = 2
_GROUND_RGBA = [0.85, 0.85, 0.8, 1]
_FEATURE_RGBA = [0.6, 0.55, 0.5, 1]
_FIELD_BASE = 0.2  # m, depth of the height field's solid base below its lowest point


def restitution_dampratio(restitution: float) -> float:
    """Damping ratio of MuJoCo's contact spring that gives this coefficient of restitution
    (the one mapping: the robot's rods and the terrains use it)."""
    if restitution <= 0:
        return 1.0
    log_e = math.log(restitution)
    return -log_e / math.sqrt(math.pi**2 + log_e**2)


def contact_parameters(terrain: Terrain, contact_timeconst: float) -> dict[str, Any]:
    """The geom attributes that set a terrain's robot-contact parameters.

    Without a terrain friction the robot's geoms outrank the terrain, so each rod's own
    friction and restitution hold; with one, the terrain outranks the robot.
    """
    if terrain.friction is None:
        return {"solref": [contact_timeconst, 1.0]}
    return {"priority": TERRAIN_PRIORITY, "friction": [terrain.friction, 0.005, 0.0001],
            "solref": [contact_timeconst, restitution_dampratio(terrain.restitution or 0.0)]}


def add_terrain(spec: mujoco.MjSpec, terrain: Terrain, contact_timeconst: float) -> Geometry:
    """Adds ``terrain``'s shapes to ``spec``'s world body and returns them.

    Names: the plane ``ground``, boxes ``terrain_box_<k>``, the height field (asset and geom)
    ``terrain``.
    """
    geometry = terrain.geometry()
    contact = contact_parameters(terrain, contact_timeconst)
    world = spec.worldbody
    if geometry.plane is not None:
        world.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1],
                       pos=[0, 0, geometry.plane], rgba=_GROUND_RGBA, **contact)
    for k, box in enumerate(geometry.boxes):
        world.add_geom(name=f"terrain_box_{k}", type=mujoco.mjtGeom.mjGEOM_BOX,
                       pos=list(box.center), size=list(box.half_size), quat=box.quat(),
                       rgba=_FEATURE_RGBA, **contact)
    if geometry.grid is not None:
        grid = geometry.grid
        low, high = float(grid.heights.min()), float(grid.heights.max())
        span = max(high - low, 1e-6)  # MuJoCo rescales the samples to [0, 1] of this span
        rows, cols = grid.heights.shape
        field = spec.add_hfield(name="terrain", nrow=rows, ncol=cols,
                                size=[grid.half_x, grid.half_y, span, _FIELD_BASE])
        field.userdata = np.ravel(grid.heights - low).tolist()
        world.add_geom(name="terrain", type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="terrain",
                       pos=[0, 0, low], rgba=_FEATURE_RGBA, **contact)
    return geometry
