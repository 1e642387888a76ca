"""Cable length derivatives of tensim.design._bodies against a rigid-body finite difference."""

from __future__ import annotations

import itertools

import numpy as np
from scipy.spatial.transform import Rotation

from tensim.design import equilibrium
from tensim.design._bodies import Bodies, bodies, cable_geometry
from tensim.structure import Cable, Node, Rod, Structure


def _bent_pair() -> Structure:
    """Two V-shaped bodies (two rods sharing a node each) held apart by cables; cable "ac"
    and "df" each have both ends on one body, so rigid motions never change their lengths."""
    nodes = (Node("a", (0.0, 0.0, 0.0)), Node("b", (0.5, 0.1, 0.4)), Node("c", (1.0, 0.0, 0.1)),
             Node("d", (0.1, 0.8, 0.2)), Node("e", (0.6, 0.7, -0.3)),
             Node("f", (1.1, 0.9, 0.3)))
    rods = tuple(Rod(a + b, (a, b), 0.01, linear_density=0.1)
                 for a, b in (("a", "b"), ("b", "c"), ("d", "e"), ("e", "f")))
    pairs = ("ac", "df", "ad", "be", "cf", "ae", "bf", "cd")
    cables = tuple(Cable(p, (p[0], p[1]), 300.0, pretension=5.0 + i) for i, p in enumerate(pairs))
    return Structure("bent pair", nodes, rods, cables)


def _lengths(structure: Structure, body_set: Bodies, twist: np.ndarray) -> np.ndarray:
    """Slow reference: every cable's length after moving each body by ``twist`` (full
    coordinates), with exact rotations."""
    def moved(name: str) -> np.ndarray:
        b = body_set.node_body[name]
        c = body_set.com[b]
        v, w = twist[6 * b:6 * b + 3], twist[6 * b + 3:6 * b + 6]
        return c + v + Rotation.from_rotvec(w).apply(structure.position(name) - c)

    return np.array([sum(np.linalg.norm(moved(q) - moved(p))
                         for p, q in itertools.pairwise(c.path)) for c in structure.cables])


def test_cable_on_one_body_has_derivatives_of_a_rigid_motion() -> None:
    structure = _bent_pair()
    body_set = bodies(structure)
    geometry = cable_geometry(structure, body_set)
    basis = body_set.basis
    n_dof, n_cables = basis.shape[1], len(structure.cables)
    h = 1e-4  # central differences: truncation ~ h^2, round-off ~ eps / h^2

    def lengths(a: float, i: int, b: float = 0.0, j: int = 0) -> np.ndarray:
        return _lengths(structure, body_set, a * basis[:, i] + b * basis[:, j])

    grad = np.array([(lengths(h, i) - lengths(-h, i)) / (2 * h) for i in range(n_dof)]).T
    np.testing.assert_allclose(geometry.gradients, grad, atol=1e-8)
    np.testing.assert_allclose(geometry.gradients[:2], 0.0, atol=1e-12)  # ac, df: rigid
    hess = np.zeros((n_cables, n_dof, n_dof))
    for i, j in itertools.product(range(n_dof), repeat=2):
        hess[:, i, j] = (lengths(h, i, h, j) - lengths(h, i, -h, j) - lengths(-h, i, h, j)
                         + lengths(-h, i, -h, j)) / (4 * h * h)
    for c, unit in enumerate(np.eye(n_cables)):
        # the exponential map's Hessian equals the exact rotation's to second order
        np.testing.assert_allclose(geometry.geometric(unit), hess[c], atol=1e-6, err_msg=str(c))


def test_cable_on_one_body_is_a_self_stress_and_no_mechanism() -> None:
    # hand count: 2 bodies x 6 DoF = 12; the 6 cables between the bodies are independent
    # (rank 6), the 2 on one body have zero columns: s = 8 - 6 = 2, m = 12 - 6 = 6 rigid
    eq = equilibrium(_bent_pair())
    assert (eq.rank, eq.s, eq.m, eq.n_rigid, eq.internal_mechanisms) == (6, 2, 6, 6, 0)
