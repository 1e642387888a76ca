"""Tip plans made once per support face and edge, and shared through the robot's symmetry.

The punctuated gait's plan (:func:`~tensim.control.rolling.plan_tip`) is the statics of the
robot standing on a face: it depends on the face, the edge it tips over and the rest lengths
it starts from, while the heading only picks the edge. A robot rolls over the few faces of
its hull again and again, so :class:`PlanCache` makes each (face, edge) plan once, from a
canonical pose: the build pose turned so that the face is down, every cable at its built rest
length. Faces related by a symmetry of the robot (a node permutation that keeps every distance
of the build pose, maps rods to rods and cables to cables of the same stiffness, rest length and
motor) share one plan, its rest lengths permuted with the cables. A support face that is not a
face of the build pose's hull (a robot flattened onto four nodes) is planned afresh from where
the robot stands.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

from tensim.control.rolling import (
    FACE_TOLERANCE,
    RollSettings,
    TipPlan,
    ahead_edges,
    plan_edge,
    plan_tip,
    support_edges,
    support_face,
)
from tensim.design._bodies import GRAVITY
from tensim.design.inverse import settle, with_rest_lengths
from tensim.structure import Cable, Structure

SYMMETRY_TOLERANCE = 0.01  # share of the robot's size within which two distances count equal
MATCH = 1e-4  # relative difference within which two members' stiffness, mass, motor count equal


@dataclasses.dataclass(frozen=True)
class Symmetry:
    """A symmetry of a robot: where each node and each cable goes.

    Attributes:
        nodes: node name -> the name of the node it maps to.
        cables: (n_cables,) index of the cable each cable maps to.
    """

    nodes: dict[str, str]
    cables: np.ndarray


def symmetries(structure: Structure, tolerance: float = SYMMETRY_TOLERANCE) -> list[Symmetry]:
    """Every node permutation of ``structure`` that keeps the distances between its nodes in
    the build pose (within ``tolerance`` times its size), maps each rod onto a rod of the same
    radius and density and each cable onto a cable of the same stiffness, damping, rest length
    and motor; the identity first. Found by backtracking over the nodes, pruning on distances.
    """
    names = [n.name for n in structure.nodes]
    points = np.array([n.position for n in structure.nodes], dtype=float)
    distance = np.linalg.norm(points[:, None] - points[None], axis=2)
    limit = tolerance * float(np.ptp(points, axis=0).max())
    index = {n: i for i, n in enumerate(names)}
    cables = {frozenset(index[e] for e in cable.nodes): c
              for c, cable in enumerate(structure.cables)}
    rest = [structure.rest_length(c) for c in structure.cables]
    rods = {frozenset(index[e] for e in rod.nodes): rod for rod in structure.rods}
    found: list[Symmetry] = []
    image = [-1] * len(names)

    def members_kept() -> np.ndarray | None:
        mapping = np.zeros(len(structure.cables), dtype=int)
        for ends, c in cables.items():
            d = cables.get(frozenset(image[e] for e in ends))
            if d is None or not _same_cable(structure.cables[c], structure.cables[d]) \
                    or abs(rest[c] - rest[d]) > limit:
                return None
            mapping[c] = d
        for ends, rod in rods.items():
            other = rods.get(frozenset(image[e] for e in ends))
            if other is None or not _close((other.radius, other.mass_per_length()),
                                           (rod.radius, rod.mass_per_length())):
                return None
        return mapping

    def extend(i: int, used: set[int]) -> None:
        if i == len(names):
            mapping = members_kept()
            if mapping is not None:
                found.append(Symmetry({names[a]: names[b] for a, b in enumerate(image)},
                                      mapping))
            return
        for j in range(len(names)):
            if j in used or any(abs(distance[i, k] - distance[j, image[k]]) > limit
                                for k in range(i)):
                continue
            image[i] = j
            extend(i + 1, used | {j})
        image[i] = -1

    extend(0, set())
    found.sort(key=lambda s: any(a != b for a, b in s.nodes.items()))
    return found


def _same_cable(a: Cable, b: Cable) -> bool:
    return _close((a.stiffness, a.damping, a.motor), (b.stiffness, b.damping, b.motor))


def _close(a: object, b: object) -> bool:
    """Equal, numbers to :data:`MATCH` (a file's rounded digits), records field by field."""
    if dataclasses.is_dataclass(a) and dataclasses.is_dataclass(b):
        return type(a) is type(b) and _close(dataclasses.astuple(a),  # type: ignore[arg-type]
                                             dataclasses.astuple(b))  # type: ignore[arg-type]
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float | int) and isinstance(b, float | int) and not isinstance(a, bool):
        return math.isclose(a, b, rel_tol=MATCH, abs_tol=1e-12)
    return a == b


def hull_faces(positions: dict[str, np.ndarray]) -> dict[tuple[str, ...], np.ndarray]:
    """The faces of the convex hull of ``positions`` as :func:`support_face` finds them (every
    node within :data:`FACE_TOLERANCE` of the face's plane): sorted node names -> the face's
    unit outward normal."""
    names = list(positions)
    points = np.array([positions[n] for n in names])
    size = float(np.ptp(points, axis=0).max())
    faces: dict[tuple[str, ...], np.ndarray] = {}
    for equation in ConvexHull(points).equations:
        near = np.abs(points @ equation[:3] + equation[3]) <= FACE_TOLERANCE * size
        faces.setdefault(tuple(sorted(n for n, on in zip(names, near, strict=True) if on)),
                         equation[:3])
    return faces


