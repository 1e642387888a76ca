"""Building a rolling robot as it rests: a face turned down, and its static pose on the ground.

A robot built in its self-stressed form and set down sags onto its feet and, where the ground
must push sideways to hold it (friction), creeps under MuJoCo's soft contacts. Built in the
static pose on frictionless feet, it stands still as built.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from tensim.structure import Structure


def face_down(nodes: dict[str, np.ndarray], face: tuple[str, str, str], lift: float
              ) -> dict[str, np.ndarray]:
    """``nodes`` [m] turned so that ``face``'s outward normal points straight down, the centre
    of the nodes over the origin and the lowest node ``lift`` metres up."""
    a, b, c = (nodes[n] for n in face)
    normal = np.cross(b - a, c - a)
    centre = np.mean(list(nodes.values()), axis=0)
    if normal @ (a - centre) < 0:
        normal = -normal
    turn, _ = Rotation.align_vectors([[0.0, 0.0, -1.0]], [normal / np.linalg.norm(normal)])
    turned = {n: turn.apply(p - centre) for n, p in nodes.items()}
    lowest = min(p[2] for p in turned.values())
    return {n: p + np.array([0.0, 0.0, lift - lowest]) for n, p in turned.items()}


def standing(structure: Structure) -> Structure:
    """``structure`` in its static pose under gravity on its lowest nodes, as on frictionless
    ground (the ground pushes only straight up; :func:`tensim.design.inverse.settle` with
    ``sliding``), its cables given the rest lengths of their pretensions: so it stands still as
    built instead of sagging onto its feet first or creeping on friction."""
    from tensim.design.inverse import feet, settle, with_rest_lengths

    rest = np.array([structure.rest_length(c) for c in structure.cables])
    explicit = with_rest_lengths(structure, rest)
    return settle(explicit, feet(explicit), sliding=True).pose
