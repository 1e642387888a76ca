"""The rolling score of ``tensim learn --rolling``: metres along the direction counted only as
far as the robot rolled them, on a rigid 3-bar written here whose rolling, crawling and
rocking are worked out by hand.

A rigid prism that rolls without slipping turns about its contact edge, so its centre of mass
moves along the heading by h dθ for a turn dθ about z x heading (h its height above the edge):
over three tips of 120 degrees it turns 2 pi and moves by its triangle's perimeter.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tensim.control import ControllerConfig, default_impedance
from tensim.learn.objective import Objective
from tensim.learn.problem import TrialProblem
from tensim.sim import TimeSeries
from tensim.sim.motion import rolled_distance
from tensim.structure import PASSIVE, Cable, Motor, Node, Rod, Structure

HEADING_DEG = 30.0
HEADING = np.array([math.cos(math.radians(HEADING_DEG)), math.sin(math.radians(HEADING_DEG))])
CIRCUMRADIUS, LENGTH = 0.3, 1.2  # m: the prism's end triangles and bars
PERIMETER = 3 * math.sqrt(3) * CIRCUMRADIUS  # m: the distance of one turn rolled


def _about(axis: np.ndarray, angle: float) -> np.ndarray:
    """The rotation matrix of ``angle`` [rad] about the unit ``axis`` (Rodrigues)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]],
                  [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def _ends() -> np.ndarray:
    """(6, 3) the rod ends of a straight prism lying on a side, its long axis square to the
    heading, its lowest ends on the ground."""
    axis = np.array([-HEADING[1], HEADING[0], 0.0])  # z x heading: the rolling axis
    up, ahead = np.array([0.0, 0.0, 1.0]), np.array([*HEADING, 0.0])
    ends = np.array([x * axis + CIRCUMRADIUS * (math.sin(a) * up + math.cos(a) * ahead)
                     for x in (0.0, LENGTH) for a in np.radians([90.0, 210.0, 330.0])])
    return ends - [0.0, 0.0, ends[:, 2].min()]


def _rolled(tips: int, steps: int = 100, toward: float = 1.0) -> np.ndarray:
    """(tips steps + 1, 6, 3) the prism rolled rigidly without slipping over ``tips`` leading
    edges, 120 degrees each, toward the heading (``toward`` = 1) or away from it (-1)."""
    axis = toward * np.array([-HEADING[1], HEADING[0], 0.0])
    ahead = toward * np.array([*HEADING, 0.0])
    path = [_ends()]
    for _ in range(tips):
        ends = path[-1]
        bottom = ends[np.argsort(ends[:, 2])[:4]]
        pivot = bottom[np.argmax(bottom @ ahead)]
        path.extend((ends - pivot) @ _about(axis, a).T + pivot
                    for a in np.linspace(0.0, 2 * math.pi / 3, steps + 1)[1:])
    return np.array(path)


def _crawled(distance: float, samples: int) -> np.ndarray:
    """The prism slid (or crawled, stretching and shrinking along the heading as it goes)
    ``distance`` metres along the heading on the face it stands on, without turning."""
    ends, ahead = _ends(), np.array([*HEADING, 0.0])
    s = np.linspace(0.0, 1.0, samples)
    centre = ends.mean(axis=0)
    stretch = 1 + 0.2 * np.sin(2 * math.pi * 5 * s)  # five strides
    along = (ends - centre) @ ahead
    return np.array([ends + distance * k * ahead + (f - 1) * along[:, None] * ahead
                     for k, f in zip(s, stretch, strict=True)])


def _trajectory(path: np.ndarray) -> TimeSeries:
    """A recorded trial whose centre of mass is the rod ends' centroid (equal end masses), with
    one idle cable."""
    com = path.mean(axis=1)
    time = np.arange(len(path)) * 0.01
    idle = {"tension/c": np.zeros(len(path)), "rest_length/c": np.ones(len(path))}
    return TimeSeries(time, {**{f"pos_{a}/com": com[:, k] for k, a in enumerate("xyz")},
                             **idle})


def test_a_rigid_roll_is_rolled_its_whole_distance():
    path = _rolled(3)
    com = path.mean(axis=1)
    along = (com[-1, :2] - com[0, :2]) @ HEADING
    assert along == pytest.approx(PERIMETER, rel=1e-12)  # one turn: the triangle's perimeter
    rolled, turn = rolled_distance(path, com[:, 2], HEADING)
    assert turn == pytest.approx(2 * math.pi, abs=1e-9)  # rigid moves: exact fits
    # the trapezoid rule on h over steps of 1.2 degrees: within (1.2 deg)^2 / 12 of the sum
    assert rolled == pytest.approx(PERIMETER, rel=2e-4)
    # rolled the other way it counts negative (a sign flip of the rolling axis would fail)
    back = _rolled(3, toward=-1.0)
    assert rolled_distance(back, back.mean(axis=1)[:, 2], HEADING)[0] == pytest.approx(
        -PERIMETER, rel=2e-4)


def test_contact_radii_lower_the_ground_not_the_turn():
    # end caps of radius r touch the ground r below their centres: a rolling cap turns about
    # that contact, so every interval's height grows by r and the sum by r times the turn
    path, r = _rolled(1), 0.025
    com_z = path.mean(axis=1)[:, 2]
    bare, turn = rolled_distance(path, com_z, HEADING)
    capped, capped_turn = rolled_distance(path, com_z, HEADING, np.full(6, r))
    assert capped_turn == turn
    assert capped - bare == pytest.approx(r * turn, abs=1e-12)


def test_the_score_counts_a_roll_and_not_a_crawl_of_the_same_distance():
    rolling = Objective(direction_deg=HEADING_DEG, max_tilt_deg=180.0, rolling=True)
    plain = Objective(direction_deg=HEADING_DEG, max_tilt_deg=180.0)
    roll = _rolled(3)
    crawl = _crawled(PERIMETER, len(roll))
    for path in (roll, crawl):  # both move the centre of mass one perimeter along
        score, metrics, _ = plain.score(_trajectory(path), ())
        assert score == pytest.approx(PERIMETER, rel=1e-9)
    score, metrics, void = rolling.score(_trajectory(roll), (), roll)
    assert void is None and score == pytest.approx(PERIMETER, rel=2e-4)
    assert metrics["roll_rad"] == pytest.approx(2 * math.pi, abs=1e-9)
    # the crawl stretches symmetrically along the heading and never turns: nothing rolled
    score, metrics, _ = rolling.score(_trajectory(crawl), (), crawl)
    assert metrics["along_m"] == pytest.approx(PERIMETER, rel=1e-9)
    assert score == pytest.approx(0.0, abs=1e-9)
    # rolled away from the heading it scores the distance lost
    back = _rolled(3, toward=-1.0)
    assert rolling.score(_trajectory(back), (), back)[0] == pytest.approx(-PERIMETER, rel=2e-4)


def test_a_rock_over_an_edge_and_back_scores_nothing():
    tip = _rolled(1)[:51]  # 60 degrees over the leading edge, then back the same way
    rock = np.concatenate([tip, tip[::-1][1:]])
    score, metrics, _ = Objective(direction_deg=HEADING_DEG, max_tilt_deg=180.0,
                                  rolling=True).score(_trajectory(rock), (), rock)
    assert metrics["roll_rad"] == pytest.approx(0.0, abs=1e-9)
    assert score == pytest.approx(0.0, abs=1e-9)


def test_a_rock_forward_while_tall_and_back_while_low_scores_nothing():
    # the centre of mass 10 cm higher while the prism turns forward than while it turns back
    # (a robot that stretches up to pivot forward and crouches to pivot back): h dθ summed
    # would count 10 cm x 60 degrees forward; the net turn is 0, and so is the distance rolled
    tip = _rolled(1)[:51]
    rock = np.concatenate([tip, tip[::-1][1:]])
    com_z = rock.mean(axis=1)[:, 2] + np.where(np.arange(len(rock)) <= 50, 0.1, 0.0)
    rolled, turn = rolled_distance(rock, com_z, HEADING)
    assert turn == pytest.approx(0.0, abs=1e-9) and rolled == pytest.approx(0.0, abs=1e-9)


def test_a_rolling_score_needs_one_direction_and_the_rod_ends():
    for bad in ({}, {"direction_deg": 90.0, "either_way": True}):
        with pytest.raises(ValueError, match="rolling scores the distance rolled"):
            Objective(rolling=True, **bad)
    objective = Objective(direction_deg=0.0, rolling=True)
    assert objective.describe() == "displacement of com along 0 deg, counted as far as rolled"
    with pytest.raises(ValueError, match="rod ends' recorded paths"):
        objective.score(_trajectory(_rolled(1)), ())


def _prism() -> Structure:
    """A small motorised 3-bar (a twisted prism, 0.5 m long) lying with its long axis along
    +y, its end triangles' cables driven."""
    def at(k: int, y: float, twist: float) -> tuple[float, float, float]:
        angle = 2 * math.pi * k / 3 + twist
        return (0.15 * math.cos(angle), y, 0.15 * math.sin(angle) + 0.3)

    nodes = tuple(Node(f"{e}{k}", at(k, y, twist)) for e, y, twist in
                  (("b", 0.0, 0.0), ("t", 0.5, math.radians(150.0))) for k in range(3))
    motor = Motor(max_speed=0.3, max_tension=300.0)
    cables = [Cable(f"{e}_{k}", (f"{e}{k}", f"{e}{(k + 1) % 3}"), 2000.0, damping=10.0,
                    pretension=40.0, motor=motor) for e in "bt" for k in range(3)]
    cables += [Cable(f"v_{k}", (f"b{k}", f"t{(k + 2) % 3}"), 2000.0, damping=10.0,
                     pretension=70.0, motor=PASSIVE) for k in range(3)]
    rods = tuple(Rod(f"bar_{k}", (f"b{k}", f"t{k}"), 0.01, linear_density=1.0)
                 for k in range(3))
    return Structure("test_prism", nodes, rods, tuple(cables))


def test_a_trial_is_scored_on_its_recorded_rod_ends():
    robot = _prism()
    objective = Objective(direction_deg=0.0, max_tilt_deg=180.0, rolling=True)
    problem = TrialProblem(robot, ControllerConfig(default_impedance(robot)), "roll", 2.0,
                           objective, model="test_prism")
    nodes, radii = problem.rod_ends
    assert set(nodes) == {n.name for n in robot.nodes} and radii == pytest.approx(0.01)
    outcome = problem.evaluate(problem.start())
    metrics = outcome.metrics
    assert outcome.status == "ok"
    assert outcome.score == pytest.approx(min(metrics["along_m"], metrics["rolled_m"]),
                                          abs=1e-12)


def test_a_tiny_rolling_learn_run_starts_where_told_and_resumes_its_problem(tmp_path):
    from tensim.learn import InlineExecutor, LearningSettings, OptimizerSettings, learn
    from tensim.learn.store import RunStore

    robot = _prism()
    objective = Objective(direction_deg=0.0, max_tilt_deg=180.0, rolling=True)
    start = (("amplitude/a", 1.5), ("frequency", 0.2))
    problem = TrialProblem(robot, ControllerConfig(default_impedance(robot)), "roll", 1.0,
                           objective, model="test_prism", start_from=start)
    values = problem.values(problem.start())
    nominal = problem.layout.nominal
    assert values == pytest.approx([1.5, nominal[1], nominal[2], nominal[3], 0.2], abs=1e-12)
    learn(problem, LearningSettings(OptimizerSettings("cma", step=0.2), 6, seed=0),
          tmp_path / "run", executor=InlineExecutor)
    again = RunStore(tmp_path / "run").load_problem()
    assert isinstance(again, TrialProblem)
    assert again.objective == objective and again.start_from == start
    # its trials are scored on their rod ends' rolling
    first = RunStore(tmp_path / "run").evaluations()[0]
    assert set(first.metrics) >= {"along_m", "rolled_m", "roll_rad"}


@pytest.mark.parametrize("start, message", [
    ((("speed", 1.0),), "not a parameter of the roll gait"),
    ((("frequency", 9.0),), r"expected a value in \[0.1, 2\]"),
    ((("frequency", 0.2), ("frequency", 0.3)), "given more than once"),
])
def test_a_bad_starting_value_is_refused_by_name(start, message):
    robot = _prism()
    with pytest.raises(ValueError, match=message):
        TrialProblem(robot, ControllerConfig(default_impedance(robot)), "roll", 1.0,
                     start_from=start)


@pytest.mark.parametrize("extra, words", [
    (["--rolling"], "rolling scores the distance rolled toward a direction"),
    (["--rolling", "--direction", "sideways"], "give one direction"),
    (["--direction", "0", "--start", "frequency"], "--start entry 'frequency': expected "
                                                   "NAME=VALUE"),
    (["--direction", "0", "--start", "wave=1"], "start wave: not a parameter of the roll gait"),
])
def test_the_command_line_refuses_a_bad_rolling_score_or_start(tmp_path, capsys, extra, words):
    from tensim.cli import main

    argv = ["learn", "--model", "three_bar", "--controller", "roll", "--evaluations", "1",
            "--out", str(tmp_path / "run"), *extra]
    assert main(argv) != 0
    assert words in capsys.readouterr().err
    assert not (tmp_path / "run").exists()
