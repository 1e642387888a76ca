"""Turning in place: the rigid-hull walks against the geometry of a polyhedron rolled around a
vertex, and a six-bar written here turning in MuJoCo, measured from its own bodies."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from icosahedron import six_bar_points
from tensim.control.turning import ground, place, plan_turn, rigid_hull, tip
from tensim.experiments.roll import roll
from tensim.model import WorldOptions, compile_structure
from tensim.structure import Cable, Motor, Node, PointMass, Rod, Structure

STRUT = 1.0  # m


def _lying_six_bar(spin_deg: float) -> dict[str, np.ndarray]:
    """The symmetric six-bar's 12 nodes (struts of STRUT, parallel pairs STRUT/2 apart) turned
    so that a closed triangle of cables faces straight down, then by spin_deg about z."""
    points = six_bar_points(STRUT)
    triangle = next(t for t in itertools.combinations(points, 3)
                    if all(_is_cable(points, a, b) for a, b in itertools.combinations(t, 2)))
    down = Rotation.align_vectors([[0.0, 0.0, -1.0]],
                                  [np.mean([points[n] for n in triangle], axis=0)])[0]
    turn = Rotation.from_rotvec([0.0, 0.0, math.radians(spin_deg)]) * down
    return {n: turn.apply(p) for n, p in points.items()}


def _is_cable(points: dict[str, np.ndarray], a: str, b: str) -> bool:
    return abs(float(np.linalg.norm(points[a] - points[b])) - STRUT * math.sqrt(6) / 4) < 1e-9


def _corner_angle(points: dict[str, np.ndarray], at: str, a: str, b: str) -> float:
    u, v = points[a] - points[at], points[b] - points[at]
    return math.acos(float(u @ v / np.linalg.norm(u) / np.linalg.norm(v)))


def test_a_walk_around_a_vertex_turns_by_its_angle_defect():
    # rolled once around a vertex, a polyhedron lands on its first face turned about the
    # vertical through that vertex by the vertex's angle defect (2 pi less its face angles)
    points = _lying_six_bar(spin_deg=20.0)
    com = np.mean(list(points.values()), axis=0)  # equal struts: the centre is the centroid
    hull = rigid_hull(points, com)
    start = place(hull, points)
    plan = plan_turn(hull, start, start, math.radians(60.0), STRUT)
    assert plan is not None and len(plan.walk) == 5  # five faces meet at each vertex
    pivots = set.intersection(*({a, b} for a, b, _ in plan.walk))
    assert len(pivots) == 1
    pivot = hull.names[pivots.pop()]
    # the faces around the pivot: hull triangles through it, by the positions alone
    angles = []
    for face in hull.faces:
        names = [hull.names[i] for i in face]
        if pivot in names:
            a, b = (n for n in names if n != pivot)
            angles.append(_corner_angle(points, pivot, a, b))
    defect = 2 * math.pi - sum(angles)
    assert len(angles) == 5 and defect == pytest.approx(math.pi / 3, abs=1e-9)  # 4 pi / 12
    assert plan.yaw == pytest.approx(defect, abs=1e-9)
    end = start
    for a, b, face in plan.walk:
        end = tip(hull, end, a, b, face)
    assert end.face == start.face
    # every node ends where the turn about the pivot's vertical puts it (x, y)
    c, s = math.cos(defect), math.sin(defect)
    turned = (hull.points[:, :2] - points[pivot][:2]) @ np.array([[c, -s], [s, c]]).T \
        + points[pivot][:2]
    np.testing.assert_allclose(ground(hull, end, hull.points), turned, atol=1e-9)
    # so the centre of mass moves 2 d sin(defect / 2), d its distance from the pivot
    d = float(np.linalg.norm(com[:2] - points[pivot][:2]))
    moved = float(np.linalg.norm(ground(hull, end, com[None])[0] - com[:2]))
    assert moved == pytest.approx(2 * d * math.sin(defect / 2), abs=1e-9)


def test_place_recovers_a_known_yaw_and_offset():
    points = _lying_six_bar(spin_deg=0.0)
    hull = rigid_hull(points, np.mean(list(points.values()), axis=0))
    start = place(hull, points)
    yaw, offset = 0.7, np.array([0.3, -1.2])  # rad, m
    c, s = math.cos(yaw), math.sin(yaw)
    moved = {n: np.array([c * p[0] - s * p[1] + offset[0], s * p[0] + c * p[1] + offset[1],
                          p[2]]) for n, p in points.items()}
    now = place(hull, moved)
    assert now.face == start.face
    assert math.remainder(now.yaw - start.yaw - yaw, 2 * math.pi) == pytest.approx(0, abs=1e-9)
    np.testing.assert_allclose(ground(hull, now, hull.points),
                               np.array([moved[n][:2] for n in hull.names]), atol=1e-9)


def test_two_walks_around_two_vertices_turn_twice_as_far_near_the_start():
    # 120 degrees: two vertices' defects, their turns' displacements nearly cancelling
    points = _lying_six_bar(spin_deg=0.0)
    hull = rigid_hull(points, np.mean(list(points.values()), axis=0))
    start = place(hull, points)
    plan = plan_turn(hull, start, start, math.radians(-120.0), STRUT)
    assert plan is not None and len(plan.walk) == 10
    assert plan.yaw == pytest.approx(-2 * math.pi / 3, abs=1e-9)
    end = start
    for a, b, face in plan.walk:
        end = tip(hull, end, a, b, face)
    com = hull.com[None]
    assert float(np.linalg.norm(ground(hull, end, com) - ground(hull, start, com))) < 0.1 * STRUT


def _robot(spin_deg: float) -> Structure:
    """A motorised six-bar lying on a closed triangle: 1 m struts of 0.2 kg/m with 0.05 kg end
    caps (radius 2 cm), 24 cables of 500 N/m at 15 N, motors 0.2 m/s."""
    points = _lying_six_bar(spin_deg)
    lift = 0.022 - min(p[2] for p in points.values())
    nodes = tuple(Node(n, tuple(p + np.array([0.0, 0.0, lift]))) for n, p in points.items())
    rods = tuple(Rod(f"rod_{a}{k}", (f"{a}{k}0", f"{a}{k}1"), 0.01, linear_density=0.2,
                     friction=1.0) for a in "xyz" for k in (0, 1))
    cables = tuple(Cable(f"c_{a}_{b}", (a, b), 500.0, damping=5.0, pretension=15.0,
                         motor=Motor(max_speed=0.2, max_tension=500.0))
                   for a, b in itertools.combinations(points, 2) if _is_cable(points, a, b))
    masses = tuple(PointMass(n, 0.05, 0.02) for n in points)
    return Structure("lying_six_bar", nodes, rods, cables, masses)


def test_a_six_bar_turns_in_place_measured_from_its_bodies():
    """One start that turns cleanly (the runs are chaotic: over starts the figures scatter,
    docs/rolling.md). Torsional friction at the feet (condim 4: end caps touch on a patch, not
    a point) keeps a pivoting foot from spinning freely."""
    robot = _robot(spin_deg=41.0)
    world = WorldOptions(condim=4)
    result, summary = roll(robot, 15.0, turn_deg=60.0, world=world)
    assert summary["duration_s"] < 15.0  # it stopped: turned
    ts = result.trajectory
    # independent figures: the centre of mass from MjData's recording, the yaw from each
    # rod's axis (its body frame), which on the first face again all turned alike
    moved = math.hypot(ts["pos_x/com"][-1] - ts["pos_x/com"][0],
                       ts["pos_y/com"][-1] - ts["pos_y/com"][0])
    assert moved < 0.5 * STRUT  # the goal: within half a body length
    assert summary["displacement_m"] == pytest.approx(moved, abs=1e-6)
    compiled = compile_structure(robot, world)
    local, body = compiled.index.node_local, compiled.index.node_body
    yaws = []
    for rod in robot.rods:
        axis = local[rod.nodes[1]] - local[rod.nodes[0]]  # in the rod body's frame
        name = compiled.model.body(body[rod.nodes[0]]).name
        (x0, y0), (x1, y1) = (
            Rotation.from_quat([ts[f"quat_{a}/{name}"][k] for a in "wxyz"],
                               scalar_first=True).apply(axis)[:2] for k in (0, -1))
        yaws.append(math.degrees(math.atan2(x0 * y1 - y0 * x1, x0 * x1 + y0 * y1)))
    assert np.ptp(yaws) < 10.0  # a rotation about the vertical: every rod turned alike
    assert float(np.median(yaws)) == pytest.approx(60.0, abs=15.0)
    assert summary["yaw_deg"] == pytest.approx(float(np.median(yaws)), abs=5.0)
