"""Cables that wrap around rods: MuJoCo's cylinder wrapping against the closed-form
tangent-arc-tangent path, the force it puts on the rod, and the cable law on the wrapped
length."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensim.model import ModelError, WorldOptions, compile_structure
from tensim.sim import Simulation
from tensim.structure import (
    Cable,
    Node,
    PointMass,
    Rod,
    Structure,
    StructureError,
    structure_from_dict,
    structure_to_dict,
)

R = 0.05  # rod radius [m]
K = 100.0  # cable stiffness [N/m]


def _over_rod(a_xz, b_xz, *, fixed_rod: bool = True, rest: float = 0.5, side=()) -> Structure:
    """A rod along y through the origin; a cable from A to B (fixed, in the xz plane) over it."""
    return Structure(
        "wrap",
        (Node("a", (a_xz[0], 0.0, a_xz[1]), fixed=True),
         Node("b", (b_xz[0], 0.0, b_xz[1]), fixed=True),
         Node("r0", (0.0, -0.2, 0.0), fixed=fixed_rod),
         Node("r1", (0.0, 0.2, 0.0), fixed=fixed_rod)),
        rods=(Rod("bar", ("r0", "r1"), R, linear_density=0.5),),
        cables=(Cable("c", ("a", "b"), K, rest_length=rest, wrap=("bar",), side=side),),
    )


def _tangent_arc_tangent(a, b) -> float:
    """Length of the shortest path from A over the top of the circle |p| = R to B (a, b left
    and right of it, both outside it)."""
    da, db = math.hypot(*a), math.hypot(*b)
    # angles from +x toward +z: A's in (0, 2 pi) (left, over the top), B's in (-pi, pi] (right)
    phi_a, phi_b = math.atan2(a[1], a[0]) % (2 * math.pi), math.atan2(b[1], b[0])
    arc = (phi_a - math.acos(R / da)) - (phi_b + math.acos(R / db))
    return math.sqrt(da**2 - R**2) + math.sqrt(db**2 - R**2) + R * arc


def _forward(structure: Structure) -> tuple:
    compiled = compile_structure(structure, WorldOptions(ground=False, gravity=(0, 0, 0)))
    data = mujoco.MjData(compiled.model)
    mujoco.mj_forward(compiled.model, data)
    return compiled, data


@pytest.mark.parametrize(("a", "b"), [((-0.5, 0.02), (0.4, 0.01)),
                                      ((-0.3, 0.04), (0.2, -0.02)),
                                      ((-0.6, 0.03), (0.5, -0.04))])
def test_a_wrapped_cable_has_the_tangent_arc_tangent_length(a, b):
    _, data = _forward(_over_rod(a, b))
    straight = math.dist(a, b)
    # without a side site MuJoCo takes the shorter way round: over the top or under the bottom
    expected = min(_tangent_arc_tangent(a, b),
                   _tangent_arc_tangent((a[0], -a[1]), (b[0], -b[1])))
    assert expected > straight + 1e-4  # the rod is in the way: the wrap is not trivial
    assert data.ten_length[0] == pytest.approx(expected, abs=1e-12)


def test_the_rod_feels_the_vector_sum_of_the_two_tensions():
    a, b = (-0.5, 0.02), (0.4, 0.01)
    with Simulation(compile_structure(_over_rod(a, b, fixed_rod=False), WorldOptions(
            ground=False, gravity=(0, 0, 0)))) as sim:
        m, d = sim.model, sim.data
        mujoco.mj_setState(m, d, m.key_qpos[0], mujoco.mjtState.mjSTATE_QPOS)
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)
        tension = K * (d.ten_length[0] - d.act[0])
        points = d.wrap_xpos.reshape(-1, 3)[d.ten_wrapadr[0]:d.ten_wrapadr[0] + 4]
        # the two straight spans pull the rod from its tangent points toward the anchors
        pull = sum((anchor - tangent) / np.linalg.norm(anchor - tangent)
                   for anchor, tangent in ((points[0], points[1]), (points[3], points[2])))
        mass = m.body_mass[m.geom_bodyid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "bar")]]
        assert tension > 1.0
        np.testing.assert_allclose(mass * d.qacc[:3], tension * pull, rtol=1e-9, atol=1e-12)


def test_the_law_acts_on_the_wrapped_length():
    a, b = (-0.5, 0.02), (0.4, 0.01)
    with Simulation(compile_structure(_over_rod(a, b, rest=0.85), WorldOptions(
            ground=False, gravity=(0, 0, 0)))) as sim:
        assert sim.drive.tension[0] == pytest.approx(K * (_tangent_arc_tangent(a, b) - 0.85),
                                                     abs=1e-9)


def test_wrap_round_trips_and_bad_wraps_are_refused():
    s = _over_rod((-0.5, 0.02), (0.4, 0.01))
    assert structure_from_dict(structure_to_dict(s)) == s
    data = structure_to_dict(s)
    with pytest.raises(StructureError, match="unknown rod"):
        structure_from_dict({**data, "cables": [{**data["cables"][0], "wrap": ["nope"]}]})
    with pytest.raises(StructureError, match="needs rest_length"):
        Cable("c", ("a", "b"), K, pretension=5.0, wrap=("bar",))
    with pytest.raises(StructureError, match="not both"):
        Cable("c", ("a", "b"), K, rest_length=0.5, wrap=("bar",), via=("r0",))
    with pytest.raises(StructureError, match="anchored"):
        Structure("w", s.nodes, rods=s.rods,
                  cables=(Cable("c", ("a", "r0"), K, rest_length=0.5, wrap=("bar",)),))


def test_the_drawing_follows_the_wrapped_path():
    from tensim.viz.cables import CableArtist

    compiled, data = _forward(_over_rod((-0.5, 0.02), (0.4, 0.01)))
    path = CableArtist(compiled)._path(data, 0)
    assert path.shape == (4, 3)  # anchor, two tangent points on the rod, anchor
    np.testing.assert_allclose(np.hypot(path[1:3, 0], path[1:3, 2]), R, rtol=1e-9)


def _pulley(l1: float, l2: float, *, mass: float = 1.0, side=()) -> Structure:
    """A fixed rod along y through the origin; a mass hangs from each end of a cable over it,
    each straight below its tangent point (the straight line between them misses the rod)."""
    weight = mass * 9.81
    return Structure(
        "pulley",
        (Node("a", (-R, 0.0, -l1)), Node("b", (R, 0.0, -l2)),
         Node("r0", (0.0, -0.2, 0.0), fixed=True), Node("r1", (0.0, 0.2, 0.0), fixed=True)),
        rods=(Rod("bar", ("r0", "r1"), R, linear_density=0.5),),
        point_masses=(PointMass("a", mass, 0.01), PointMass("b", mass, 0.01)),
        cables=(Cable("c", ("a", "b"), 1000.0, damping=20.0, wrap=("bar",), side=side,
                      rest_length=l1 + l2 + math.pi * R - weight / 1000.0),),
    )


@pytest.mark.parametrize("side", [(), ((0.0, 0.0, 1.0),)])
def test_a_cable_over_a_pulley_wraps_and_holds_two_equal_masses(side):
    l1, l2 = 0.3, 0.5
    structure = _pulley(l1, l2, side=side)
    with Simulation(compile_structure(structure, WorldOptions(ground=False))) as sim:
        # wrapped at build: tangent, half a turn, tangent
        assert sim.data.ten_length[0] == pytest.approx(l1 + l2 + math.pi * R, abs=1e-9)
        sim.run(1.0)
        # each mass hangs at m g tension and stays where it was built
        assert sim.drive.tension[0] == pytest.approx(9.81, rel=1e-3)
        z = sim.data.xpos[[sim.compiled.index.node_body[n] for n in "ab"], 2]
        np.testing.assert_allclose(z, [-l1, -l2], atol=1e-4)
        assert sim.data.ten_length[0] == pytest.approx(l1 + l2 + math.pi * R, abs=2e-4)


def test_a_pulley_wrap_holds_its_side_as_the_masses_move():
    # unequal masses: the heavier one goes down, the cable stays over the top, its wrapped
    # length is the tangents plus half a turn, and the tension is 2 m1 m2 g / (m1 + m2)
    structure = _pulley(0.3, 0.3)
    b = structure.point_masses[1]
    structure = dataclasses.replace(structure, point_masses=(
        structure.point_masses[0], dataclasses.replace(b, mass=2.0)))
    with Simulation(compile_structure(structure, WorldOptions(ground=False))) as sim:
        sim.run(0.2)
        za, zb = sim.data.xpos[[sim.compiled.index.node_body[n] for n in "ab"], 2]
        assert zb < -0.3 - 0.01 and za > -0.3 + 0.01
        assert sim.data.ten_length[0] == pytest.approx(-za - zb + math.pi * R, abs=2e-3)
        assert sim.drive.tension[0] == pytest.approx(2 * 1 * 2 * 9.81 / 3, rel=0.05)


@pytest.mark.parametrize(("a", "b", "match"), [
    ((-0.3, 0.0), (0.3, 0.0), "too near its axis"),  # through the axis: either way as short
    ((-0.3, R), (0.3, R), "too near its surface"),  # touching: wrapped or clear?
    ((-0.01, 0.0), (0.3, 0.1), "within its radius"),  # an anchor inside the rod
])
def test_a_wrap_whose_side_cannot_be_decided_is_refused(a, b, match):
    with pytest.raises(StructureError, match=match):
        _over_rod(a, b)
    # a side given decides it
    s = _over_rod((-0.3, 0.0), (0.3, 0.0), side=((0, 0, -1),))
    assert s.wrap_sides(s.cables[0])[0][1] == pytest.approx([0, 0, -1])


@pytest.mark.parametrize(("side", "match"), [
    (((0, 1, 0),), "along the rod's axis"), (((0, 0, 0),), "non-zero"),
    (((0, 0, 1), (0, 0, 1)), "one per rod"), ("up", "list of directions"),
    (((0, "x", 1),), "finite numbers"), (((0, math.nan, 1),), "finite numbers"),
    (((0, 0),), "three numbers")])
def test_bad_sides_are_refused(side, match):
    with pytest.raises(StructureError, match=match):
        _over_rod((-0.5, 0.02), (0.4, 0.01), side=side)


def test_side_round_trips_through_yaml():
    import yaml

    s = _over_rod((-0.5, 0.02), (0.4, 0.01), side=((0.0, 0.0, 1.0),))
    assert structure_from_dict(yaml.safe_load(yaml.safe_dump(structure_to_dict(s)))) == s


def test_a_wrap_mujoco_would_run_straight_is_refused():
    # more than half a turn from a line clear of the rod: MuJoCo's side choice drops the wrap
    s = _pulley(0.7, 0.1)
    s = dataclasses.replace(s, nodes=(Node("a", (-R + 0.03, 0.0, -0.7)),
                                      Node("b", (R - 0.015, 0.0, -0.1)), *s.nodes[2:]))
    with pytest.raises(ModelError, match="does not wrap it over rod 'bar'"):
        compile_structure(s, WorldOptions(ground=False))


@settings(max_examples=150, derandomize=True, database=None, deadline=None)
@given(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0),
       st.sampled_from([(), ((0.0, 0.0, 1.0),), ((1.0, 0.0, -1.0),), ((0.0, 1.0, 0.0),)]))
def test_any_wrap_is_refused_or_wraps_on_its_side_in_the_build_pose(ax, az, bx, bz, side):
    # a cable from A to B (anywhere around the rod) is refused with tensim's errors, or
    # compiles into a tendon that wraps the rod on its side in the build pose, or runs
    # straight past it where it is clear of the rod on the side given: never the wrong way
    try:
        structure = _over_rod((ax, az), (bx, bz), side=side)
        _, data = _forward(structure)
    except (StructureError, ModelError):
        return
    _, direction, touches = structure.wrap_sides(structure.cables[0])[0]
    if not touches:
        assert side and data.ten_wrapnum[0] == 2
        assert data.ten_length[0] == pytest.approx(math.dist((ax, az), (bx, bz)), abs=1e-12)
        return
    assert data.ten_wrapnum[0] == 4  # anchor, two tangent points on the rod, anchor
    points = data.wrap_xpos.reshape(-1, 3)[1:3]
    np.testing.assert_allclose(np.hypot(points[:, 0], points[:, 2]), R, rtol=1e-9)
    # the arc between the tangent points runs over the side the wrap was given (or decided):
    # the tendon's length is the two tangents and that arc
    t1, t2, d = (math.atan2(p[2], p[0]) for p in (*points, direction))
    ccw = (t2 - t1) % (2 * math.pi)
    arc = ccw if (d - t1) % (2 * math.pi) <= ccw else 2 * math.pi - ccw
    tangents = math.dist((ax, az), points[0, [0, 2]]) + math.dist((bx, bz), points[1, [0, 2]])
    assert data.ten_length[0] == pytest.approx(tangents + R * arc, abs=1e-9)
