"""The n-prisms, SUPERball and the complex spines: self-stress, masses, shapes, standing still.

Self-stress is checked independently of how the presets compute it: by the null space of the
equilibrium matrix (an SVD) for the pin-jointed forms, and by summing every cable's pull on
each rigid vertebra for the spines.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from statics import self_stress
from tensim.model import WorldOptions, compile_structure
from tensim.models import (
    octahedral_complex,
    prism,
    prism3,
    prism4,
    prism5,
    superball,
    tetrahedral_complex,
)
from tensim.sim import simulate
from tensim.structure import Structure

ZERO_G = WorldOptions(gravity=(0.0, 0.0, 0.0), ground=False)


def _moved(compiled, duration: float) -> float:
    """Largest node displacement [m] over ``duration`` seconds from the build pose."""
    ts = simulate(compiled, duration, record_dt=duration).trajectory
    moved = 0.0
    for group in compiled.structure.rigid_groups():
        poses = []
        for k in (0, -1):
            rot = np.zeros(9)
            mujoco.mju_quat2Mat(rot, np.array([ts[f"quat_{a}/{group.name}"][k] for a in "wxyz"]))
            pos = np.array([ts[f"pos_{a}/{group.name}"][k] for a in "xyz"])
            poses.append((pos, rot.reshape(3, 3)))
        for node in group.nodes:
            local = compiled.index.node_local[node]
            (p0, r0), (p1, r1) = poses
            moved = max(moved, float(np.linalg.norm(p1 + r1 @ local - p0 - r0 @ local)))
    return moved


@pytest.mark.parametrize("n", [4, 5, 6])
def test_prism_pretensions_are_its_state_of_self_stress(n):
    s = prism(n)
    _, q = self_stress(s)
    n_rods = len(s.rods)
    lengths = np.array([s.distance(*r.nodes) for r in s.rods]
                       + [s.distance(*c.nodes) for c in s.cables])
    forces = q * lengths
    pretension = np.array([c.pretension for c in s.cables])
    scale = forces[n_rods:] @ pretension / (forces[n_rods:] @ forces[n_rods:])
    assert np.all(scale * forces[n_rods:] > 0) and np.all(scale * forces[:n_rods] < 0)
    np.testing.assert_allclose(pretension, scale * forces[n_rods:], rtol=1e-9)  # rounding
    # and its twist is the textbook one: 90 + 180/n degrees between the polygons
    b0, t0 = s.position("b0"), s.position("t0")
    assert math.degrees(math.atan2(t0[1], t0[0]) - math.atan2(b0[1], b0[0])) == \
        pytest.approx(90.0 + 180.0 / n)


def test_prism_generalises_prism3():
    three, reference = prism(3), prism3()
    for a, b in zip(three.nodes, reference.nodes, strict=True):
        np.testing.assert_allclose(a.position, b.position, atol=1e-15)  # same formulas
    assert [c.nodes for c in three.cables] == [c.nodes for c in reference.cables]
    np.testing.assert_allclose([c.pretension for c in three.cables],
                               [c.pretension for c in reference.cables], rtol=1e-14)


@pytest.mark.parametrize("build", [prism4, prism5, lambda: superball(standing=False)],
                         ids=["prism4", "prism5", "superball"])
def test_self_stressed_form_holds_in_zero_gravity(build):
    # an equilibrium up to rounding stays put; a wrong pretension moves nodes by millimetres
    assert _moved(compile_structure(build(), ZERO_G), 1.0) < 1e-9


def test_superball_scale():
    s = superball(clearance=0.01, standing=False)  # the form, before it settles
    lengths = {round(s.distance(*r.nodes), 12) for r in s.rods}
    assert lengths == {1.684}
    # a strut of 16.84 dm, radius 0.31 dm, 0.688 kg/dm^3 (the toolkit's model): 3.50 kg
    strut = 0.688 * math.pi * 0.31**2 * 16.84
    assert strut == pytest.approx(3.50, abs=0.005)
    assert s.total_mass() == pytest.approx(6 * strut, rel=1e-12)
    compiled = compile_structure(s)
    assert compiled.model.body_mass[1:].sum() == pytest.approx(6 * strut, rel=1e-12)
    # equal pretension in all 24 cables is this form's self-stress (one per cable: no rod sign)
    _, q = self_stress(s)
    cables = q[6:] * np.array([s.distance(*c.nodes) for c in s.cables])
    np.testing.assert_allclose(cables / cables[0], 1.0, rtol=1e-9)
    assert min(s.position(n.name)[2] for n in s.nodes) - 0.031 == pytest.approx(0.01)


def _vertebra_wrenches(s: Structure) -> dict[str, np.ndarray]:
    """Net force and moment (about the origin) of every cable's pretension on each vertebra."""
    body = {node: g.name for g in s.rigid_groups() for node in g.nodes}
    wrench = {g.name: np.zeros(6) for g in s.rigid_groups()}
    for cable in s.cables:
        a, b = s.anchors(cable)
        for point, toward, node in ((a, b, cable.nodes[0]), (b, a, cable.nodes[1])):
            force = cable.pretension * (toward - point) / np.linalg.norm(toward - point)
            wrench[body[node]] += np.concatenate([force, np.cross(point, force)])
    return wrench


@pytest.mark.parametrize(("build", "rods"), [(tetrahedral_complex, 4), (octahedral_complex, 6)])
def test_complex_spine_shape_and_self_stress(build, rods):
    s = build(5)
    groups = s.rigid_groups()
    assert [g.name for g in groups] == [f"segment_{i}" for i in range(5)]
    assert len(s.cables) == 8 * 4  # eight cables per joint
    for i, group in enumerate(groups):
        assert len(group.rods) == rods
        centre = s.position(f"s{i}_centre")
        tips = [n for n in group.nodes if n != f"s{i}_centre"]
        # every rod runs from the centre, all 0.1 m x sqrt(3) (tetra) or 0.1 m (octa) long
        length = 0.1 * math.sqrt(3) if rods == 4 else 0.1
        np.testing.assert_allclose([np.linalg.norm(s.position(t) - centre) for t in tips],
                                   length, rtol=1e-12)
        directions = np.array([s.position(t) - centre for t in tips]) / length
        # the rods point along the vertex directions: sum zero, pairwise cosines -1/3 or 0/-1
        np.testing.assert_allclose(directions.sum(axis=0), 0.0, atol=1e-12)
        cosines = np.round(directions @ directions.T, 9)
        allowed = {1.0, -1 / 3} if rods == 4 else {1.0, 0.0, -1.0}
        assert set(np.round(cosines.ravel(), 6)) <= {round(c, 6) for c in allowed}
    # every vertebra is balanced by its cables' pretensions (force and moment), 10 N at most
    for name, wrench in _vertebra_wrenches(s).items():
        np.testing.assert_allclose(wrench, 0.0, atol=1e-12, err_msg=name)  # rounding
    pretension = np.array([c.pretension for c in s.cables])
    assert pretension.max() == pytest.approx(10.0) and pretension.min() > 3.0
    # the vertebrae interleave without touching: no contact at the build pose
    compiled = compile_structure(s, ZERO_G)
    data = mujoco.MjData(compiled.model)
    mujoco.mj_forward(compiled.model, data)
    assert data.ncon == 0
    assert _moved(compiled, 1.0) < 1e-9
