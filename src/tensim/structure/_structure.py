"""A whole tensegrity structure: nodes, rods, point masses and cables, checked together."""

from __future__ import annotations

import dataclasses
import functools
import itertools
from collections.abc import Iterable

import numpy as np

from tensim.structure._errors import StructureError
from tensim.structure._records import Cable, Node, PointMass, Rod

_SIDE_MARGIN = 0.01  # a wrap side is undecided within this share of the rod's radius


@dataclasses.dataclass(frozen=True)
class RigidGroup:
    """Rods (and the nodes they join) that share nodes and so move as one rigid body.

    Attributes:
        name: deterministic body name.
        rods: names of the rods in the group (empty for a lone point-mass node).
        nodes: names of the nodes in the group.
        fixed: welded to the world.
    """

    name: str
    rods: tuple[str, ...]
    nodes: tuple[str, ...]
    fixed: bool


def _hidden_middle(p: np.ndarray, q: np.ndarray, radius: float, toward: np.ndarray,
                   axis: np.ndarray) -> np.ndarray:
    """The middle of the arc of a circle (radius ``radius``, centre 0, across unit ``axis``)
    that neither ``p`` nor ``q`` sees, the one nearest ``toward``: where a cable from ``p`` to
    ``q`` wrapped on that side touches the circle. MuJoCo picks the wrap whose tangent points
    lie nearest the side site, a choice that is degenerate for half a turn unless the site sits
    at the arc's middle."""
    e1 = toward / np.linalg.norm(toward)
    e2 = np.cross(axis, e1)
    angles = np.linspace(-np.pi, np.pi, 3600, endpoint=False)  # 0: toward
    hidden = np.ones(angles.size, dtype=bool)
    for point in (p, q):
        phi = np.arctan2(point @ e2, point @ e1)
        hidden &= np.cos(angles - phi) < radius / np.linalg.norm(point)
    # the run of hidden angles that holds angle 0 (or comes nearest it)
    candidates = np.flatnonzero(hidden)
    if not candidates.size:
        return e1
    start = int(candidates[np.argmax(np.cos(angles[candidates]))])
    lo = hi = start
    while hidden[(lo - 1) % angles.size] and (start - lo) < angles.size:
        lo -= 1
    while hidden[(hi + 1) % angles.size] and (hi - lo) < angles.size:
        hi += 1
    middle = np.pi / 1800 * (lo + hi) / 2 - np.pi
    return np.cos(middle) * e1 + np.sin(middle) * e2


