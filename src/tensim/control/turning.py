"""Turning in place: rolling the robot's hull around its vertices, planned on the rigid hull.

A convex polyhedron rolled over the faces around one of its vertices comes back to its first
face turned about the vertical by that vertex's angle defect (2 pi less the faces' angles
there): 60 degrees at each vertex of a symmetric six-bar's hull, 120 at a 3-bar prism's. Any
closed walk over the faces turns it by the defects it encloses. So the robot can turn in place
by rolling: :func:`plan_turn` searches the walks of up to :data:`DEPTH` tips from the face it
stands on back to the face it started on, on the hull taken as rigid, and keeps the one whose
yaw comes nearest the target with its centre of mass nearest the start.

The hull's state on the ground is a :class:`Placement`: the face it stands on and a planar
rigid motion (yaw, offset). A tip over an edge keeps the edge's two nodes where they lie on the
ground and lays the neighbouring face down (:func:`tip`), so every walk is planar arithmetic.
The yaw is a fixed body frame's: that of the robot's nodes at the start (:func:`place` fits a
placement to where the nodes are); standing on the first face again, the robot's pose differs
from its start by a rotation about the vertical, and the yaw is that rotation's angle.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

from tensim.control.rolling import FACE_TOLERANCE

DEPTH = 10  # tips a walk may take: twice around a six-bar's hull vertex (five faces meet there)
RADIUS = 0.35  # body lengths from the start within which the centre of mass moves freely
WEIGHT = 4.0  # rad of yaw error that one body length beyond RADIUS costs as much as
TIP_COST = 0.1  # rad per tip: each real tip may slip or roll on, so the shorter walk


@dataclasses.dataclass(frozen=True)
class RigidHull:
    """The convex hull of the robot's nodes as a rigid body, in the frame of its start pose.

    Attributes:
        names: the nodes, in the order of ``points``.
        points: (n, 3) node positions at the start [m].
        com: (3,) the centre of mass at the start [m].
        faces: each face's node indices (those within :data:`FACE_TOLERANCE` of its plane).
        normals: (m, 3) each face's unit outward normal.
        down: (m, 3, 3) for each face, a rotation that turns its outward normal straight down.
        edges: for each face, its support polygon's edges as (node a, node b, face across).
    """

    names: tuple[str, ...]
    points: np.ndarray
    com: np.ndarray
    faces: tuple[tuple[int, ...], ...]
    normals: np.ndarray
    down: np.ndarray
    edges: tuple[tuple[tuple[int, int, int], ...], ...]


@dataclasses.dataclass(frozen=True)
class Placement:
    """The rigid hull standing on a face: a body point x lies at yaw (down[face] x) + offset.

    Attributes:
        face: index of the face on the ground.
        yaw: rotation about the vertical [rad].
        offset: (2,) horizontal offset [m].
    """

    face: int
    yaw: float
    offset: np.ndarray


@dataclasses.dataclass(frozen=True)
class TurnPlan:
    """The best walk back to the first face, and where it ends.

    Attributes:
        walk: its tips, each as (node a, node b, the face it lands on), a and b the edge's
            nodes (indices into :attr:`RigidHull.names`).
        yaw: the yaw it ends with, from the start [rad].
        cost: its :func:`cost` [rad].
    """

    walk: tuple[tuple[int, int, int], ...]
    yaw: float
    cost: float


def rigid_hull(positions: dict[str, np.ndarray], com: np.ndarray) -> RigidHull:
    """The hull of ``positions`` (node name -> (3,) position [m]) as a rigid body, with its
    centre of mass ``com`` (3,) [m]."""
    names = tuple(positions)
    points = np.array([positions[n] for n in names], dtype=float)
    hull = ConvexHull(points)
    size = float(np.ptp(points, axis=0).max())
    seen: dict[tuple[int, ...], np.ndarray] = {}
    for eq in hull.equations:
        on = tuple(int(i) for i in np.flatnonzero(np.abs(points @ eq[:3] + eq[3])
                                                  <= FACE_TOLERANCE * size))
        seen.setdefault(on, eq[:3] / np.linalg.norm(eq[:3]))
    faces = tuple(seen)
    normals = np.array([seen[f] for f in faces])
    down = np.array([Rotation.align_vectors([[0.0, 0.0, -1.0]], [n])[0].as_matrix()
                     for n in normals])
    edges = tuple(_edges(points, faces, k, down[k]) for k in range(len(faces)))
    return RigidHull(names, points, np.asarray(com, dtype=float), faces, normals, down, edges)


def _edges(points: np.ndarray, faces: tuple[tuple[int, ...], ...], k: int,
           down: np.ndarray) -> tuple[tuple[int, int, int], ...]:
    """Face k's polygon edges (a, b) and the other face that holds both their nodes."""
    face = faces[k]
    flat = (points[list(face)] @ down.T)[:, :2]
    ring = [face[i] for i in ConvexHull(flat).vertices] if len(face) > 3 else list(face)
    out = []
    for a, b in zip(ring, ring[1:] + ring[:1], strict=True):
        across = [j for j, f in enumerate(faces) if j != k and a in f and b in f]
        if across:
            out.append((a, b, across[0]))
    return tuple(out)


