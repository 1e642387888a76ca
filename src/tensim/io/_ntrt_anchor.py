"""Where the original toolkit anchors a cable end on a rigid body (``getConnectionPoint``).

A cable end at a node is attached to the rigid body there (the rod, box or sphere whose centre
is nearest the node when several meet). On a rod it moves from the node perpendicular to the
rod's axis, toward the cable's other node, by the rod's radius (a box: by its width), turned
about the axis by the cable's ``rotation``; on a sphere it moves toward the other node by the
radius. tensim anchors a cable on its own line, so the importer uses these points only for the
cable's length: that is what sets the rest length for a given pretension.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation


@dataclasses.dataclass(frozen=True)
class Rigid:
    """A rigid body a cable may end on.

    Attributes:
        ends: (2, 3) a rod's or box's two end nodes [m]; a sphere's centre twice.
        offset: how far the toolkit moves an anchor from the node [m] (rod radius, box
            width, sphere radius).
        sphere: a sphere (anchors move toward the other node) rather than a rod or box.
    """

    ends: np.ndarray
    offset: float
    sphere: bool = False


def anchor(node: np.ndarray, toward: np.ndarray, rigids: list[Rigid],
           rotation: float = 0.0) -> np.ndarray:
    """The toolkit's anchor point of a cable end at ``node`` whose other end is ``toward``.

    Args:
        node: (3,) the cable's node [m].
        toward: (3,) its other node [m].
        rigids: the rigid bodies that hold ``node``; empty: the node itself.
        rotation: the cable's ``rotation`` parameter [rad].
    """
    if not rigids:
        return node
    body = min(rigids, key=lambda r: float(np.linalg.norm(r.ends.mean(axis=0) - node)))
    if body.sphere:
        return node + body.offset * (toward - node) / np.linalg.norm(toward - node)
    axis = body.ends[1] - body.ends[0]
    axis = axis / np.linalg.norm(axis)
    away = (node - toward) / np.linalg.norm(node - toward)
    turn_axis = np.cross(axis, away)
    if np.linalg.norm(turn_axis) == 0.0:  # the cable runs along the rod: any perpendicular
        turn_axis = np.array([axis[1] - axis[2], -axis[0], axis[0]])
    turn_axis = turn_axis / np.linalg.norm(turn_axis)
    side = Rotation.from_rotvec(-np.pi / 2 * turn_axis).apply(axis)
    side = Rotation.from_rotvec(rotation * axis).apply(side)
    return node + body.offset * side / np.linalg.norm(side)
