"""The triangular tensegrity prism (Snelson's simplex): 3 rods, 9 cables.

Bottom triangle at z = 0, top triangle twisted by 150 degrees, rod i from bottom node i to top
node i, vertical cable from bottom node i to top node i+2. In this form the structure has one
state of self-stress with force densities 1 (triangle cables), sqrt(3) (vertical cables) and
-sqrt(3) (rods); the build-time pretensions follow from it.
"""

from __future__ import annotations

import math

import numpy as np

from tensim.structure import Cable, Motor, Node, PointMass, Rod, Structure

RADIUS = 0.2  # m, circumradius of the triangles
HEIGHT = 0.3  # m
TWIST = math.radians(150.0)
ROD_RADIUS = 0.01  # m
ROD_LINEAR_DENSITY = 0.2  # kg/m
END_MASS = 0.05  # kg
STIFFNESS = 1000.0  # N/m
DAMPING = 5.0  # N s/m
FORCE_DENSITY = 40.0  # N/m in the triangle cables; sets the level of self-stress


def prism3(elevation: float = 0.02, force_density: float = FORCE_DENSITY) -> Structure:
    """The prism with its bottom nodes ``elevation`` metres above the ground."""
    def at(angle: float, z: float) -> tuple[float, float, float]:
        return (RADIUS * math.cos(angle), RADIUS * math.sin(angle), z + elevation)

    nodes = tuple(Node(f"b{i}", at(2 * math.pi * i / 3, 0.0), tags=("bottom",)) for i in range(3))
    nodes += tuple(Node(f"t{i}", at(2 * math.pi * i / 3 + TWIST, HEIGHT), tags=("top",))
                   for i in range(3))
    pos = {n.name: np.array(n.position) for n in nodes}
    rods = tuple(Rod(f"rod_{i}", (f"b{i}", f"t{i}"), ROD_RADIUS,
                     linear_density=ROD_LINEAR_DENSITY, tags=(f"rod_{i}",)) for i in range(3))
    members = [(f"bottom_{i}", f"b{i}", f"b{(i + 1) % 3}", 1.0, "bottom") for i in range(3)]
    members += [(f"top_{i}", f"t{i}", f"t{(i + 1) % 3}", 1.0, "top") for i in range(3)]
    members += [(f"vertical_{i}", f"b{i}", f"t{(i + 2) % 3}", math.sqrt(3), "vertical")
                for i in range(3)]
    cables = tuple(
        Cable(name, (a, b), STIFFNESS, damping=DAMPING,
              pretension=force_density * q * float(np.linalg.norm(pos[a] - pos[b])),
              motor=Motor(max_speed=0.1, max_tension=500.0), tags=(tag,))
        for name, a, b, q, tag in members
    )
    masses = tuple(PointMass(n.name, END_MASS, 0.015) for n in nodes)
    return Structure("prism3", nodes, rods, cables, masses)
