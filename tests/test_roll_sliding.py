"""Tip plans on sliding feet: the statics of a robot whose feet stand on frictionless ground
(:class:`tensim.control.rolling.RollSettings` ``sliding``), on the 3-bar written in
tests/test_roll_prism.py."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tensim.control.rolling import (
    PRISM_SETTINGS,
    _com,
    _com_jacobian,
    _sensitivity,
    heading_vector,
    plan_tip,
    support_face,
)
from tensim.design.inverse import PIN_STIFFNESS, settle, with_rest_lengths
from tensim.model import WorldOptions, compile_structure
from test_roll_prism import _prism


@pytest.fixture(scope="module")
def prism():
    compiled = compile_structure(_prism(), WorldOptions())
    return compiled.structure, compiled.rest_length.copy()


@pytest.mark.parametrize("sliding", [False, True])
def test_the_centre_of_mass_sensitivity_matches_finite_differences(prism, sliding):
    # the linearised dc/dl0 (J_c K^-1 A diag(k)) against static poses re-solved with each
    # motorised cable's rest length moved by +-1 mm
    structure, built = prism
    feet = support_face({n.name: np.asarray(n.position) for n in structure.nodes})
    explicit = with_rest_lengths(structure, built)
    lin = settle(explicit, feet, sliding=sliding)
    linear = _com_jacobian(lin) @ _sensitivity(lin, structure, sliding)
    h = 1e-3
    # within a few per cent of the largest entry: the held linearisation holds the feet
    # exactly where the re-solved poses hold them by springs of PIN_STIFFNESS (which give
    # way by about cable stiffness / PIN_STIFFNESS, 1 %), and the tangent stiffness is a
    # linearisation (1.4 % off on sliding feet, measured)
    stiffest = max(c.stiffness for c in structure.cables)
    rel = 3 * stiffest / PIN_STIFFNESS
    motorised = [i for i, c in enumerate(structure.cables) if not c.motor.passive]
    numeric = np.zeros((3, len(motorised)))
    for j, i in enumerate(motorised):
        moved = [_com(settle(with_rest_lengths(explicit, built + s * h * np.eye(len(built))[i]),
                             feet, sliding=sliding)) for s in (1, -1)]
        numeric[:, j] = (moved[0] - moved[1]) / (2 * h)
    assert np.abs(numeric).max() > 0.05  # the centre of mass moves with the cables
    assert linear[:, motorised] == pytest.approx(numeric, abs=rel * np.abs(numeric).max())


def test_a_plan_on_sliding_feet_reports_its_static_pose(prism):
    # the 3-bar toward +x: over the far side edge of the face it lies on. The plan's margin
    # and height, recomputed from the static pose its rest lengths give on sliding feet and
    # from the edge's two feet where they slid to
    structure, built = prism
    settings = dataclasses.replace(PRISM_SETTINGS, sliding=True)
    plan = plan_tip(structure, built, built, heading_vector(0.0), settings)
    assert plan.margin >= settings.margin  # reached: the planning stopped at this pose
    lin = settle(with_rest_lengths(structure, plan.rest_lengths), plan.feet, sliding=True)
    start = {n.name: np.asarray(n.position) for n in structure.nodes}
    pair = sorted(plan.feet, key=lambda f: start[f][:2] @ plan.direction)[-2:]  # outermost
    a, b = (np.asarray(lin.pose.position(f)) for f in pair)
    along = (b - a)[:2] / np.linalg.norm((b - a)[:2])
    assert abs(along @ plan.direction) < 1e-9  # the direction is the edge's normal now
    com = _com(lin)
    assert plan.margin == pytest.approx(plan.direction @ (com[:2] - a[:2]), abs=1e-9)
    lowest = min(lin.pose.position(f)[2] for f in plan.feet)
    assert plan.height == pytest.approx(com[2] - lowest, abs=1e-9)
    # with the feet held, the same travel leaves it short of that edge (its feet cannot
    # spread), which the gait then crosses only dynamically
    held = plan_tip(structure, built, built, heading_vector(0.0), PRISM_SETTINGS)
    assert held.margin < 0 < plan.margin


def test_a_plan_whose_step_leaves_no_static_pose_keeps_that_step(prism, monkeypatch):
    # the static solve fails on the plan's second step (no pose stands on these feet: the
    # robot tips there): the plan's rest lengths are that step's, one step past the last pose
    # solved, and its margin is that last pose's
    import tensim.control.rolling as rolling
    from tensim.design import DesignError

    structure, built = prism
    solved: list[np.ndarray] = []
    asked: list[np.ndarray] = []

    def failing(explicit, feet, gravity=9.81, sliding=False):
        asked.append(np.array([c.rest_length for c in explicit.cables]))
        if len(solved) == 2:  # the start pose and one step
            raise DesignError("no static pose")
        solved.append(asked[-1])
        return settle(explicit, feet, gravity, sliding=sliding)

    monkeypatch.setattr(rolling, "settle", failing)
    settings = dataclasses.replace(PRISM_SETTINGS, sliding=False)
    plan = rolling.plan_edge(structure, with_rest_lengths(structure, built),
                             failing(with_rest_lengths(structure, built), _feet(structure)),
                             built, built, _edge(structure), _feet(structure), settings)
    assert len(solved) == 2 and not np.array_equal(solved[-1], built)  # it moved, then failed
    assert np.array_equal(plan.rest_lengths, asked[-1])
    assert not np.array_equal(asked[-1], solved[-1])
    lin = settle(with_rest_lengths(structure, solved[-1]), plan.feet)
    edge = _edge(structure)
    assert plan.margin == pytest.approx(edge[:2] @ _com(lin)[:2] + edge[2], abs=1e-9)


def _feet(structure):
    return support_face({n.name: np.asarray(n.position) for n in structure.nodes})


def _edge(structure):
    from tensim.control.rolling import ahead_edges

    positions = {n.name: np.asarray(n.position) for n in structure.nodes}
    feet = _feet(structure)
    return ahead_edges(np.array([positions[f][:2] for f in feet]), feet,
                       heading_vector(0.0))[0]