@dataclasses.dataclass(frozen=True)
class Structure:
    """A tensegrity structure in its build pose (all positions in the world frame, metres).

    Rods that share a node form one rigid body, as in the original toolkit. A node that no rod
    touches must carry a point mass (it becomes a body of its own) or be fixed.

    Attributes:
        name: structure name.
        nodes: the nodes.
        rods: the rods.
        cables: the cables.
        point_masses: concentrated masses at nodes.
    """

    name: str
    nodes: tuple[Node, ...]
    rods: tuple[Rod, ...] = ()
    cables: tuple[Cable, ...] = ()
    point_masses: tuple[PointMass, ...] = ()

    def __post_init__(self) -> None:
        for field in ("nodes", "rods", "cables", "point_masses"):
            object.__setattr__(self, field, tuple(getattr(self, field)))
        _unique((n.name for n in self.nodes), "node")
        _unique((r.name for r in self.rods), "rod")
        _unique((c.name for c in self.cables), "cable")
        _unique((p.node for p in self.point_masses), "point mass at node")
        known = {n.name for n in self.nodes}
        members: list[tuple[str, tuple[str, ...]]] = [(f"rod {r.name!r}", r.nodes)
                                                      for r in self.rods]
        members += [(f"cable {c.name!r}", c.path) for c in self.cables]
        members += [(f"point mass at {p.node!r}", (p.node,)) for p in self.point_masses]
        for item, ends in members:
            for end in ends:
                if end not in known:
                    raise StructureError(f"unknown node {end!r}; known nodes: {sorted(known)}",
                                         item=item)
        for rod in self.rods:
            if self.distance(*rod.nodes) <= 0:
                raise StructureError("zero-length rod: its two nodes coincide",
                                     item=f"rod {rod.name!r}")
        for cable in self.cables:
            self._check_cable(cable)
        on_rods = {n for r in self.rods for n in r.nodes}
        massive = {p.node for p in self.point_masses}
        for node in self.nodes:
            if node.name not in on_rods and node.name not in massive and not node.fixed:
                raise StructureError(
                    "node touches no rod and carries no point mass; add a mass or mark it fixed",
                    item=f"node {node.name!r}",
                )

    def _check_cable(self, cable: Cable) -> None:
        item = f"cable {cable.name!r}"
        rods = {r.name: r for r in self.rods} if cable.wrap else {}
        for name in cable.wrap:
            if name not in rods:
                raise StructureError(f"wraps around unknown rod {name!r}; rods: {sorted(rods)}",
                                     item=item)
            if set(rods[name].nodes) & set(cable.nodes):
                raise StructureError(f"wraps around rod {name!r}, on which it is anchored",
                                     item=item)
        if cable.wrap:
            self.wrap_sides(cable)  # refuses a wrap whose side cannot be decided
        for a, b in itertools.pairwise(cable.path):
            if self.distance(a, b) <= 0:
                what = "its two nodes coincide" if not cable.via else f"{a!r} and {b!r} coincide"
                raise StructureError(f"zero-length cable span: {what}", item=item)
        length = self.cable_length(cable)
        if length <= 0:
            raise StructureError(
                f"anchor_offset {cable.anchor_offset} m leaves no length between the anchors",
                item=item,
            )
        rest = self.rest_length(cable)
        if rest <= 0:
            raise StructureError(
                f"pretension {cable.pretension} N needs a non-positive rest length ({rest:.4g} m "
                f"for a {length:.4g} m cable of stiffness {cable.stiffness} N/m); expected "
                f"pretension < stiffness * length = {cable.stiffness * length:.4g} N",
                item=item,
            )

    # -- lookups -----------------------------------------------------------------------------

    def node(self, name: str) -> Node:
        """The node called ``name``."""
        return self._nodes_by_name[name]

    @functools.cached_property
    def _nodes_by_name(self) -> dict[str, Node]:
        """Name -> node, built once (a robot of hundreds of nodes looks them up by the
        hundred thousand)."""
        return {node.name: node for node in self.nodes}

    def cable(self, name: str) -> Cable:
        """The cable called ``name``."""
        for cable in self.cables:
            if cable.name == name:
                return cable
        raise KeyError(name)

    def position(self, name: str) -> np.ndarray:
        """(3,) build-pose position of a node [m]."""
        return np.asarray(self.node(name).position, dtype=float)

    def distance(self, a: str, b: str) -> float:
        """Node-to-node distance in the build pose [m]."""
        return float(np.linalg.norm(self.position(a) - self.position(b)))

    def tagged(self, tag: str) -> tuple[Cable, ...]:
        """The cables that carry ``tag``."""
        return tuple(c for c in self.cables if tag in c.tags)

    # -- cable geometry ----------------------------------------------------------------------

    def anchors(self, cable: Cable) -> tuple[np.ndarray, np.ndarray]:
        """The cable's two anchor points in the build pose, (3,) each [m].

        Each anchor sits ``anchor_offset`` from its end node toward the next point of the
        cable's path (the other end, or the nearest via node).
        """
        path = cable.path

        def toward(a: str, b: str) -> np.ndarray:
            span = self.position(b) - self.position(a)
            norm = np.linalg.norm(span)
            unit = span / norm if norm > 0 else np.zeros(3)
            return self.position(a) + cable.anchor_offset * unit

        return toward(path[0], path[1]), toward(path[-1], path[-2])

    def cable_points(self, cable: Cable) -> tuple[np.ndarray, ...]:
        """The points the cable runs through in the build pose: anchor, via nodes, anchor [m]."""
        first, last = self.anchors(cable)
        return (first, *(self.position(v) for v in cable.via), last)

    def wrap_sides(self, cable: Cable) -> tuple[tuple[np.ndarray, np.ndarray, bool], ...]:
        """For each rod the cable wraps: a point on the rod's axis, the unit direction across
        the axis of the side the cable runs over [m, -] (the compiled wrap holds it), and
        whether the cable touches the rod in the build pose.

        In the rod's cross-section, the straight line between the path points on either side
        of the rod (the anchors, or the previous rod's side) either crosses the rod or passes
        clear of it. A ``side`` the cable gives decides: a line that crosses wraps on that
        side; a clear line on that side runs straight past the rod (until the rod moves into
        it), one on the other side wraps around the rod to that side. Without ``side`` the
        build pose decides: a line through the rod wraps on the side it crosses (the shorter
        way round), a line clear of it wraps around the rod's far side (the cable is declared
        to wrap it: a cable over a pulley); a line too close to the axis (either way round is
        as short) or to the surface (touching or clear) leaves it undecided.

        Raises:
            StructureError: an undecided side, a path point within the rod, or a given side
                along the rod's axis.
        """
        item = f"cable {cable.name!r}"
        rods = {r.name: r for r in self.rods}
        first, last = self.anchors(cable)
        previous = first
        out = []
        for k, name in enumerate(cable.wrap):
            rod = rods[name]
            base = self.position(rod.nodes[0])
            axis = self.position(rod.nodes[1]) - base
            axis /= np.linalg.norm(axis)

            def across(v: np.ndarray, axis: np.ndarray = axis) -> np.ndarray:
                return v - (v @ axis) * axis

            p, q = across(previous - base), across(last - base)
            centre = base + ((previous + last) / 2 - base) @ axis * axis
            where = f"wrapping rod {name!r} (radius {rod.radius:g} m)"
            for point, dist in ((previous, np.linalg.norm(p)), (last, np.linalg.norm(q))):
                if dist <= rod.radius * (1 + _SIDE_MARGIN):
                    raise StructureError(
                        f"{where}: the path point {np.round(point, 6).tolist()} lies "
                        f"{dist:.4g} m from its axis, within its radius; move it out",
                        item=item)
            run = (q - p) @ (q - p)
            t = float(np.clip(-(p @ (q - p)) / run, 0.0, 1.0)) if run > 0 else 0.0
            closest = p + t * (q - p)
            clearance = float(np.linalg.norm(closest))
            crosses = clearance < rod.radius
            if cable.side:
                given = across(np.asarray(cable.side[k], dtype=float))
                if np.linalg.norm(given) < 1e-9 * np.linalg.norm(cable.side[k]):
                    raise StructureError(f"{where}: side {list(cable.side[k])} runs along the "
                                         "rod's axis; give a direction across it", item=item)
                touches = crosses or given @ closest < 0
                direction = _hidden_middle(p, q, rod.radius, given, axis) if touches else given
            else:
                if clearance < _SIDE_MARGIN * rod.radius or \
                        abs(clearance - rod.radius) < _SIDE_MARGIN * rod.radius:
                    place = "its axis" if clearance < rod.radius / 2 else "its surface"
                    raise StructureError(
                        f"{where}: the cable's straight build line passes {clearance:.4g} m "
                        f"from the axis, too near {place} to tell which side it runs over; "
                        "give side (a direction from the axis, [0, 0, 1]: over the top)",
                        item=item)
                # through the rod: the side it crosses; clear of it: around the far side
                touches = True
                direction = _hidden_middle(p, q, rod.radius, closest if crosses else -closest,
                                           axis)
            direction = direction / np.linalg.norm(direction)
            out.append((centre, direction, bool(touches)))
            previous = centre + rod.radius * direction if touches else previous
        return tuple(out)

    def cable_length(self, cable: Cable) -> float:
        """Anchor-to-anchor length along the path in the build pose [m] (x in paper eq. 2).

        -1 when the anchor offsets leave no length (they pass the next point of the path).
        Computed once per cable (the checks, the compiler and the writers each ask for
        every cable's length; the structure and its records are frozen).
        """
        lengths = self._cable_lengths
        try:
            length = lengths.get(cable)
        except TypeError:  # a cable built with an unhashable field: not remembered
            return self._cable_length(cable)
        if length is None:
            length = lengths[cable] = self._cable_length(cable)
        return length

    @functools.cached_property
    def _cable_lengths(self) -> dict[Cable, float]:
        """Cable -> :meth:`cable_length`, filled as they are asked for."""
        return {}

    def _cable_length(self, cable: Cable) -> float:
        """:meth:`cable_length`, computed."""
        ends = (cable.path[:2], cable.path[-2:])
        spans = [self.distance(a, b) for a, b in ends]
        room = 2 * cable.anchor_offset if not cable.via else cable.anchor_offset
        if min(spans) <= room:
            return -1.0
        points = self.cable_points(cable)
        return float(sum(np.linalg.norm(b - a) for a, b in itertools.pairwise(points)))

    def rest_length(self, cable: Cable) -> float:
        """Initial rest length [m]: given, or length - pretension / stiffness."""
        if cable.rest_length is not None:
            return cable.rest_length
        assert cable.pretension is not None
        return self.cable_length(cable) - cable.pretension / cable.stiffness

    # -- rigid bodies ------------------------------------------------------------------------

    def rigid_groups(self) -> tuple[RigidGroup, ...]:
        """Partitions rods into rigid bodies (rods sharing a node), in a deterministic order.

        A group is named after the first tag that all its rods carry and no other rod does,
        else ``rigid_<k>``; a lone point-mass node gives a group named after the node.
        Found once per structure (the check, the analyses and the compiler each ask).
        """
        return self._rigid_groups

    @functools.cached_property
    def _rigid_groups(self) -> tuple[RigidGroup, ...]:
        """:meth:`rigid_groups`, found."""
        parent = {n.name: n.name for n in self.nodes}

        def find(x: str) -> str:
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        for rod in self.rods:
            parent[find(rod.nodes[0])] = find(rod.nodes[1])
        order: dict[str, list[Rod]] = {}
        for rod in self.rods:
            order.setdefault(find(rod.nodes[0]), []).append(rod)
        fixed = {n.name for n in self.nodes if n.fixed}
        groups = []
        for k, (root, rods) in enumerate(order.items()):
            nodes = tuple(n.name for n in self.nodes if find(n.name) == root)
            name = self._group_name(rods) or f"rigid_{k}"
            groups.append(RigidGroup(name, tuple(r.name for r in rods), nodes,
                                     any(n in fixed for n in nodes)))
        on_rods = {n for r in self.rods for n in r.nodes}
        for pm in self.point_masses:
            if pm.node not in on_rods:
                groups.append(RigidGroup(pm.node, (), (pm.node,), pm.node in fixed))
        _unique((g.name for g in groups), "rigid body")
        return tuple(groups)

    def _group_name(self, rods: list[Rod]) -> str | None:
        inside = {r.name for r in rods}
        for tag in rods[0].tags:
            if all(tag in r.tags for r in rods) and not any(
                tag in r.tags for r in self.rods if r.name not in inside
            ):
                return tag
        return None

    def total_mass(self) -> float:
        """Mass of all rods and point masses [kg]."""
        rods = sum(r.mass_per_length() * self.distance(*r.nodes) for r in self.rods)
        return rods + sum(p.mass for p in self.point_masses)

    def replace_cables(self, **changes: object) -> Structure:
        """A copy with every cable's fields changed (e.g. ``stiffness=300.0``)."""
        cables = tuple(dataclasses.replace(c, **changes) for c in self.cables)  # type: ignore[arg-type]
        return dataclasses.replace(self, cables=cables)


