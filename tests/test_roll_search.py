"""A 3-bar's tips found in simulation (``RollSettings(search=N)``), on a prism written here.

The prism (``tests/test_roll_prism.py``'s, 1.1 m rods) pairs its six side faces into three
shallow folds (31 degrees across a hull edge that no member spans); the edges between folds
(84-91 degrees, along the passive verticals) are what a roll must get over, and statics alone
does not. The checks are geometric: where the simulated robot stands afterwards, from its
nodes, against the hull of its build pose.
"""

from __future__ import annotations

import dataclasses
from functools import partial

import numpy as np

from tensim.control.roll_plans import PlanCache, face_down_pose
from tensim.control.rolling import (
    PRISM_SETTINGS,
    folds,
    searched,
    support_face,
)
from tensim.experiments.roll import node_positions
from tensim.experiments.roll_search import WINDOW_S, search_tip
from tensim.model import WorldOptions, compile_structure
from tensim.sim import Simulation
from test_roll_prism import _prism

SETTINGS = searched(PRISM_SETTINGS)  # as `experiment roll --searched-tips` plays it


def _build(robot):
    return {n.name: np.asarray(n.position, dtype=float) for n in robot.nodes}


def test_the_prism_folds_pair_its_side_faces_across_unspanned_edges():
    robot = _prism()
    found = folds(_build(robot), 45.0)
    assert len(found) == 6  # the six side faces, none of the end triangles
    spanned = {frozenset(m.nodes) for m in (*robot.rods, *robot.cables)}
    for face, (nodes, shared) in found.items():
        assert len(nodes) == 4 and set(face) < set(nodes)
        assert frozenset(shared) not in spanned  # a fold's edge is no member
        assert {n[0] for n in shared} == {"b", "t"}
    assert len({nodes for nodes, _ in found.values()}) == 3


def _far_edge(robot):
    """A side face, its far edge (its other side edge than the fold's) and the build pose
    turned with that face down."""
    build = _build(robot)
    face, (_, shared) = sorted(folds(build, 45.0).items())[0]
    side = [tuple(sorted((a, b))) for a in face for b in face
            if a < b and {a[0], b[0]} == {"b", "t"} and {a, b} != set(shared)]
    cache = PlanCache(robot, compile_structure(robot).rest_length, SETTINGS)
    return face, side[0], face_down_pose(robot, cache.faces[face])


def test_a_searched_tip_rolls_the_prism_over_its_far_edge():
    robot = _prism()
    face, edge, pose = _far_edge(robot)
    compiled = compile_structure(pose, WorldOptions())
    built = compiled.rest_length.copy()
    search = partial(search_tip, built=built, settings=SETTINGS, world=WorldOptions())
    command = search(pose, face, edge, built)
    assert command is not None
    # replayed from the canonical pose: the robot leaves the face over that edge (it stands
    # on a face holding the edge's two nodes and a node the first face lacks) and stays
    motorised = np.array([not c.motor.passive for c in compiled.structure.cables])
    with Simulation(compiled) as sim:
        assert support_face(node_positions(sim)) == face
        sim.drive.rest_command[motorised] = command[motorised]
        sim.run(WINDOW_S)
        after = support_face(node_positions(sim))
    assert set(edge) <= set(after) and set(after) - set(face)
    # standing still with the built rest lengths is no tip: the search then finds none
    assert search(pose, face, edge, built,
                  settings=dataclasses.replace(SETTINGS, search=1)) is None


def test_cli_searched_tips_belong_to_the_statics_roll(tmp_path):
    from tensim.cli import main

    assert main(["experiment", "drag", "--searched-tips", "--out", str(tmp_path / "d")]) == 2
    assert main(["experiment", "roll", "three_bar", "--searched-tips", "--controller",
                 "three_bar_roll", "--out", str(tmp_path / "r")]) == 2


def test_the_batched_tries_are_one_simulation_per_try_bit_for_bit():
    # the search runs its tries through the batch engine; each must see what a simulation of
    # its own, commanded once it is made and looked at every control period, sees
    from tensim.control.rolling import support_edges
    from tensim.experiments.roll_search import crossings

    robot = _prism()
    face, _, pose = _far_edge(robot)
    compiled = compile_structure(pose, WorldOptions())
    built = compiled.rest_length.copy()
    motorised = np.array([not c.motor.passive for c in compiled.structure.cables])
    rng = np.random.default_rng(3)
    commands = [np.where(motorised, rng.uniform(built * 0.3, built * 1.5), built)
                for _ in range(6)]
    positions = {n.name: np.asarray(n.position, dtype=float) for n in pose.nodes}
    polygon = np.array([positions[f][:2] for f in face])
    found = []
    for line in support_edges(polygon):  # each edge of the face the tries may cross
        expected = []
        for command in commands:
            when, past = None, False
            with Simulation(compiled) as sim:
                sim.drive.rest_command[motorised] = command[motorised]
                while sim.time < WINDOW_S - 1e-9:
                    sim.run(SETTINGS.period_s)
                    past = float(line[:2] @ sim.data.subtree_com[0][:2] + line[2]) > 0
                    if when is None and past:
                        when = sim.time
            expected.append(when if past else None)
        got = crossings(compiled, commands, motorised, line, SETTINGS.period_s)
        assert got == expected
        found.extend(got)
    assert any(t is not None for t in found) and any(t is None for t in found)  # both kinds
