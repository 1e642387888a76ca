"""Tangent stiffness of tensim.design against closed forms and a finite-difference Hessian."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tensim.design._bodies import bodies
from tensim.design.stiffness import stiffness
from tensim.models.prisms import prism
from tensim.structure import Cable, Node, PointMass, Rod, Structure


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


def test_rod_between_two_cables_has_the_pin_jointed_geometric_stiffness() -> None:
    # a rigid rod of length 2a on the z axis, pulled at each end by a cable of tension T and
    # length d to a fixed anchor on the axis. Pin-jointed, its ends move by +-a theta when it
    # turns by theta: the cables give T/d each across, the rod (axial force N = T) its
    # geometric stiffness N/(2a) on the ends' relative motion 2 a theta, so
    #     K_theta = 2 T a^2 / d + (T / 2a)(2a)^2 = 2 T a (a + d) / d,   K_x = 2 T / d,
    # and along the axis the rigid rod stretches one cable and eases the other: 2 k.
    a, d, k, tension = 0.25, 0.1, 500.0, 20.0
    nodes = (Node("f1", (0.0, 0.0, -d), fixed=True), Node("a", (0.0, 0.0, 0.0)),
             Node("b", (0.0, 0.0, 2 * a)), Node("f2", (0.0, 0.0, 2 * a + d), fixed=True))
    structure = Structure(
        "rod", nodes, (Rod("r", ("a", "b"), 0.01, linear_density=0.2),),
        (Cable("c1", ("f1", "a"), k, pretension=tension),
         Cable("c2", ("b", "f2"), k, pretension=tension)))
    result = stiffness(structure)
    basis = bodies(structure).basis  # translations x, y, z, then the two turns across
    matrix = basis @ result.matrix @ basis.T  # back to (v, w) of the rod's centre
    assert matrix[0, 0] == pytest.approx(2 * tension / d, rel=1e-12)
    assert matrix[2, 2] == pytest.approx(2 * k, rel=1e-12)
    assert matrix[3, 3] == pytest.approx(2 * tension * a * (a + d) / d, rel=1e-12)
    assert matrix[4, 4] == pytest.approx(2 * tension * a * (a + d) / d, rel=1e-12)
    # sideways shift and turn do not couple: the two ends' pulls cancel by symmetry
    assert abs(matrix[0, 4]) < 1e-9 * matrix[0, 0]


def test_the_growing_modes_vector_by_inverse_iteration_is_an_eigenvector():
    """The step bound names its mode from one eigenvector found by inverse iteration (not a
    full eigendecomposition): on random step-like matrices, real and complex dominant
    eigenvalues alike, it satisfies M v = lambda v to round-off, as numpy's eig's does."""
    from tensim.design.stiffness import _eigenvector

    rng = np.random.default_rng(11)
    for n in (6, 40, 200):
        for _ in range(3):
            matrix = rng.standard_normal((n, n)) / np.sqrt(n)
            values = np.linalg.eigvals(matrix)
            value = values[int(np.argmax(np.abs(values)))]
            vector = _eigenvector(matrix, value)
            assert np.isclose(np.linalg.norm(vector), 1.0)
            # 1e-8: the shift off the eigenvalue (1e-10 relative) and two iterations
            assert np.linalg.norm(matrix @ vector - value * vector) < 1e-8 * abs(value)


def _companion_flip(stiff: np.ndarray, rate: np.ndarray) -> float:
    """The flip step 2 / r from the largest real eigenvalue r of the companion matrix
    [[0, I], [K, B]] (the general method, the reference)."""
    n = len(stiff)
    roots = np.linalg.eigvals(np.block([[np.zeros((n, n)), np.eye(n)], [stiff, rate]]))
    size = np.abs(roots).max()
    real = roots.real[(np.abs(roots.imag) <= 1e-9 * size) & (roots.real > 1e-9 * size)]
    return 2 / float(real.max()) if real.size else np.inf


def test_the_flip_step_by_the_monotone_root_equals_the_companion_matrix_eigenvalues():
    """_flip_step finds the largest real root of (r^2 I - r B - K) x = 0 by a Newton iteration
    on the smallest eigenvalue of a symmetric matrix, where that is monotone; it must give the
    step the companion matrix's eigenvalues give: on random mode sets (stiffness >= 0,
    damping of either sign, as B = C - 2 D is under implicitfast), on a 4-bar prism and
    on Tetraspine3, for both integrators with a bound (every preset and the 796-cable
    centipede agree to 2e-14)."""
    from tensim.design.stiffness import _flip_step, _monotone_root, body_blocks
    from tensim.models import tetraspine3

    rng = np.random.default_rng(5)
    for n in (1, 5, 40):
        for _ in range(3):
            stiff = np.diag(rng.uniform(0, 1e4, n))
            half = rng.standard_normal((n, n)) * rng.uniform(1, 100)
            for rate in (half @ half.T / n, half @ half.T / n - 2 * np.diag(rng.uniform(0, 50, n)),
                         -(half @ half.T) / n):
                assert _monotone_root(stiff, rate) is not None  # K >= 0: always this path
                # 1e-9: the bound's stated agreement; both are exact to round-off (~1e-14)
                assert _flip_step(stiff, rate, "euler") == pytest.approx(
                    _companion_flip(stiff, rate), rel=1e-9)
    # no real root (K < 0 would need one): the companion matrix's answer, inf
    assert _monotone_root(-np.eye(3), np.zeros((3, 3))) is None
    assert _flip_step(-np.eye(3), np.zeros((3, 3)), "euler") == np.inf
    for structure in (prism(4), tetraspine3()):
        result = stiffness(structure)
        values, modes = np.linalg.eigh(np.linalg.solve(
            np.linalg.cholesky(result.mass), np.linalg.solve(
                np.linalg.cholesky(result.mass), result.matrix).T))
        lower = np.linalg.cholesky(result.mass)
        basis = np.linalg.solve(lower.T, modes)  # mass-normalised modes
        stiff = np.diag(np.clip(values, 0, None))
        damp = basis.T @ result.damping @ basis
        blocks = basis.T @ body_blocks(result) @ basis
        assert _flip_step(stiff, damp, "euler") == pytest.approx(
            _companion_flip(stiff, damp), rel=1e-9)
        assert _flip_step(stiff, damp, "implicitfast", (stiff, damp, blocks)) == pytest.approx(
            _companion_flip(stiff, damp - 2 * blocks), rel=1e-9)


def test_no_euler_step_grows_below_the_flip_root() -> None:
    """The Euler bound's proof (_proven_euler_bound): with K > 0 diagonal and C >= 0, an
    eigenvalue of the step matrix leaves the unit disc first through -1, so just below the flip
    root every eigenvalue has modulus <= 1 and just above one exceeds 1 + GROWTH_TOLERANCE. On
    random mode sets, some with undamped modes (C x = 0) and some with a damping of rank 1."""
    from tensim.design.stiffness import (
        GROWTH_TOLERANCE,
        STEP_RESOLUTION,
        _flip_step,
        step_matrix,
    )

    rng = np.random.default_rng(7)
    for n in (1, 4, 30):
        for rank in (n, 1, max(n - 2, 1)):
            stiff = np.diag(rng.uniform(1.0, 1e4, n))
            half = rng.standard_normal((n, rank)) * rng.uniform(0.1, 300)
            damp = half @ half.T / rank
            limit = _flip_step(stiff, damp, "euler")
            for factor, grows in ((1 - STEP_RESOLUTION, False), (1 + STEP_RESOLUTION, True)):
                values = np.linalg.eigvals(step_matrix(stiff, damp, np.eye(n), limit * factor))
                # GROWTH_TOLERANCE: the step bound's own threshold, far above round-off
                assert (np.abs(values).max() > 1 + GROWTH_TOLERANCE) == grows


@pytest.mark.parametrize("name", ["tetraspine3", "six_bar", "superball", "octahedral_complex"])
def test_the_proven_euler_bound_equals_the_step_matrix_eigenvalues(name: str) -> None:
    """The Euler bound without the step matrix's eigenvalues gives the bound those give: the
    same step bit for bit, and the same mode's frequency and damping ratio (to round-off: a
    symmetric robot's copies of one mode tie, and either may be named)."""
    import importlib
    from unittest import mock

    from tensim.models import preset

    module = importlib.import_module("tensim.design.stiffness")  # the package's function shadows it

    result = stiffness(preset(name).build(), count=False)
    fast = module.step_bound(result, "euler")
    with mock.patch.object(module, "_proven_euler_bound", return_value=None):
        full = module.step_bound(result, "euler")
    values, modes = module.eigh(result.matrix, result.mass)
    keep = values > 1e-9 * values.max()
    damp = (modes.T @ result.damping @ modes)[np.ix_(keep, keep)]
    assert module._proven_euler_bound(np.diag(values[keep]), damp) is not None  # proof path
    assert fast.limit == full.limit
    # 1e-12: tied copies of a mode differ in the last digits of their damping
    assert fast.frequency == pytest.approx(full.frequency, rel=1e-12)
    assert fast.damping_ratio == pytest.approx(full.damping_ratio, rel=1e-12)
