"""Placing a robot on a terrain: lifted so that it starts clear of the surface."""

from __future__ import annotations

import dataclasses

import numpy as np

from tensim.structure import Structure
from tensim.terrain._kinds import Terrain

_SPACING = 0.01  # m, between surface samples under the robot


def footprint_height(structure: Structure, terrain: Terrain) -> float:
    """The highest terrain point under the robot's footprint [m] (0 where there is none).

    The footprint is the x-y bounding box of the nodes, widened by the largest rod or point
    mass radius.
    """
    geometry = terrain.geometry()
    if not geometry.boxes and geometry.grid is None:  # a plane or nothing: one height
        # everywhere (a 37 m robot's footprint is otherwise millions of samples of it)
        return 0.0 if geometry.plane is None else float(geometry.plane)
    xyz = np.array([n.position for n in structure.nodes], dtype=float)
    radius = max([r.radius for r in structure.rods] + [p.radius for p in
                                                       structure.point_masses], default=0.0)
    low, high = xyz[:, :2].min(axis=0) - radius, xyz[:, :2].max(axis=0) + radius
    axes = [np.linspace(a, b, max(2, int(np.ceil((b - a) / _SPACING)) + 1))
            for a, b in zip(low, high, strict=True)]
    x, y = np.meshgrid(*axes)
    heights = geometry.height(np.append(x.ravel(), xyz[:, 0]),
                              np.append(y.ravel(), xyz[:, 1]))
    top = float(heights.max())
    return top if np.isfinite(top) else 0.0


def place_on_terrain(structure: Structure, terrain: Terrain) -> Structure:
    """``structure`` moved up (or down) by the highest terrain point under its footprint.

    A robot built to stand on z = 0 then starts at its build clearance above the highest
    point of the ground beneath it, never inside it, and drops onto the lower parts. Where
    that height is 0 (flat ground, features ahead of the robot) the structure is returned
    unchanged.
    """
    lift = footprint_height(structure, terrain)
    if lift == 0.0:
        return structure
    nodes = tuple(dataclasses.replace(n, position=(n.position[0], n.position[1],
                                                   n.position[2] + lift))
                  for n in structure.nodes)
    return dataclasses.replace(structure, nodes=nodes)
