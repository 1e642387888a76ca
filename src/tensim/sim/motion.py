"""Rigid motion of a robot's points: node paths from recorded body poses, and the best rigid
fit (Kabsch's, least squares) of a point set's move, with its turn about the vertical and about
a rolling axis.

A tensegrity deforms as it moves, so "how far it turned" is the rotation of the rigid motion
that best takes its points (rod ends) from one sample to the next; summed sample by sample it
measures a turn in place (about the vertical) or rolling (about the horizontal axis z x heading),
while a wobble or a rock back and forth sums to little.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from tensim.sim._timeseries import TimeSeries
from tensim.structure import Structure


def node_bodies(index: Any) -> dict[str, tuple[str, np.ndarray]]:
    """Node name -> (its body's name, its position in the body's frame [m]), for the nodes
    on the robot's rigid bodies (``index``: a compiled model's ``ModelIndex``)."""
    bodies = dict(zip((int(b) for b in index.body), index.bodies, strict=True))
    return {n: (bodies[b], index.node_local[n])
            for n, b in index.node_body.items() if b in bodies}


def node_paths(trajectory: TimeSeries, nodes: dict[str, tuple[str, np.ndarray]]
               ) -> np.ndarray:
    """(T, n, 3) the recorded paths of ``nodes`` (node name -> (its body's name, its position
    in the body's frame [m])), from the bodies' ``pos_*`` and ``quat_*`` channels [m]."""
    out = []
    for body, local in nodes.values():
        quat = np.stack([trajectory[f"quat_{a}/{body}"] for a in "wxyz"], axis=1)
        quat = quat / np.linalg.norm(quat, axis=1, keepdims=True)
        w, x, y, z = quat.T
        rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
        pos = np.stack([trajectory[f"pos_{a}/{body}"] for a in "xyz"], axis=1)
        out.append(pos + np.einsum("ijt,j->ti", rot, np.asarray(local, dtype=float)))
    return np.stack(out, axis=1)


def contact_radii(structure: Structure, nodes: Iterable[str]) -> np.ndarray:
    """(p,) each of ``nodes``' contact radius [m]: the largest radius of the rods of
    ``structure`` ending there (0 for a node on no rod)."""
    radius: dict[str, float] = {}
    for rod in structure.rods:
        for node in rod.nodes:
            radius[node] = max(radius.get(node, 0.0), rod.radius)
    return np.array([radius.get(n, 0.0) for n in nodes])


def fit_rotation(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """(k, 3, 3) the rotation of the best rigid fit (Kabsch's, least squares) that takes the
    (k, p, 3) points ``before`` to ``after``, each set about its centroid."""
    p = before - before.mean(axis=1, keepdims=True)
    q = after - after.mean(axis=1, keepdims=True)
    u, _, vt = np.linalg.svd(np.einsum("kpi,kpj->kij", p, q))
    d = np.sign(np.linalg.det(np.einsum("kij,kjl->kil", u, vt)))  # a rotation, not a mirror
    vt[:, 2] *= d[:, None]
    return np.einsum("kji,klj->kil", vt, u)  # V diag(1, 1, d) U^T: after ~ rot @ before


def yaw_change(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """(k,) rotation about the vertical [rad, counter-clockwise] of the best rigid fit
    (:func:`fit_rotation`) that takes the (k, p, 3) points ``before`` to ``after``: a rigid
    turn gives its angle, and points that circle their centroid while the body they lie on
    does not turn (a wobble, a precessing top) give little, where the points' own angles
    about the centroid would add up their circling."""
    rot = fit_rotation(before, after)
    return np.arctan2(rot[:, 1, 0] - rot[:, 0, 1], rot[:, 0, 0] + rot[:, 1, 1])


def roll_change(before: np.ndarray, after: np.ndarray, heading: np.ndarray) -> np.ndarray:
    """(k,) rotation [rad] about the rolling axis z x ``heading`` ((k, 2) unit, world) of the
    best rigid fit (:func:`fit_rotation`) that takes the (k, p, 3) points ``before`` to
    ``after``: the component along that axis of the fit's rotation vector, positive for a
    robot rolling toward ``heading``; a robot that rocks back and forth sums to nothing."""
    from scipy.spatial.transform import Rotation

    axis = np.zeros((heading.shape[0], 3))
    axis[:, 0], axis[:, 1] = -heading[:, 1], heading[:, 0]
    rotvec = Rotation.from_matrix(fit_rotation(before, after)).as_rotvec()
    return np.einsum("kj,kj->k", rotvec, axis)


def rolled_distance(points: np.ndarray, com_z: np.ndarray, heading: np.ndarray,
                    radii: np.ndarray | float = 0.0) -> tuple[float, float]:
    """How far a robot rolled toward ``heading``: (metres, radians).

    A body that rolls without slipping turns about its contact with the ground, so its centre
    of mass moves horizontally by h dθ toward the heading for a turn dθ about the rolling axis
    z x heading, h its height above the contact. Here dθ is the turn of the best rigid fit of
    the points' move between samples (:func:`roll_change`) and h the centre of mass's height
    above the lowest point of the robot (each point's z less its radius, e.g. a rod's end
    cap), averaged over the interval; the distance rolled is the net turn Σ dθ times the mean
    height while turning, Σ |dθ| h / Σ |dθ|. For rolling on without slipping that is Σ h dθ,
    the distance made along the heading; a crawl or a slide on one face scores about 0
    whatever the distance, and so does any rocking back and forth, also one that pivots
    forward while tall and back while flat; rolling away from the heading scores negative.

    Args:
        points: (T, p, 3) the robot's points (rod ends) [m].
        com_z: (T,) the centre of mass's height [m].
        heading: (2,) unit vector in the ground plane.
        radii: () or (p,) each point's contact radius [m].

    Returns:
        (rolled [m], net turn about z x heading [rad]).
    """
    points = np.asarray(points, dtype=float)
    if points.shape[0] < 2:
        return 0.0, 0.0
    turn = roll_change(points[:-1], points[1:], np.tile(heading, (points.shape[0] - 1, 1)))
    height = np.asarray(com_z, dtype=float) - np.min(points[..., 2] - radii, axis=1)
    size = np.abs(turn)
    total = float(size.sum())
    if total == 0.0:
        return 0.0, 0.0
    lever = float(size @ (0.5 * (height[1:] + height[:-1]))) / total
    return float(turn.sum()) * lever, float(turn.sum())