def _unique(names: Iterable[str], what: str) -> None:
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise StructureError(f"duplicate {what} name {name!r}", item=f"{what} {name!r}")
        seen.add(name)


def body_length(structure: Structure) -> float:
    """The robot's body length [m], the field's unit of a rolling or crawling robot's speed
    (body lengths per second): its longest bar, end node to end node in the build pose, where
    a bar is a rod together with the rods of its rigid body that lie on its line (a bar split
    into pieces at its nodes, as an imported file's end caps and sleeves split it); a robot
    without rods, its longest cable, end node to end node.

    Raises:
        StructureError: a structure with neither rods nor cables.
    """
    if not structure.rods:
        if not structure.cables:
            raise StructureError("has neither rods nor cables, so no body length",
                                 item=f"structure {structure.name!r}")
        return max(structure.distance(*c.nodes) for c in structure.cables)
    return max(_bar_length(structure, group) for group in structure.rigid_groups() if group.rods)


def _bar_length(structure: Structure, group: RigidGroup) -> float:
    """The longest bar of one rigid body [m]: its rods' lengths, a rod's taken with the
    nodes of the body's other rods on its line (within 1e-9 of its length)."""
    members = set(group.rods)
    rods = [r.nodes for r in structure.rods if r.name in members]
    longest = 0.0
    for a, b in rods:
        start, length = structure.position(a), structure.distance(a, b)
        axis = (structure.position(b) - start) / length
        on_line = {a, b}
        for c, d in rods:
            ends = [structure.position(n) - start for n in (c, d)]
            if all(np.linalg.norm(e - (e @ axis) * axis) <= 1e-9 * length for e in ends):
                on_line.update((c, d))
        longest = max(longest, length if len(on_line) == 2 else
                      max(structure.distance(p, q) for p in on_line for q in on_line))
    return longest

