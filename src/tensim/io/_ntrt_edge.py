"""The original toolkit's ``node_edge`` bonds: a substructure posed onto another, nodes into edges.

Follows ``TensegrityModel::addNodeEdgePairs``: each of three or more entries pairs a node of one
substructure with an edge ``n1/n2`` (two nodes) of the other. The second substructure is turned
about the centroid of its reference points (its nodes, its edges' midpoints) so that the normal
of its first three points matches the first's, moved onto the first's centroid, then turned about
that normal so that its first point lies toward the first's. Each edge's old pair and the pairs
between the bonded nodes are removed (unless a rigid builder would build them; an edge that is a
rod is an error), and each edge becomes two pairs through its node: edge start -> node -> edge
end, with the bond's tags.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from tensim.io._ntrt_parts import (
    RIGID_CLASSES,
    Part,
    Tree,
    add_pair,
    fail,
    find_node,
    position,
    same_pair,
)

_ALMOST = 1e-5  # the toolkit's tgUtil::almostEqual distance between two unit vectors

End = tuple[Part, str]


def add_node_edge(tree: Tree, owner: Part, children: tuple[Part, Part], tags: tuple[str, ...],
                  entries: list[tuple[str, str]], label: str) -> None:
    """Bonds ``children[1]`` onto ``children[0]`` as the entries say.

    Raises:
        StructureError: fewer than three entries, an entry that is not one node and one edge,
            an unknown node, reference points on a line, or an edge that is a rod.
    """
    source = owner.source
    if len(entries) < 3:
        raise fail(source, label, f"a node_edge bond needs at least 3 [node, edge] entries, "
                   f"got {len(entries)}")
    nodes: list[End] = []
    edges: list[tuple[End, End]] = []
    refs: tuple[list[np.ndarray], list[np.ndarray]] = ([], [])
    for first, second in entries:
        item = f"{label} [{first}, {second}]"
        if ("/" in first) == ("/" in second):
            raise fail(source, item, "expected one node and one edge 'node1/node2'")
        for side, (child, ref) in enumerate(zip(children, (first, second), strict=True)):
            if "/" in ref:
                a, b = ref.split("/", 1)
                edge = (find_node(child, a, source, item), find_node(child, b, source, item))
                edges.append(edge)
                refs[side].append((position(edge[0]) + position(edge[1])) / 2)
            else:
                nodes.append(find_node(child, ref, source, item))
                refs[side].append(position(nodes[-1]).copy())
    _pose(children[1], refs[0], refs[1], source, label)
    for node, (start, end) in zip(nodes, edges, strict=True):
        for child in children:
            _remove(tree, child, (start, end), edge=True, where=(source, label))
            for other in nodes:
                _remove(tree, child, (node, other), edge=False, where=(source, label))
        add_pair(tree, owner, (start, node), tags, f"{label} [{node[1]}, edge start]")
        add_pair(tree, owner, (node, end), tags, f"{label} [{node[1]}, edge end]")


def _normal(points: list[np.ndarray], source: Path, label: str) -> np.ndarray:
    n = np.cross(points[1] - points[0], points[2] - points[0])
    if not np.linalg.norm(n) > 0:
        raise fail(source, label, "the first three bonded points of a substructure lie on a "
                   "line; they must span a plane")
    return n / np.linalg.norm(n)


def _between(a: np.ndarray, b: np.ndarray, fallback: np.ndarray) -> Rotation:
    """The toolkit's ``getQuaternionBetween``: the turn taking direction a to b (about
    ``fallback`` by 180 degrees when they are opposite)."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    if np.linalg.norm(a - b) < _ALMOST:
        return Rotation.identity()
    if np.linalg.norm(a + b) < _ALMOST:
        return Rotation.from_rotvec(np.pi * fallback / np.linalg.norm(fallback))
    axis = np.cross(a, b)
    return Rotation.from_rotvec(axis / np.linalg.norm(axis)
                                * np.arccos(np.clip(a @ b, -1.0, 1.0)))


def _turn(part: Part, centre: np.ndarray, turn: Rotation) -> None:
    for p in (p for child in part.walk() for p in child.nodes.values()):
        p[:] = centre + turn.apply(p - centre)


def _pose(second: Part, refs1: list[np.ndarray], refs2: list[np.ndarray], source: Path,
          label: str) -> None:
    """``TensegrityModel::rotateAndTranslate``: align normals, centroids, then first points."""
    c1, c2 = np.mean(refs1, axis=0), np.mean(refs2, axis=0)
    n1, n2 = _normal(refs1, source, label), _normal(refs2, source, label)
    fallback = refs2[1] - refs2[0]
    align = _between(n2, n1, fallback)
    _turn(second, c2, align)
    lead = c1 + align.apply(refs2[0] - c2)  # its first point, turned, then moved onto c1
    for child in second.walk():
        for p in child.nodes.values():
            p += c1 - c2
    _turn(second, c1, _between(lead - c1, refs1[0] - c1, n1))


def _remove(tree: Tree, child: Part, ends: tuple[End, End], edge: bool,
            where: tuple[Path, str]) -> None:
    """``TensegrityModel::removePair``: the first pair of ``child`` (or below) between the two
    places, either way round, unless a rigid builder's tags match it."""
    mine = [p for part in child.walk() for p in tree.pairs if p.owner is part]
    found = next((p for p in mine if same_pair(p, ends) or same_pair(p, ends[::-1])), None)
    if found is None:
        return
    if any(b.cls in RIGID_CLASSES and set(b.tags) <= set(found.tags) for b in tree.builders):
        if edge:
            raise fail(*where, f"the edge {found.label} of {found.owner.source.name} is built "
                       "as a rigid body; node_edge bonds need edges that are cables")
        return
    gone = {id(p) for p in mine if same_pair(p, found.ends)}
    tree.pairs[:] = [p for p in tree.pairs if id(p) not in gone]
