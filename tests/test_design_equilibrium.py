"""Self-stress and mechanism counts of tensim.design against closed forms and hand counts."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import statics
from tensim.design import DesignError, equilibrium, prestressed, residuals, self_stress
from tensim.models.prisms import prism
from tensim.models.six_bar import six_bar
from tensim.structure import Cable, Node, PointMass, Structure, load_structure


def _wrong(structure: Structure, seed: int = 0) -> Structure:
    """The same structure with pretensions drawn at random (far from any self-stress)."""
    rng = np.random.default_rng(seed)
    cables = tuple(dataclasses.replace(c, pretension=float(rng.uniform(1.0, 30.0)))
                   for c in structure.cables)
    return dataclasses.replace(structure, cables=cables)


@pytest.mark.parametrize("n", [3, 4, 5, 7])
def test_prism_force_densities_recovered_from_wrong_pretensions(n: int) -> None:
    # Closed form (derived in tensim.models.prisms' docstring, after Tibert & Pellegrino 2003):
    # for the n-prism with bottom node b_i joined by a rod to t_i and by a vertical cable to
    # t_(i-1), the top polygon twisted by pi/2 + pi/n (the mirror image of the classical
    # pi/2 - pi/n), equilibrium of b_i along z gives q_rod = -q_vertical, and in the plane
    # -4 q_polygon R sin^2(pi/n) + 2 q_vertical R sin(pi/n) = 0, so
    #     q_polygon : q_vertical : q_rod = 1 : 2 sin(pi/n) : -2 sin(pi/n).
    structure = _wrong(prism(n))
    assert max(f for f, _ in residuals(structure).values()) > 1.0  # truly wrong to start with
    stress = self_stress(structure, min_tension=5.0)
    q = stress.force_densities
    polygon, vertical = q[:2 * n], q[2 * n:]
    ratio = 2 * math.sin(math.pi / n)
    np.testing.assert_allclose(polygon, polygon[0], rtol=1e-9)  # round-off of an SVD
    np.testing.assert_allclose(vertical / polygon[0], ratio, rtol=1e-9)
    for i, rod in enumerate(prism(n).rods):
        length = structure.distance(*rod.nodes)
        assert stress.rod_forces[rod.name] / length / polygon[0] == pytest.approx(-ratio,
                                                                                   rel=1e-9), i
    assert stress.tensions.min() == pytest.approx(5.0)
    # the written structure is in equilibrium: no net cable force on any rod
    fixed = prestressed(structure, stress)
    assert max(f for f, _ in residuals(fixed).values()) < 1e-9 * stress.tensions.max()


def test_prism_counts_match_pellegrino_calladine() -> None:
    # pin-jointed count for the n-prism: 3(2n) coordinates - 4n members + s = 2n - 6 + 1
    # internal mechanisms with s = 1; the rigid-body formulation (5 DoF per rod) must agree
    for n in (3, 4, 6):
        eq = equilibrium(prism(n))
        assert (eq.s, eq.n_rigid, eq.internal_mechanisms) == (1, 6, 2 * n - 5)
        assert eq.n_dof == 5 * n and eq.rank == 3 * n - 1


def test_six_bar_has_one_self_stress_equal_to_the_pin_jointed_one() -> None:
    structure = six_bar(standing=False)  # the self-stressed form
    eq = equilibrium(structure)
    # 12 nodes x 3 - 30 members + s(=1) - 6 rigid = 1 internal mechanism (Pellegrino 1986)
    assert (eq.s, eq.m, eq.internal_mechanisms) == (1, 7, 1)
    stress = self_stress(_wrong(structure), cable=structure.cables[0].name, tension=10.0)
    _, reference = statics.self_stress(structure)  # pin-jointed force densities
    rods, cables = reference[:6], reference[6:]
    scale = stress.force_densities[0] / cables[0]
    np.testing.assert_allclose(stress.force_densities, cables * scale, rtol=1e-9)
    for rod, q in zip(structure.rods, rods, strict=True):
        assert stress.rod_forces[rod.name] == pytest.approx(q * scale * 1.0, rel=1e-9)  # 1 m


def test_under_braced_prism_has_a_finite_mechanism_and_no_self_stress(tmp_path) -> None:
    structure = prism(3)
    braced = dataclasses.replace(structure, cables=structure.cables[:-1])  # one vertical gone
    eq = equilibrium(braced)
    # hand count: 3 rods x 5 DoF = 15, 8 independent cables: m = 15 - 8 = 7 = 6 rigid + 1
    assert (eq.s, eq.rank, eq.m, eq.internal_mechanisms) == (0, 8, 7, 1)
    with pytest.raises(DesignError, match="no state of self-stress"):
        self_stress(braced, min_tension=1.0)


def _string(bend: float) -> Structure:
    """A point mass held between two fixed anchors by two cables, kinked by ``bend`` [m]."""
    nodes = (Node("a", (0.0, 0.0, 1.0), fixed=True), Node("b", (2.0, 0.0, 1.0), fixed=True),
             Node("m", (1.0, bend, 1.0)))
    cables = (Cable("left", ("a", "m"), 100.0, pretension=5.0),
              Cable("right", ("m", "b"), 100.0, pretension=5.0))
    return Structure("string", nodes, (), cables, (PointMass("m", 0.1),))


def test_straight_and_kinked_string_counts() -> None:
    # Pellegrino & Calladine's classic: a straight two-bar between supports has 1 state of
    # self-stress and 2 infinitesimal mechanisms (3 DoF, rank 1); kinked: s = 0, m = 1
    straight, kinked = equilibrium(_string(0.0)), equilibrium(_string(0.2))
    assert (straight.s, straight.m, straight.n_rigid) == (1, 2, 0)
    assert (kinked.s, kinked.m) == (0, 1)


def test_no_all_tension_state_is_refused() -> None:
    # the prism with rods and vertical cables swapped keeps its one state of self-stress, but
    # that state pushes the new vertical cables (they sit where the struts were)
    structure = prism(3)
    rods = tuple(dataclasses.replace(r, nodes=(r.nodes[0], f"t{(int(r.nodes[0][1]) - 1) % 3}"))
                 for r in structure.rods)
    cables = tuple(dataclasses.replace(c, nodes=(c.nodes[0], f"t{c.nodes[0][1]}"))
                   if "vertical" in c.tags else c for c in structure.cables)
    swapped = dataclasses.replace(structure, rods=rods, cables=cables)
    assert equilibrium(swapped).s == 1
    with pytest.raises(DesignError, match="none puts every cable in tension"):
        self_stress(swapped, min_tension=1.0)


def test_level_options() -> None:
    structure = prism(4)
    q = self_stress(structure, force_density=20.0).force_densities
    assert q.mean() == pytest.approx(20.0)
    t = self_stress(structure, cable="vertical_2", tension=7.0).tensions
    assert t[[c.name for c in structure.cables].index("vertical_2")] == pytest.approx(7.0)
    with pytest.raises(DesignError, match="unknown cable"):
        self_stress(structure, cable="nope", tension=1.0)
    with pytest.raises(DesignError, match="one prestress level"):
        self_stress(structure)


def test_prestress_command_writes_nothing_without_a_self_stress(tmp_path, capsys) -> None:
    from tensim.cli import main
    from tensim.structure import save_structure

    braced = dataclasses.replace(prism(3), cables=prism(3).cables[:-1])
    path, out = tmp_path / "braced.yaml", tmp_path / "out.yaml"
    save_structure(braced, path)
    assert main(["design", "prestress", str(path), "--min-tension", "5", "--out",
                 str(out)]) == 2
    assert "no state of self-stress" in capsys.readouterr().err
    assert not out.exists()
    save_structure(prism(3), path)
    assert main(["design", "prestress", str(path), "--cable", "top_0", "--tension", "8",
                 "--out", str(out)]) == 0
    written = self_stress(load_structure(out), cable="top_0", tension=8.0)
    assert written.tensions == pytest.approx([c.pretension for c in load_structure(out).cables])


def _twisted(structure: Structure, angle: float) -> Structure:
    """``structure`` with its top nodes (above the mean height) turned ``angle`` [rad] about z."""
    middle = np.mean([n.position[2] for n in structure.nodes])
    c, s = math.cos(angle), math.sin(angle)
    nodes = tuple(dataclasses.replace(n, position=(c * n.position[0] - s * n.position[1],
                                                   s * n.position[0] + c * n.position[1],
                                                   n.position[2]))
                  if n.position[2] > middle else n for n in structure.nodes)
    return dataclasses.replace(structure, nodes=nodes)


def test_the_rank_tolerance_tells_a_near_form_from_a_rounded_one() -> None:
    # A 3-prism turned 0.003 rad (0.17 deg) off its self-stressed twist has none: its smallest
    # singular value is 1.8e-3 of the largest, a real one (a tolerance 1000x larger counted
    # it as zero and found a self-stress that does not exist). Its coordinates written with
    # six digits leave ~1e-6: still the one self-stress.
    near = _twisted(prism(3), 0.003)
    eq = equilibrium(near)
    assert (eq.s, eq.rank) == (0, 9)
    with pytest.raises(DesignError, match=r"no state of self-stress at its build pose \(s = 0"):
        self_stress(near, min_tension=5.0)
    rounded = dataclasses.replace(prism(3), nodes=tuple(
        dataclasses.replace(n, position=tuple(round(x, 6) for x in n.position))
        for n in prism(3).nodes))
    assert equilibrium(rounded).s == 1
