"""Tip plans cached per face and edge and shared through symmetry equal the plans made afresh,
on the 3-bar written in tests/test_roll_prism.py."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tensim.control.roll_plans import PlanCache, face_down_pose, hull_faces, symmetries
from tensim.control.rolling import (
    PRISM_SETTINGS,
    RollSettings,
    heading_vector,
    plan_tip,
    support_face,
)
from tensim.experiments.roll import roll
from test_roll import DURATION, STRUT, _icosahedron
from test_roll_prism import _prism

SETTINGS = dataclasses.replace(PRISM_SETTINGS, steps=6)  # fewer statics steps: a faster test


def _built(robot):
    return np.array([robot.rest_length(c) for c in robot.cables])


def _positions(robot):
    return {n.name: np.asarray(n.position, dtype=float) for n in robot.nodes}


def test_the_prism_has_the_six_symmetries_of_a_twisted_prism():
    robot = _prism(lying=False)
    found = symmetries(robot)
    assert len(found) == 6  # 3 turns about the axis, times the half turn that swaps the ends
    assert all(a == b for a, b in found[0].nodes.items())  # the identity first
    points = _positions(robot)
    for s in found:
        for a, b in itertools.combinations(points, 2):
            assert np.linalg.norm(points[s.nodes[a]] - points[s.nodes[b]]) == pytest.approx(
                np.linalg.norm(points[a] - points[b]), abs=1e-9)
        for c, cable in enumerate(robot.cables):
            assert set(robot.cables[s.cables[c]].nodes) == {s.nodes[n] for n in cable.nodes}
    # a stiffer cable breaks every symmetry that moves it
    stiffer = dataclasses.replace(robot, cables=(
        dataclasses.replace(robot.cables[0], stiffness=2e4), *robot.cables[1:]))
    assert len(symmetries(stiffer)) == 1  # every turn and half turn moves it


def test_plans_shared_through_symmetry_equal_plans_made_on_each_face():
    robot = _prism()
    built = _built(robot)
    shared = PlanCache(robot, built, SETTINGS)
    each = PlanCache(robot, built, SETTINGS, symmetric=False)
    faces = hull_faces(_positions(robot))
    assert len(faces) == 8  # two end triangles, six side triangles
    pairs = [(feet, edge) for feet in faces for edge in itertools.combinations(feet, 2)]
    plans = {pair: shared.edge_plan(*pair) for pair in pairs}
    # 24 face-edge pairs, four plans: an end triangle's edge, a side face's two side edges and
    # its edge on an end triangle; every other pair is one of these, its cables permuted
    assert shared.made == 4
    by_orbit = {round(margin, 9): pair for pair, (_, margin) in plans.items()}
    assert len(by_orbit) == 4
    for pair in by_orbit.values():  # the last pair of each orbit: a permuted plan
        alone, alone_margin = each.edge_plan(*pair)
        np.testing.assert_allclose(plans[pair][0], alone, atol=1e-6)
        assert plans[pair][1] == pytest.approx(alone_margin, abs=1e-6)
    assert each.made == 4


def test_a_moved_robot_gets_the_plan_of_its_face_turned_with_it():
    robot = _prism()
    built = _built(robot)
    cache = PlanCache(robot, built, SETTINGS)
    feet = support_face(_positions(robot))
    lying = face_down_pose(robot, cache.faces[feet])  # the canonical pose of its face
    turn = Rotation.from_euler("z", 70, degrees=True)
    moved = dataclasses.replace(lying, nodes=tuple(
        dataclasses.replace(n, position=tuple(turn.apply(n.position) + np.array([3.0, -2.0, 0.0])))
        for n in lying.nodes))
    heading = heading_vector(70.0)  # +x turned with the robot
    cached = cache.plan(moved, built, heading)
    fresh = plan_tip(lying, built, built, heading_vector(0.0), SETTINGS)
    assert cached.feet == fresh.feet
    np.testing.assert_allclose(cached.rest_lengths, fresh.rest_lengths, atol=1e-6)
    np.testing.assert_allclose(cached.direction, turn.apply([*fresh.direction, 0.0])[:2],
                               atol=1e-6)
    assert cache.fresh == 0 and math.isfinite(cached.margin)


def test_a_face_not_of_the_build_hull_is_planned_from_where_the_robot_stands():
    robot = _prism()
    built = _built(robot)
    cache = PlanCache(robot, built, SETTINGS)
    feet = next(iter(cache.faces))
    lying = face_down_pose(robot, cache.faces[feet])
    points = _positions(lying)
    fourth = min((n for n in points if n not in feet), key=lambda n: points[n][2])
    flat = dataclasses.replace(lying, nodes=tuple(  # the fourth node pressed onto the ground
        dataclasses.replace(n, position=(*n.position[:2], 0.0)) if n.name == fourth else n
        for n in lying.nodes))
    plan = cache.plan(flat, built, heading_vector(0.0))
    assert len(plan.feet) == 4 and cache.fresh == 1 and cache.made == 0


def test_a_six_bar_rolls_on_cached_plans():
    robot = _icosahedron()
    result, summary = roll(robot, DURATION, heading_deg=0.0, settings=RollSettings(cache=True))
    ts = result.trajectory
    assert ts["pos_x/com"][-1] - ts["pos_x/com"][0] > STRUT / 4  # at least one tip's worth
    assert summary["rolls"] >= 1
    assert 1 <= summary["plans_made"] < summary["plans"]  # later faces' plans came cached
