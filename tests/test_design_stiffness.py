"""Tangent stiffness of tensim.design against closed forms and a finite-difference Hessian."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
from scipy.spatial.transform import Rotation

from tensim.design._bodies import bodies
from tensim.design.stiffness import stiffness
from tensim.models.prisms import prism
from tensim.structure import Cable, Node, PointMass, Structure


def _tether(k: float, tension: float, length: float, mass: float) -> Structure:
    """A point mass on one cable from a fixed anchor, the cable along (1, 2, 2) / 3."""
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    nodes = (Node("anchor", (0.0, 0.0, 0.0), fixed=True),
             Node("m", tuple(length * axis)))
    return Structure("tether", nodes, (), (Cable("c", ("anchor", "m"), k, pretension=tension),),
                     (PointMass("m", mass),))


def test_single_cable_stiffness_is_k_along_and_tension_over_length_across() -> None:
    k, tension, length, mass = 400.0, 12.0, 0.6, 0.25
    result = stiffness(_tether(k, tension, length, mass))
    e = np.array([1.0, 2.0, 2.0]) / 3.0
    expected = k * np.outer(e, e) + tension / length * (np.eye(3) - np.outer(e, e))
    np.testing.assert_allclose(result.matrix, expected, rtol=1e-12)
    np.testing.assert_allclose(result.material, k * np.outer(e, e), rtol=1e-12)
    # natural frequencies: sqrt(T / (L m)) twice (across), sqrt(k / m) once (along)
    omega = 2 * np.pi * result.frequencies
    np.testing.assert_allclose(omega, np.sqrt([tension / (length * mass)] * 2 + [k / mass]),
                               rtol=1e-12)
    # one cable on 3 DoF: 2 mechanisms (across), both stiffened by the tension
    assert (result.rigid, result.mechanisms, result.stiffened) == (0, 2, 2)


def _energy(structure: Structure, twist: np.ndarray) -> float:
    """Slow reference: the cables' elastic energy after moving every body by ``twist`` (full
    coordinates: COM translation and rotation vector per body), with exact rotations."""
    body_set = bodies(structure)

    def moved(name: str) -> np.ndarray:
        b = body_set.node_body[name]
        p = structure.position(name)
        if b < 0:
            return p
        v, w = twist[6 * b:6 * b + 3], twist[6 * b + 3:6 * b + 6]
        c = body_set.com[b]
        return c + v + Rotation.from_rotvec(w).apply(p - c)

    total = 0.0
    for cable in structure.cables:
        points = [moved(n) for n in cable.path]
        length = sum(np.linalg.norm(b - a) for a, b in itertools.pairwise(points))
        stretch = max(0.0, length - structure.rest_length(cable))
        total += 0.5 * cable.stiffness * stretch**2
    return total


def test_stiffness_equals_finite_difference_hessian_of_the_energy() -> None:
    # a prism whose cables all pull at different tensions (not an equilibrium, so the geometric
    # term matters everywhere) against central differences of the exact energy
    structure = prism(3)
    cables = tuple(dataclasses.replace(c, pretension=5.0 + 2.0 * i)
                   for i, c in enumerate(structure.cables))
    structure = dataclasses.replace(structure, cables=cables)
    result = stiffness(structure)
    basis = bodies(structure).basis
    h = 1e-4  # central differences: error ~ h^2 x fourth derivative, round-off ~ eps V / h^2
    n = basis.shape[1]
    fd = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            def e(a: float, b: float, i: int = i, j: int = j) -> float:
                return _energy(structure, basis[:, i] * a + basis[:, j] * b)
            fd[i, j] = (e(h, h) - e(h, -h) - e(-h, h) + e(-h, -h)) / (4 * h * h)
    # tolerance: the exponential map's Hessian equals the exact rotation's to second order;
    # differences of O(h^2) relative to the largest entry remain
    np.testing.assert_allclose(result.matrix, fd, atol=1e-5 * np.abs(fd).max())


def test_prestress_stiffens_the_prism_mechanism() -> None:
    # the 3-prism's one infinitesimal mechanism has no material stiffness but positive
    # geometric stiffness under its self-stress: 6 zero frequencies (rigid), then all > 0
    result = stiffness(prism(3))
    assert (result.rigid, result.mechanisms, result.stiffened) == (6, 1, 1)
    assert np.all(result.frequencies[:6] < 1e-6 * result.frequencies[-1])
    assert result.frequencies[6] > 1.0  # Hz: the softest deforming mode is stiff
    # without pretension that mode is free: the seventh frequency drops to zero
    slack = dataclasses.replace(prism(3), cables=tuple(
        dataclasses.replace(c, pretension=0.0) for c in prism(3).cables))
    assert stiffness(slack).frequencies[6] < 1e-6 * result.frequencies[-1]


def test_stiffness_command_draws_the_softest_modes(tmp_path, capsys) -> None:
    from tensim.cli import main

    out = tmp_path / "stiffness"
    assert main(["design", "stiffness", "prism3", "--modes", "3", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "1 internal mechanisms, 1 of them stiffened by prestress" in text
    assert (out / "modes.png").stat().st_size > 10_000 and (out / "summary.json").exists()
