"""Regular n-prisms (twisted tensegrity prisms): n rods, 3n cables, in self-stressed form.

Bottom n-gon at z = 0, top n-gon at the prism's height twisted by pi/2 + pi/n, rod i from
bottom node i to top node i, vertical cable from bottom node i to top node i-1. This twist is
the one at which the prism has a state of self-stress (Kenner's result; see Skelton & de
Oliveira, *Tensegrity Systems*, 2009, and Tibert & Pellegrino, "Review of form-finding methods
for tensegrity structures", 2003): with force density 1 in the top and bottom cables it is
2 sin(pi/n) in the vertical cables and -2 sin(pi/n) in the rods (n = 3 gives the 1 : sqrt(3) :
-sqrt(3) of :mod:`tensim.models.prism3`, which this generalises). Sizes, masses and cables are
prism3's.
"""

from __future__ import annotations

import math

import numpy as np

from tensim.models.prism3 import (
    DAMPING,
    END_MASS,
    FORCE_DENSITY,
    HEIGHT,
    RADIUS,
    ROD_LINEAR_DENSITY,
    ROD_RADIUS,
    STIFFNESS,
)
from tensim.structure import Cable, Motor, Node, PointMass, Rod, Structure


def twist(n: int) -> float:
    """Rotation of the top polygon against the bottom one in the self-stressed form [rad]."""
    return math.pi / 2 + math.pi / n


def vertical_force_density(n: int) -> float:
    """Force density of the vertical cables per unit force density of the polygon cables."""
    return 2 * math.sin(math.pi / n)


def prism(n: int, elevation: float = 0.02, force_density: float = FORCE_DENSITY) -> Structure:
    """The n-prism with its bottom nodes ``elevation`` metres above the ground.

    Args:
        n: number of rods (sides of the polygons), at least 3.
        elevation: height of the bottom nodes [m].
        force_density: force density of the polygon cables [N/m]; sets the level of
            self-stress (each cable's pretension is its force density times its length).

    Raises:
        ValueError: n < 3.
    """
    if n < 3:
        raise ValueError(f"a prism needs at least 3 rods, got {n}")

    def at(angle: float, z: float) -> tuple[float, float, float]:
        return (RADIUS * math.cos(angle), RADIUS * math.sin(angle), z + elevation)

    step = 2 * math.pi / n
    nodes = tuple(Node(f"b{i}", at(step * i, 0.0), tags=("bottom",)) for i in range(n))
    nodes += tuple(Node(f"t{i}", at(step * i + twist(n), HEIGHT), tags=("top",))
                   for i in range(n))
    pos = {node.name: np.array(node.position) for node in nodes}
    rods = tuple(Rod(f"rod_{i}", (f"b{i}", f"t{i}"), ROD_RADIUS,
                     linear_density=ROD_LINEAR_DENSITY, tags=(f"rod_{i}",)) for i in range(n))
    members = [(f"bottom_{i}", f"b{i}", f"b{(i + 1) % n}", 1.0, "bottom") for i in range(n)]
    members += [(f"top_{i}", f"t{i}", f"t{(i + 1) % n}", 1.0, "top") for i in range(n)]
    members += [(f"vertical_{i}", f"b{i}", f"t{(i - 1) % n}", vertical_force_density(n),
                 "vertical") for i in range(n)]
    cables = tuple(
        Cable(name, (a, b), STIFFNESS, damping=DAMPING,
              pretension=force_density * q * float(np.linalg.norm(pos[a] - pos[b])),
              motor=Motor(max_speed=0.1, max_tension=500.0), tags=(tag,))
        for name, a, b, q, tag in members
    )
    masses = tuple(PointMass(node.name, END_MASS, 0.015) for node in nodes)
    return Structure(f"prism{n}", nodes, rods, cables, masses)


def prism4() -> Structure:
    """The square prism (4 rods, 12 cables), twisted 135 degrees."""
    return prism(4)


def prism5() -> Structure:
    """The pentagonal prism (5 rods, 15 cables), twisted 126 degrees."""
    return prism(5)
