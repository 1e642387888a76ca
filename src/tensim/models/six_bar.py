"""The six-strut icosahedron ("expanded octahedron") of ReCTeR and SUPERball: 6 rods, 24 cables.

Three pairs of parallel struts along x, y and z; each pair is half a strut length apart, the
form in which equal cable force densities are in equilibrium (cable length = strut * sqrt(6)/4,
strut force density = -1.5 x the cable's). Scale: 1 m struts as on ReCTeR.

Standing: built resting on a closed triangle of cables in its static pose under gravity on
frictionless feet, as ``three_bar`` and ``superball`` are (:mod:`tensim.models._standing`), so
it stands still as built; ``six_bar(standing=False)`` is the symmetric form (the one the
design tools' tests take as the published expanded octahedron).
"""

from __future__ import annotations

import itertools

import numpy as np

from tensim.models._standing import lying, stored_standing
from tensim.models._standing import standing as settled
from tensim.structure import Cable, Motor, Node, PointMass, Rod, Structure

STRUT_LENGTH = 1.0  # m
ROD_RADIUS = 0.01  # m
ROD_LINEAR_DENSITY = 0.2  # kg/m
END_MASS = 0.05  # kg, end caps
CAP_RADIUS = 0.02  # m, end caps (the feet: they touch the ground before the rods)
STIFFNESS = 500.0  # N/m
DAMPING = 5.0  # N s/m
PRETENSION = 15.0  # N, the same in every cable


def six_bar_nodes(strut_length: float = STRUT_LENGTH) -> dict[str, np.ndarray]:
    """The 12 node positions [m], centred at the origin; nodes ``<axis><pair><end>``."""
    h, s = strut_length / 2, strut_length / 4
    nodes = {}
    for axis, perm in (("x", (2, 0, 1)), ("y", (1, 2, 0)), ("z", (0, 1, 2))):
        for pair, offset in enumerate((-s, s)):
            for end, along in enumerate((-h, h)):
                local = np.array([0.0, offset, along])  # strut along local z at y = offset
                nodes[f"{axis}{pair}{end}"] = local[list(perm)]
    return nodes


def six_bar(clearance: float = 0.0, standing: bool = True) -> Structure:
    """The six-bar resting on a closed triangle of cables, as it rests between rolls: in its
    static pose under gravity on frictionless feet (:func:`tensim.models._standing.standing`:
    it stands still as built), its lowest end cap ``clearance`` metres up before it
    settles. ``standing=False``: the symmetric self-stressed form, unsettled (rest lengths from
    the pretension), lifted the same way. With the
    default arguments the pose is read, bit for bit, from the stored file
    (:func:`tensim.models._standing.stored_standing`), not solved again."""
    positions = six_bar_nodes()
    length = STRUT_LENGTH * np.sqrt(6) / 4
    pairs = [(a, b) for a, b in itertools.combinations(positions, 2)
             if abs(np.linalg.norm(positions[a] - positions[b]) - length) < 1e-9]
    face = next(f for f in itertools.combinations(positions, 3)
                if all(p in pairs for p in itertools.combinations(f, 2)))
    nodes = tuple(Node(n, tuple(p)) for n, p in positions.items())
    rods = tuple(
        Rod(f"rod_{axis}{pair}", (f"{axis}{pair}0", f"{axis}{pair}1"), ROD_RADIUS,
            linear_density=ROD_LINEAR_DENSITY, friction=1.0, tags=(f"rod_{axis}{pair}",))
        for axis in "xyz" for pair in (0, 1)
    )
    cables = tuple(Cable(f"cable_{a}_{b}", (a, b), STIFFNESS, damping=DAMPING,
                         pretension=PRETENSION, motor=Motor(max_speed=0.2, max_tension=500.0))
                   for a, b in pairs)
    masses = tuple(PointMass(n, END_MASS, CAP_RADIUS) for n in positions)
    form = Structure("six_bar", nodes, rods, cables, masses)
    if standing and clearance == 0.0:  # the pose solved once and stored (_standing.STORED)
        return stored_standing(form)
    robot = lying(form, face, clearance + max(ROD_RADIUS, CAP_RADIUS))
    return settled(robot) if standing else robot
