"""The rolling gait on a 3-bar written here, the rigid-hull tip and yaw, and turning in place.

The prism lies with its long axis along y, so that it rolls along x (across the axis), the
way a 3-bar rolls.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from tensim.control.rolling import (
    PRISM_SETTINGS,
    RollSettings,
    default_settings,
    rocks_back,
    support_edges,
    tip_rotation,
    yaw_between,
)
from tensim.experiments.roll import roll, turn_summary
from tensim.sim import TimeSeries
from tensim.structure import PASSIVE, Cable, Motor, Node, Rod, Structure

RADIUS, HEIGHT = 0.5, 0.98  # m: the end triangles' circumradius, the prism's height
DURATION = 6.0  # s: a few rolls (some rock back)


def _prism(turn_deg: float = 90.0, q: float = 150.0, lying: bool = True) -> Structure:
    """A 3-bar prism of 1.1 m, 3.3 kg rods: rods b_i-t_i, the top triangle turned 150 degrees,
    six motorised end cables and three passive verticals of 10 kN/m in self-stress (force
    density q in the triangles, q sqrt(3) in the verticals). Standing on its bottom triangle,
    or (``lying``) laid down with its long axis along y, so that it rolls along x."""
    pos = {}
    for i in range(3):
        a = math.radians(turn_deg + 120 * i)
        pos[f"b{i}"] = np.array([RADIUS * math.cos(a), RADIUS * math.sin(a), 0.0])
        a += math.radians(150)
        pos[f"t{i}"] = np.array([RADIUS * math.cos(a), RADIUS * math.sin(a), HEIGHT])
    if lying:  # turn -90 degrees about x: the axis along +y
        pos = {n: np.array([p[0], p[2], -p[1]]) for n, p in pos.items()}
    lift = 0.04 - min(p[2] for p in pos.values())
    pos = {n: p + np.array([0.0, 0.0, lift]) for n, p in pos.items()}
    nodes = [Node(n, tuple(float(x) for x in p)) for n, p in pos.items()]
    rods = tuple(Rod(f"bar{i}", (f"b{i}", f"t{i}"), 0.02, linear_density=3.0) for i in range(3))
    motor = Motor(max_speed=0.5, max_tension=2000.0, min_rest_length=0.1)
    cables = [Cable(f"{e}_{i}", (f"{e}{i}", f"{e}{(i + 1) % 3}"), 10_000.0, damping=50.0,
                    pretension=q * float(np.linalg.norm(pos[f"{e}{i}"] - pos[f"{e}{(i + 1) % 3}"])),
                    motor=motor) for e in "bt" for i in range(3)]
    cables += [Cable(f"v_{i}", (f"b{i}", f"t{(i + 2) % 3}"), 10_000.0, damping=50.0,
                     pretension=q * math.sqrt(3) * float(np.linalg.norm(
                         pos[f"b{i}"] - pos[f"t{(i + 2) % 3}"])), motor=PASSIVE)
               for i in range(3)]
    return Structure("test_prism", tuple(nodes), rods, tuple(cables))


@pytest.fixture(scope="module")
def runs() -> dict[float, tuple]:
    robot = _prism()
    return {heading: roll(robot, DURATION, heading_deg=heading) for heading in (0.0, 180.0)}


def test_a_3bar_gets_the_prism_settings():
    assert default_settings(_prism()) == PRISM_SETTINGS
    assert PRISM_SETTINGS.settle_s == 0.0 and PRISM_SETTINGS.shorten > RollSettings().shorten


def test_a_3bar_rolls_both_ways_along_x(runs):
    length = HEIGHT  # about the rod length; a tip carries the centre about a fifth of it
    for heading, sign in ((0.0, 1.0), (180.0, -1.0)):
        result, summary = runs[heading]
        ts = result.trajectory
        dx = ts["pos_x/com"][-1] - ts["pos_x/com"][0]
        assert sign * dx > length / 4  # more than one tip along the heading
        assert summary["distance_m"] == pytest.approx(sign * dx, abs=1e-6)
        assert summary["heading_error_deg"] < 30.0
        assert summary["rolls"] >= 2
        assert 0 <= summary["rocks_back"] <= summary["rolls"] - 1
        assert 0 < summary["first_roll_s"] < DURATION


def test_rocks_back_counts_returns_to_the_face_before():
    a, b, c, d = ("a",), ("b",), ("c",), ("d",)
    assert rocks_back([]) == rocks_back([a]) == rocks_back([a, b]) == 0
    # a-b-a and b-a-b are rocks; b-c, c-d and the rest get on
    assert rocks_back([a, b, a, b, c, d, c]) == 3
    assert rocks_back([a, b, c, d]) == 0


def test_the_pump_lets_go_swinging_back_and_pulls_swinging_forward():
    from types import SimpleNamespace

    from tensim.control.rolling import TipPlan
    from tensim.experiments.roll import PUMP_HOLD_S, _Gait

    built, planned = np.array([1.0, 1.0, 2.0]), np.array([0.7, 1.2, 2.0])
    motorised = np.array([True, True, False])
    gait = _Gait(_prism(), built, motorised, RollSettings(pump=True, settle_s=0.0), 0.0, None,
                 np.zeros(2), 1.0, pushing=True,
                 plan=TipPlan(planned, ("b0",), np.array([1.0, 0.0]), -0.1))
    sim = SimpleNamespace(drive=SimpleNamespace(rest_command=planned.copy()))
    gait._pump(sim, -0.1, PUMP_HOLD_S / 2)  # held too briefly to let go
    assert np.array_equal(sim.drive.rest_command, planned)
    gait._pump(sim, 0.1, PUMP_HOLD_S)  # still swinging toward the edge: keep pulling
    assert np.array_equal(sim.drive.rest_command, planned)
    gait._pump(sim, -0.1, PUMP_HOLD_S)  # swinging back: let go (motorised cables only)
    assert np.array_equal(sim.drive.rest_command, built) and gait.released
    gait._pump(sim, -0.1, PUMP_HOLD_S + 0.05)
    assert np.array_equal(sim.drive.rest_command, built)
    gait._pump(sim, 0.1, PUMP_HOLD_S + 0.1)  # toward the edge again: pull
    assert np.array_equal(sim.drive.rest_command, planned) and not gait.released


def test_tip_rotation_lays_a_box_on_its_side():
    # a 1 x 2 x 0.5 box tipped over its +x edge lies on its 0.5 x 2 face, spanning x 0.5..1
    corners = np.array(list(itertools.product((-0.5, 0.5), (-1.0, 1.0), (0.0, 0.5))))
    feet = corners[corners[:, 2] == 0.0]
    edge = next(e for e in support_edges(feet[:, :2]) if e[0] > 0.5)
    rotation, anchor = tip_rotation(corners, feet, edge)
    landed = (corners - anchor) @ rotation.T + anchor
    assert np.allclose(sorted(set(np.round(landed[:, 0], 9))), [0.5, 1.0])
    assert np.allclose(sorted(set(np.round(landed[:, 2], 9))), [0.0, 1.0])
    assert np.allclose(rotation @ rotation.T, np.eye(3))


def _yawed(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T


@pytest.mark.parametrize("angle_deg", [-150.0, -30.0, 0.0, 75.0, 179.0])
def test_yaw_between_recovers_a_rotation_about_z(angle_deg):
    points = np.random.default_rng(1).normal(size=(6, 3))
    moved = _yawed(points, math.radians(angle_deg)) + np.array([3.0, -1.0, 0.2])
    assert math.degrees(yaw_between(points, moved)) == pytest.approx(angle_deg, abs=1e-9)


def test_turn_summary_from_the_bodies_paths():
    # three bodies (centres and frames) turned by 40 degrees about the centre, then moved
    # 0.3 m along y
    start = np.array([[1.0, 0.0, 0.5], [-0.5, 0.8, 0.5], [-0.5, -0.8, 0.5]])
    end = _yawed(start, math.radians(40.0)) + np.array([0.0, 0.3, 0.0])
    channels = {f"pos_{a}/bar{b}": np.array([start[b, i], end[b, i]])
                for b in range(3) for i, a in enumerate("xyz")}
    half = math.radians(40.0) / 2  # each body's frame turns with the set
    for b in range(3):
        for a, q in zip("wxyz", ((1.0, math.cos(half)), (0.0, 0.0), (0.0, 0.0),
                                 (0.0, math.sin(half))), strict=True):
            channels[f"quat_{a}/bar{b}"] = np.array(q)
    for i, a in enumerate("xyz"):
        channels[f"pos_{a}/com"] = np.array([start[:, i].mean(), end[:, i].mean()])
    # each body's two nodes 0.4 m either side of its centre along its frame's x axis
    nodes = {f"n{b}{k}": (f"bar{b}", np.array([0.4 * k, 0.0, 0.0])) for b in range(3)
             for k in (-1, 1)}
    summary = turn_summary(TimeSeries(np.array([0.0, 1.0]), channels), 45.0, 1.5, nodes)
    assert summary["yaw_deg"] == pytest.approx(40.0, abs=1e-3)
    assert summary["displacement_m"] == pytest.approx(0.3, abs=1e-6)
    assert summary["displacement_body_lengths"] == pytest.approx(0.2, abs=1e-6)


def test_cli_turn_refuses_a_heading_and_other_experiments(tmp_path):
    from tensim.cli import main

    out = str(tmp_path / "r")
    assert main(["experiment", "roll", "six_bar", "--turn", "30", "--heading", "0",
                 "--out", out]) == 2
    assert main(["experiment", "roll", "six_bar", "--turn", "nan", "--out", out]) == 2
    assert main(["experiment", "drag", "--turn", "30", "--out", out]) == 2


def test_held_faces_count_a_face_once_seen_twice_running():
    from tensim.experiments.roll import held_faces

    a, b, c = ("a",), ("b",), ("c",)
    # a one-look flicker onto c is not a face stood on; b held for two looks is
    assert held_faces([a, a, c, a, b, b, b, a, a]) == ([a, b, a], 5)
    assert held_faces([a, a, a]) == ([a], None)


def test_the_faces_from_the_recorded_rod_poses_are_those_the_gait_saw(runs):
    # the gait counts faces from the live simulation at each look; the same count made from
    # the recorded bodies' poses (as `experiment roll --controller` and `rl evaluate` do)
    # must agree, look for look
    from tensim.control.rolling import support_face
    from tensim.experiments.roll import held_faces, node_bodies, node_paths
    from tensim.model import compile_structure

    nodes = node_bodies(compile_structure(_prism()).index)
    for result, summary in runs.values():
        ts = result.trajectory
        paths = node_paths(ts, nodes)
        looks = np.arange(0, len(ts.time), 5)  # every 0.05 s, the gait's period
        faces, first = held_faces([support_face(dict(zip(nodes, p, strict=True)))
                                   for p in paths[looks]])
        assert len(faces) - 1 == summary["rolls"]
        assert len(set(faces)) == summary["faces_visited"]
        assert rocks_back(faces) == summary["rocks_back"]
        assert ts.time[looks[first]] == pytest.approx(summary["first_roll_s"], abs=1e-9)
        # every node on the ground at some sample: nodes whose recorded height came within
        # the face tolerance of the lowest node's
        low = paths[:, :, 2] - paths[:, :, 2].min(axis=1, keepdims=True)
        assert summary["ends_on_ground"] <= int((low < 0.02 * 1.3).any(axis=0).sum())
        assert summary["ends"] == 6 and summary["support_changes"] >= summary["rolls"]


def test_a_played_gait_reports_its_faces_from_the_recorded_rod_poses():
    from tensim.control import ControllerConfig, default_impedance
    from tensim.experiments.roll import play

    robot = _prism(lying=False)
    # no gait: the prism stands still on its bottom triangle, b0 b1 b2
    result, summary = play(robot, ControllerConfig(default_impedance(robot)), 1.0)
    assert summary["faces_visited"] == 1 and summary["rolls"] == 0
    assert summary["rocks_back"] == 0 and summary["first_roll_s"] is None
    assert summary["plans"] is None and summary["support_changes"] == 0
    assert summary["ends_on_ground"] == 3 and summary["ends"] == 6
    # laid on its side it falls from 4 cm onto a side face and stays: one change of face,
    # which the recorded heights of its nodes show (the three lowest at the end are not the
    # three lowest at the start)
    from tensim.experiments.roll import node_bodies, node_paths
    from tensim.model import compile_structure

    lying = _prism()
    result, summary = play(lying, ControllerConfig(default_impedance(lying)), 1.0)
    z = node_paths(result.trajectory, node_bodies(compile_structure(lying).index))[..., 2]
    start, end = (set(np.argsort(h)[:3]) for h in (z[0], z[-1]))
    assert start != end
    assert summary["faces_visited"] == 2 and summary["rolls"] == 1
    assert summary["ends_on_ground"] == len(start | end) == 4