def _rot2(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def ground(hull: RigidHull, placement: Placement, points: np.ndarray) -> np.ndarray:
    """(k, 2) where body points (k, 3) lie on the ground, seen from above [m]."""
    flat = (points @ hull.down[placement.face].T)[:, :2]
    return flat @ _rot2(placement.yaw).T + placement.offset


def place(hull: RigidHull, positions: dict[str, np.ndarray]) -> Placement:
    """The placement that best fits the nodes where they are now: the face whose normal the
    best-fitting rotation (Kabsch) turns nearest straight down, then the planar yaw and offset
    that best fit the nodes' horizontal positions to that face's."""
    now = np.array([positions[n] for n in hull.names], dtype=float)
    a, b = hull.points - hull.points.mean(axis=0), now - now.mean(axis=0)
    u, _, vt = np.linalg.svd(b.T @ a)
    r = u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt
    face = int(np.argmin((hull.normals @ r.T)[:, 2]))
    flat = (hull.points @ hull.down[face].T)[:, :2]
    fc, nc = flat - flat.mean(axis=0), now[:, :2] - now[:, :2].mean(axis=0)
    yaw = math.atan2(float(np.sum(fc[:, 0] * nc[:, 1] - fc[:, 1] * nc[:, 0])),
                     float(np.sum(fc * nc)))
    return Placement(face, yaw, now[:, :2].mean(axis=0) - flat.mean(axis=0) @ _rot2(yaw).T)


def tip(hull: RigidHull, placement: Placement, a: int, b: int, face: int) -> Placement:
    """The placement after tipping over the edge of nodes a and b onto ``face``: the two nodes
    stay where they lie on the ground."""
    wa, wb = ground(hull, placement, hull.points[[a, b]])
    ua, ub = (hull.points[[a, b]] @ hull.down[face].T)[:, :2]
    yaw = math.atan2(*(wb - wa)[::-1]) - math.atan2(*(ub - ua)[::-1])
    return Placement(face, yaw, wa - _rot2(yaw) @ ua)


def _walk(hull: RigidHull, p: Placement, before: int | None, depth: int,
          visit: Callable[[Placement, list[tuple[int, int, int]]], None],
          path: list[tuple[int, int, int]]) -> None:
    """Calls visit(placement, path) at every placement of every walk from p (never straight
    back over the edge just crossed) of up to ``depth`` tips."""
    visit(p, path)
    if depth == 0:
        return
    for a, b, face in hull.edges[p.face]:
        if face != before:
            path.append((a, b, face))
            _walk(hull, tip(hull, p, a, b, face), p.face, depth - 1, visit, path)
            path.pop()


def cost(hull: RigidHull, end: Placement, start: Placement, turn: float, length: float,
         tips: int) -> float:
    """What ending a walk of ``tips`` tips at ``end`` (on the start's face) costs [rad]: its yaw
    error from ``turn`` [rad], plus :data:`WEIGHT` rad per body length (``length`` [m]) that
    its centre of mass ends beyond :data:`RADIUS` body lengths from the start, plus
    :data:`TIP_COST` per tip."""
    yaw = math.remainder(end.yaw - start.yaw, 2 * math.pi)
    away = float(np.linalg.norm(ground(hull, end, hull.com[None])[0]
                                - ground(hull, start, hull.com[None])[0]))
    return (abs(math.remainder(turn - yaw, 2 * math.pi))
            + WEIGHT * max(0.0, away / length - RADIUS) + TIP_COST * tips)


def walk_cost(hull: RigidHull, now: Placement, start: Placement, turn: float, length: float,
              walk: tuple[tuple[int, int, int], ...]) -> float:
    """:func:`cost` of following ``walk`` (tips as in :attr:`TurnPlan.walk`) from ``now``;
    infinite where it does not end on the start's face."""
    for a, b, face in walk:
        now = tip(hull, now, a, b, face)
    if now.face != start.face:
        return math.inf
    return cost(hull, now, start, turn, length, len(walk))


def plan_turn(hull: RigidHull, now: Placement, start: Placement, turn: float, length: float,
              depth: int = DEPTH) -> TurnPlan | None:
    """The walk of up to ``depth`` tips, from ``now`` back to the start's face, whose end best
    turns the robot by ``turn`` [rad] from ``start`` while keeping its centre of mass near the
    start: the one of least :func:`cost`.

    Returns:
        The plan, or None where standing where it is (on the start's face) costs least.
    """
    best: list[tuple[float, tuple[tuple[int, int, int], ...], float]] = []

    def visit(p: Placement, path: list[tuple[int, int, int]]) -> None:
        if p.face == start.face:
            c = cost(hull, p, start, turn, length, len(path))
            if not best or c < best[0][0] - 1e-9:
                best[:] = [(c, tuple(path), math.remainder(p.yaw - start.yaw, 2 * math.pi))]

    _walk(hull, now, None, depth, visit, [])
    if not best or not best[0][1]:
        return None
    c, walk, yaw = best[0]
    return TurnPlan(walk, yaw, c)


def edge_heading(hull: RigidHull, placement: Placement, a: int, b: int) -> np.ndarray:
    """(2,) the outward normal, on the ground, of the support polygon's edge of nodes a and b."""
    wa, wb = ground(hull, placement, hull.points[[a, b]])
    centre = ground(hull, placement, hull.points[list(hull.faces[placement.face])]).mean(axis=0)
    normal = np.array([wb[1] - wa[1], wa[0] - wb[0]]) / float(np.linalg.norm(wb - wa))
    return normal if normal @ ((wa + wb) / 2 - centre) >= 0 else -normal
