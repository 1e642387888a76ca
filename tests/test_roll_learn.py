"""The learned rolling gait: the ``roll`` family's layout and symmetry, a learn run end to end,
and the shipped 3-bar gait rolling the preset.

The layout is checked on a twisted prism written here, lying with its long axis along +y: its
cables turned by the prism's 3-fold symmetry must get the same wave shifted in time.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tensim.control import ControllerConfig, SineGait, default_impedance, load_controller
from tensim.control.roll_parameters import ROLL_NAMES, roll_parameters, rolling_axis
from tensim.experiments.roll import play
from tensim.learn import InlineExecutor, LearningSettings, OptimizerSettings, learn
from tensim.learn.objective import Objective
from tensim.learn.problem import TrialProblem
from tensim.models import three_bar
from tensim.structure import PASSIVE, Cable, Motor, Node, Rod, Structure

RADIUS, HEIGHT, TWIST = 0.15, 0.5, math.radians(150.0)  # m, m, rad


def _prism(turn_deg: float = 0.0) -> Structure:
    """A small motorised 3-bar lying with its long axis along +y, turned ``turn_deg`` about it.

    Turning by 120 degrees maps node b_i onto b_(i+1)'s place (and t_i onto t_(i+1)'s).
    """
    def at(k: int, z: float, twist: float) -> np.ndarray:
        angle = 2 * math.pi * k / 3 + twist
        return np.array([RADIUS * math.cos(angle), RADIUS * math.sin(angle), z - HEIGHT / 2])

    lay = Rotation.from_euler("x", -90, degrees=True)  # prism axis z -> +y
    turn = Rotation.from_euler("y", turn_deg, degrees=True)
    points = {f"b{k}": at(k, 0.0, 0.0) for k in range(3)}
    points.update({f"t{k}": at(k, HEIGHT, TWIST) for k in range(3)})
    nodes = tuple(Node(n, tuple((turn * lay).apply(p) + np.array([0.0, 0.0, 0.3])))
                  for n, p in points.items())
    motor = Motor(max_speed=0.3, max_tension=300.0)
    cables = [Cable(f"{e}_{k}", (f"{e[0]}{k}", f"{e[0]}{(k + 1) % 3}"), 2000.0, damping=10.0,
                    pretension=40.0, motor=motor) for e in ("bottom", "top") for k in range(3)]
    cables += [Cable(f"vertical_{k}", (f"b{k}", f"t{(k + 2) % 3}"), 2000.0, damping=10.0,
                     pretension=70.0, motor=PASSIVE) for k in range(3)]
    rods = tuple(Rod(f"bar_{k}", (f"b{k}", f"t{k}"), 0.01, linear_density=1.0)
                 for k in range(3))
    return Structure("test_prism", nodes, rods, tuple(cables))


DRIVEN = tuple(f"{e}_{k}" for e in ("bottom", "top") for k in range(3))


def test_the_layout_has_five_numbers_and_one_wave_around_the_axis():
    robot = _prism()
    layout = roll_parameters(robot, DRIVEN)
    assert layout.names == ROLL_NAMES
    np.testing.assert_allclose(rolling_axis(robot), [0.0, 1.0, 0.0], atol=1e-9)
    # the ends: the two triangles, each with its cables 120 degrees apart about the axis
    first = layout.end_b[0]
    assert layout.end_b == (first,) * 3 + (not first,) * 3
    for end in (slice(0, 3), slice(3, 6)):
        gaps = np.remainder(np.diff(np.asarray(layout.angle[end])[[0, 1, 2, 0]]), 2 * math.pi)
        np.testing.assert_allclose(gaps, gaps[0], atol=1e-9)  # one way round, evenly
        assert min(abs(gaps[0] - 2 * math.pi / 3), abs(gaps[0] - 4 * math.pi / 3)) < 1e-9
    # the values land in the gait: amplitudes by end, one frequency
    gait = layout.gait([0.3, 0.7, 0.5, 1.0, 0.8])
    assert isinstance(gait, SineGait) and gait.cables == DRIVEN
    assert set(gait.frequency) == {0.8}
    by_end = {b: {a for a, e in zip(gait.amplitude, layout.end_b, strict=True) if e == b}
              for b in (False, True)}
    assert by_end == {False: {0.3}, True: {0.7}}


@pytest.mark.parametrize("wave", [1.0, -1.0])
def test_turning_the_robot_by_its_symmetry_shifts_the_gait_in_time(wave):
    """Cable c of the prism turned by 120 degrees sits where cable c-1 sat: same amplitude, and
    every cable's phase moves by one common angle (a time shift), for a whole wave number."""
    values = [0.4, 0.9, 1.1, wave, 0.5]
    gait = roll_parameters(_prism(), DRIVEN).gait(values)
    turned = roll_parameters(_prism(120.0), DRIVEN).gait(values)
    before = dict(zip(gait.cables, zip(gait.amplitude, gait.phase, strict=True), strict=True))
    after = dict(zip(turned.cables, zip(turned.amplitude, turned.phase, strict=True), strict=True))
    shifts = []
    for name in DRIVEN:
        end, k = name.split("_")
        previous = f"{end}_{(int(k) - 1) % 3}"  # the cable whose place it took
        assert after[name][0] == before[previous][0]
        shifts.append(after[name][1] - before[previous][1])
    shifts = np.remainder(np.asarray(shifts) - shifts[0] + math.pi, 2 * math.pi) - math.pi
    np.testing.assert_allclose(shifts, 0.0, atol=1e-9)
    # and the shift is the wave number times the turn (the pattern runs around the axis)
    common = np.remainder(after["bottom_0"][1] - gait.phase[0] + math.pi, 2 * math.pi) - math.pi
    expected = math.remainder(wave * 2 * math.pi / 3, 2 * math.pi)
    assert min(abs(common - expected), abs(common + expected)) < 1e-9


