"""The punctuated rolling gait: support faces, the summary's figures, steering, the 3-bar preset.

The gait runs on a six-bar written here (not a preset); its summary is recomputed from the
recorded centre-of-mass path, and headings 0 and 180 degrees must roll opposite ways.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from icosahedron import six_bar_points
from tensim.control.rolling import MOVED_M, heading_error_deg, support_edges, support_face
from tensim.design import check_structure
from tensim.experiments.roll import body_length, roll
from tensim.models import three_bar
from tensim.models.three_bar import BAR_LENGTH, BAR_MASS, DEFAULT_TIMESTEP
from tensim.structure import Cable, Motor, Node, Rod, Structure

STRUT = 0.6  # m
DURATION = 8.0  # s: a few rolls (a first tip may go astray while the robot lands)


def _icosahedron() -> Structure:
    """A small motorised six-bar: 0.6 m struts of 0.3 kg, 24 cables of 800 N/m at 20 N."""
    points = six_bar_points(STRUT)
    lift = 0.02 - min(p[2] for p in points.values())
    nodes = tuple(Node(n, tuple(p + np.array([0.0, 0.0, lift]))) for n, p in points.items())
    rods = tuple(Rod(f"rod_{a}{k}", (f"{a}{k}0", f"{a}{k}1"), 0.01, linear_density=0.5)
                 for a in "xyz" for k in (0, 1))
    length = STRUT * math.sqrt(6) / 4
    cables = tuple(Cable(f"c_{a}_{b}", (a, b), 800.0, damping=5.0, pretension=20.0,
                         motor=Motor(max_speed=0.3, max_tension=300.0))
                   for a, b in itertools.combinations(points, 2)
                   if abs(np.linalg.norm(points[a] - points[b]) - length) < 1e-9)
    return Structure("test_icosahedron", nodes, rods, cables)


@pytest.fixture(scope="module")
def runs() -> dict[float, tuple]:
    robot = _icosahedron()
    return {heading: roll(robot, DURATION, heading_deg=heading) for heading in (0.0, 180.0)}


def test_headings_0_and_180_roll_opposite_ways(runs):
    dx = {h: r.trajectory["pos_x/com"][-1] - r.trajectory["pos_x/com"][0]
          for h, (r, _) in runs.items()}
    # each ends at least one tip's worth (a face's size, ~ a quarter strut) its own way
    assert dx[0.0] > STRUT / 4 and dx[180.0] < -STRUT / 4
    for _, summary in runs.values():
        assert summary["rolls"] >= 1 and summary["faces_visited"] >= 2
        assert summary["plans_made"] == summary["plans"]  # each made afresh (no cache)


@pytest.mark.parametrize("heading", [0.0, 180.0])
def test_summary_fields_from_the_trajectory(runs, heading):
    result, summary = runs[heading]
    ts = result.trajectory
    start = np.array([ts["pos_x/com"][0], ts["pos_y/com"][0]])
    end = np.array([ts["pos_x/com"][-1], ts["pos_y/com"][-1]])
    h = np.array([math.cos(math.radians(heading)), math.sin(math.radians(heading))])
    distance = (end - start) @ h
    moved = end - start
    error = math.degrees(math.acos(np.clip(moved @ h / np.linalg.norm(moved), -1, 1)))
    assert summary["body_length_m"] == pytest.approx(STRUT, abs=1e-6)  # rounded to 6 digits
    assert summary["distance_m"] == pytest.approx(distance, abs=1e-6)
    assert summary["body_lengths_per_s"] == pytest.approx(distance / STRUT / DURATION, abs=1e-6)
    assert summary["heading_error_deg"] == pytest.approx(error, abs=1e-3)


@pytest.mark.parametrize("heading_deg", [0.0, 90.0, -150.0])
@pytest.mark.parametrize("turn_deg", [0.0, 30.0, -45.0, 120.0, -170.0])
def test_heading_error_is_the_signed_angle_from_the_heading(heading_deg, turn_deg):
    # the displacement is the heading turned counter-clockwise by turn_deg: that is the error
    h = math.radians(heading_deg)
    heading = np.array([math.cos(h), math.sin(h)])
    for length in (0.05, 3.0):
        moved = length * np.array([math.cos(h + math.radians(turn_deg)),
                                   math.sin(h + math.radians(turn_deg))])
        assert heading_error_deg(moved, heading) == pytest.approx(turn_deg, abs=1e-9)
    assert heading_error_deg(0.99 * MOVED_M * heading, heading) is None  # too short to say


def test_the_roll_experiment_and_the_rl_evaluation_share_the_heading_error():
    from tensim.experiments import roll as experiment
    from tensim.rl import evaluate

    assert experiment.heading_error_deg is heading_error_deg
    assert evaluate.heading_error_deg is heading_error_deg


def test_goal_point_steers_toward_it():
    _, summary = roll(_icosahedron(), DURATION, goal=(0.0, -5.0))
    before, after = summary["goal_distance_m"]
    assert after < before - STRUT / 4  # closer by at least one tip's worth


def test_support_face_and_edges_of_a_lying_box():
    # a 1 x 2 x 0.5 box on the ground: the bottom four corners, edges at x = +-0.5, y = +-1
    corners = {f"n{i}": np.array([x, y, z]) for i, (x, y, z) in enumerate(
        itertools.product((-0.5, 0.5), (-1.0, 1.0), (0.0, 0.5)))}
    face = support_face(corners)
    assert face == tuple(sorted(n for n, p in corners.items() if p[2] == 0.0))
    edges = support_edges(np.array([corners[n][:2] for n in face]))
    # unit outward normals; the centre lies 0.5 m inside the x edges and 1 m inside the y ones
    assert np.allclose(np.linalg.norm(edges[:, :2], axis=1), 1.0)
    assert sorted(np.round(-edges[:, 2], 9)) == [0.5, 0.5, 1.0, 1.0]


def test_body_length_is_the_longest_rod():
    assert body_length(three_bar()) == pytest.approx(BAR_LENGTH, rel=1e-3)  # settled pose


def test_three_bar_is_as_published_and_checks_clean():
    robot = three_bar()
    assert sum(not c.motor.passive for c in robot.cables) == 6
    assert {c.name for c in robot.cables if c.motor.passive} == {f"vertical_{i}"
                                                                 for i in range(3)}
    assert all(c.stiffness == 10_000.0 for c in robot.cables)
    for rod in robot.rods:
        assert rod.mass_per_length() * robot.distance(*rod.nodes) == pytest.approx(
            BAR_MASS, rel=1e-3)  # the standing pose stretches bars by nothing; cables sag
    assert check_structure(robot, DEFAULT_TIMESTEP) == []


def test_cli_roll_options_belong_to_roll(tmp_path):
    from tensim.cli import main

    assert main(["experiment", "drag", "--heading", "90", "--out", str(tmp_path / "d")]) == 2
    assert main(["experiment", "drag", "--cached-plans", "--out", str(tmp_path / "d")]) == 2
    assert main(["experiment", "roll", "--out", str(tmp_path / "r")]) == 2  # no robot
    assert main(["experiment", "roll", "six_bar", "--heading", "0", "--goal", "1,0",
                 "--out", str(tmp_path / "r")]) == 2


def test_cli_writes_a_run_folder_with_the_rolling_fields(tmp_path):
    import json

    from tensim.cli import main
    from tensim.sim import TimeSeries
    from tensim.structure import save_structure

    save_structure(_icosahedron(), tmp_path / "robot.yaml")
    out = tmp_path / "run"
    assert main(["--quiet", "experiment", "roll", str(tmp_path / "robot.yaml"), "--heading",
                 "90", "--duration", "1", "--cached-plans", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    ts = TimeSeries.from_parquet(out / "trajectory.parquet")
    dy = ts["pos_y/com"][-1] - ts["pos_y/com"][0]  # heading 90: along +y
    assert summary["distance_m"] == pytest.approx(dy, abs=1e-6)
    assert summary["body_lengths_per_s"] == pytest.approx(dy / STRUT / 1.0, abs=1e-6)
    for field in ("heading_error_deg", "faces_visited", "rolls", "body_length_m",
                  "rocks_back", "first_roll_s", "plans", "plans_made"):
        assert field in summary
    assert 0 <= summary["rocks_back"] <= max(0, summary["rolls"] - 1)
    assert 1 <= summary["plans_made"] <= summary["plans"]
    assert (out / "structure.yaml").is_file()


def test_a_pose_whose_cable_anchors_met_is_not_planned_from() -> None:
    """A cable anchored anchor_offset from its nodes (an imported lab file's end caps) can be
    wound until its anchors meet; the gait then makes no plan (and the run goes on) rather
    than stopping on the structure's check."""
    import dataclasses

    from tensim.control.rolling import default_settings
    from tensim.experiments.roll import _Gait

    robot = three_bar()
    cables = list(robot.cables)
    cables[0] = dataclasses.replace(cables[0], anchor_offset=0.05)
    robot = dataclasses.replace(robot, cables=tuple(cables))
    rest = np.array([c.rest_length for c in robot.cables])
    gait = _Gait(robot, rest, np.ones(len(rest), bool), default_settings(robot), 0.0, None,
                 np.zeros(2), body_length(robot))
    positions = {n.name: np.asarray(n.position, float) for n in robot.nodes}
    a, b = robot.cables[0].nodes
    positions[b] = positions[a] + [0.05, 0.0, 0.0]  # anchors 0.05 m apart would need 0.1 m
    gait._push(None, positions)  # type: ignore[arg-type]  # returns before it reads the sim
    assert gait.plans == 0 and not gait.pushing
