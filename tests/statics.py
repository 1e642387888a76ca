"""Independent statics for the tests: a structure's state of self-stress by the force-density
method, from its node positions alone (no tensim physics)."""

from __future__ import annotations

import numpy as np

from tensim.structure import Structure


def self_stress(structure: Structure) -> tuple[list[tuple[str, str]], np.ndarray]:
    """Member ends (rods, then cables) and the one state of self-stress (their force
    densities, up to scale), from the SVD of the equilibrium matrix."""
    names = [n.name for n in structure.nodes]
    x = np.array([n.position for n in structure.nodes])
    members = [r.nodes for r in structure.rods] + [c.nodes for c in structure.cables]
    # equilibrium matrix: node i gets q_ij (x_j - x_i) from each member ij
    a = np.zeros((3 * len(names), len(members)))
    for j, (p, q) in enumerate(members):
        i, k = names.index(p), names.index(q)
        a[3 * i:3 * i + 3, j] = x[k] - x[i]
        a[3 * k:3 * k + 3, j] = x[i] - x[k]
    _, sv, vt = np.linalg.svd(a)
    assert (sv < 1e-10 * sv[0]).sum() == 1  # exactly one state of self-stress
    return members, vt[-1]