def face_down_pose(structure: Structure, normal: np.ndarray) -> Structure:
    """``structure`` turned so that the face with outward ``normal`` points straight down."""
    turn, _ = Rotation.align_vectors([[0.0, 0.0, -1.0]], [normal])
    points = turn.apply(np.array([n.position for n in structure.nodes], dtype=float))
    points[:, 2] -= points[:, 2].min()
    return dataclasses.replace(structure, nodes=tuple(
        dataclasses.replace(n, position=tuple(p)) for n, p in zip(structure.nodes, points,
                                                                   strict=True)))


class PlanCache:
    """Tip plans of one robot, made once per (face, edge) and shared through its symmetries.

    Args:
        structure: the robot in its build pose.
        built: (n_cables,) its built rest lengths [m] (the plans start from them).
        settings: the gait's travel, margin and steps.
        gravity: [m/s^2].
        symmetric: share plans between faces the robot's symmetries relate (else every face
            and edge is planned from statics).
        dynamic: called as dynamic(pose, feet, edge, statics rest lengths) where the statics
            plan falls short of the margin: the rest lengths of a tip found otherwise (in
            simulation, :func:`tensim.experiments.roll_search.search_tip`), or None.
    """

    def __init__(self, structure: Structure, built: np.ndarray, settings: RollSettings,
                 gravity: float = GRAVITY, symmetric: bool = True,
                 dynamic: Callable[[Structure, tuple[str, ...], tuple[str, str], np.ndarray],
                                   np.ndarray | None] | None = None) -> None:
        self.dynamic = dynamic
        self.structure, self.built = structure, np.asarray(built, dtype=float)
        self.settings, self.gravity = settings, gravity
        self.faces = hull_faces({n.name: np.asarray(n.position, dtype=float)
                                 for n in structure.nodes})
        self.symmetries = symmetries(structure) if symmetric else []
        self._plans: dict[tuple[tuple[str, ...], tuple[str, str]], tuple[np.ndarray, float]] = {}
        self.made = 0  # plans made from statics (the rest came from the cache)
        self.fresh = 0  # plans made from the robot's own pose (a face not of the build hull)

    def plan(self, pose: Structure, rest: np.ndarray, heading: np.ndarray) -> TipPlan:
        """The tip toward ``heading`` of the robot standing in ``pose`` (its nodes where they
        are now), as :func:`~tensim.control.rolling.plan_tip` makes it but from the face's
        canonical pose; a face not of the build pose's hull is planned from ``pose`` and
        ``rest`` by :func:`~tensim.control.rolling.plan_tip` itself.

        Raises:
            DesignError: no edge ahead of the heading, or no static pose on the face.
        """
        positions = {n.name: np.asarray(n.position, dtype=float) for n in pose.nodes}
        feet = support_face(positions)
        if feet not in self.faces:
            self.fresh += 1
            return plan_tip(pose, rest, self.built, heading, self.settings, self.gravity)
        best: TipPlan | None = None
        for edge in ahead_edges(np.array([positions[f][:2] for f in feet]), feet, heading):
            rest_lengths, margin = self.edge_plan(feet, _edge_nodes(edge, feet, positions))
            # as plan_tip's: the cables the plan does not move keep the rest lengths they hold
            kept = np.where(np.abs(rest_lengths - self.built) > 1e-9, rest_lengths, rest)
            plan = TipPlan(kept, feet, edge[:2].copy(), margin)
            if margin >= self.settings.margin:
                return plan
            if best is None or margin > best.margin:
                best = plan
        assert best is not None
        return best

    def edge_plan(self, feet: tuple[str, ...], edge: tuple[str, str]) -> tuple[np.ndarray, float]:
        """(rest lengths [m], margin [m]) of the tip over ``edge`` (two of ``feet``) from the
        face ``feet`` of the build hull, from the cache or its symmetric image."""
        key = (feet, edge)
        if key in self._plans:
            return self._plans[key]
        for symmetry in self.symmetries[1:]:
            inverse = {b: a for a, b in symmetry.nodes.items()}
            source = (tuple(sorted(inverse[n] for n in feet)),
                      tuple(sorted(inverse[n] for n in edge)))
            if source in self._plans:
                rest_lengths, margin = self._plans[source]
                mapped = np.empty_like(rest_lengths)
                mapped[symmetry.cables] = rest_lengths
                self._plans[key] = (mapped, margin)
                return self._plans[key]
        self._plans[key] = self._make(feet, edge)
        return self._plans[key]

    def _make(self, feet: tuple[str, ...], edge: tuple[str, str]) -> tuple[np.ndarray, float]:
        self.made += 1
        pose = face_down_pose(self.structure, self.faces[feet])
        positions = {n.name: np.asarray(n.position) for n in pose.nodes}
        line = next(e for e in support_edges(np.array([positions[f][:2] for f in feet]))
                    if _edge_nodes(e, feet, positions) == edge)
        explicit = with_rest_lengths(pose, self.built)
        start = settle(explicit, feet, self.gravity, sliding=self.settings.sliding)
        plan = plan_edge(pose, explicit, start, self.built, self.built, line, feet,
                         self.settings, self.gravity)
        if plan.margin < self.settings.margin and self.dynamic is not None:
            found = self.dynamic(pose, feet, edge, plan.rest_lengths)
            if found is not None:  # a tip found in simulation: it crosses the edge
                return found, self.settings.margin
        return plan.rest_lengths, plan.margin


def _edge_nodes(edge: np.ndarray, feet: tuple[str, ...], positions: dict[str, np.ndarray]
                ) -> tuple[str, str]:
    """The two feet on the support edge ``edge`` (a, b, c), sorted."""
    off = [abs(positions[f][:2] @ edge[:2] + edge[2]) for f in feet]
    a, b = sorted(feet[i] for i in np.argsort(off)[:2])
    return a, b