def test_a_vertical_axis_measures_the_angles_about_z_from_x():
    # a prism built standing on its end falls onto its side first: about a vertical axis
    # there is no "down" to measure from, so the angles are taken from +x (toward +y)
    robot = _prism()
    layout = roll_parameters(robot, DRIVEN, axis=(0.0, 0.0, 1.0))
    centre = np.mean([n.position for n in robot.nodes], axis=0)
    for name, angle in zip(layout.cables, layout.angle, strict=True):
        a, b = robot.cable(name).nodes
        mid = (robot.position(a) + robot.position(b)) / 2 - centre
        assert angle == pytest.approx(math.atan2(mid[1], mid[0]), abs=1e-12)


def test_a_tiny_learn_run_writes_a_roll_controller_that_replays_its_score(tmp_path):
    robot = _prism()
    base = ControllerConfig(default_impedance(robot))
    objective = Objective(direction_deg=0.0, max_tilt_deg=180.0)
    problem = TrialProblem(robot, base, "roll", 1.0, objective, model="test_prism")
    assert problem.dimension == 5
    settings = LearningSettings(OptimizerSettings("cma", step=0.3), 8, seed=0)
    result = learn(problem, settings, tmp_path / "run", executor=InlineExecutor)
    config = load_controller(tmp_path / "run" / "best_controller.yaml", robot)
    assert isinstance(config.gait, SineGait) and set(config.gait.cables) == set(DRIVEN)
    # the file is the best trial: played again for the trial's time it scores the same
    replay = problem.evaluate(problem.layout.to_unit(np.asarray(result.x)))
    assert replay.score == pytest.approx(-result.fun, abs=1e-9)


SHIPPED_HEADING = -30.0  # deg: the preset lies with its long axis along 60 degrees
SHIPPED_SPEED = 0.161  # body lengths/s over 30 s toward that heading (docs/rolling.md)


def test_the_shipped_gait_rolls_the_three_bar_forward():
    robot = three_bar()
    config = load_controller("three_bar_roll", robot)
    _, summary = play(robot, config, 6.0, heading_deg=SHIPPED_HEADING)
    # Over 30 s it makes SHIPPED_SPEED body lengths/s (docs/rolling.md); 6 s (1.22 m, 0.148
    # body lengths/s when measured) include the start from rest, so they must give at least
    # half that pace: a gait that only rocks in place, or rolls the other way, makes ~0 or less
    assert summary["distance_m"] > SHIPPED_SPEED / 2 * summary["body_length_m"] * 6.0
    assert summary["heading_error_deg"] < 20.0  # 6.8 degrees when measured



def test_the_gait_learned_with_a_rolling_score_rolls_the_three_bar_over_every_side():
    # examples/rolling/three_bar_rolling.yaml, learned with `tensim learn --rolling`
    # (docs/rolling.md: 43 rolls over 6 faces in 30 s, 5.2 turns about the axis); 6 s of it
    robot = three_bar()
    config = load_controller(Path(__file__).parent.parent
                             / "examples/rolling/three_bar_rolling.yaml", robot)
    _, summary = play(robot, config, 6.0, heading_deg=SHIPPED_HEADING)
    # rolling: all six side faces and rod ends, and about one turn forward about the axis
    # (6.14 rad when measured); a crawl or a rock would turn ~0, a roll backward < 0
    assert summary["faces_visited"] == 6 and summary["ends_on_ground"] == 6
    assert summary["roll_rad"] > 1.5 * math.pi
    # 1.25 m along the heading when measured: at least the statics gait's 0.128 body
    # lengths/s over those 6 s
    assert summary["distance_m"] > 0.128 * summary["body_length_m"] * 6.0


def test_the_lab_files_rolling_gait_gets_it_off_its_end_triangle_and_rolling():
    # examples/rolling/three_bar_lab_rolling.yaml on the lab-style MJCF 3-bar, as
    # docs/rolling.md plays it (implicit cable law, the file's 1 ms step); 8 s of it
    from tensim.io.mjcf_import import import_mjcf
    from tensim.model import WorldOptions

    examples = Path(__file__).parent.parent / "examples/rolling"
    robot = import_mjcf(examples / "three_bar_lab.xml", warn=False).structure
    config = load_controller(examples / "three_bar_lab_rolling.yaml", robot)
    _, summary = play(robot, config, 8.0, heading_deg=90.0,
                      world=WorldOptions(cable_law="implicit"))
    # built standing on an end triangle, it falls onto its side within 2.5 s (1.7 s when
    # measured) and turns forward about its axis (1.35 rad when measured; a crawl turns ~0,
    # a rock back and forth nets ~0)
    assert summary["first_roll_s"] <= 2.5 and summary["faces_visited"] >= 3
    assert summary["roll_rad"] > 1.0
