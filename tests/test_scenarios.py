"""The 12-segment scenarios: wave gait, goal objective, wall figures, short end-to-end runs."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tensim
from tensim.cli import main
from tensim.control import SineController, SpineWave
from tensim.experiments.climb import climb_controller, run_climb, wall_progress
from tensim.experiments.goal import (
    GOAL_TARGET,
    GOAL_TERRAIN,
    REACHED_RADIUS,
    goal_objective,
    goal_progress,
    goal_summary,
    run_goal,
    write_goal,
)
from tensim.experiments.sidewind import (
    run_sidewind,
    sideways_share,
    transferred_controller,
    transferred_cpg,
)
from tensim.models import load_controller, preset
from tensim.sim import TimeSeries
from tensim.terrain import Flat, Rough, Wall, parse_terrain


def _series(time: np.ndarray, **paths: tuple[np.ndarray, np.ndarray, np.ndarray]) -> TimeSeries:
    channels = {}
    for item, (x, y, z) in paths.items():
        channels.update({f"pos_x/{item}": x, f"pos_y/{item}": y, f"pos_z/{item}": z})
    return TimeSeries(time, channels)


# -- the wave gait --------------------------------------------------------------------------


def test_spine_wave_gives_each_cable_its_modes_sum():
    structure = preset("tetraspine3").build()
    f, lag, a, b = 0.4, 0.9, 0.03, 0.02
    gait = SpineWave(frequency=f, joint_lag=lag, pitch=(a, 0.3), yaw=(b, -1.1)).gait(structure)
    t = np.linspace(0.0, 3.0, 31)
    table = gait.table(t)

    def expected(side: str, inner: bool, joint: int) -> np.ndarray:
        # pitch weights top 1, bottom corners -1/2; yaw left 1, right -1; inner = -outer
        w_pitch = {"top": 1.0, "left": -0.5, "right": -0.5}[side]
        w_yaw = {"top": 0.0, "left": 1.0, "right": -1.0}[side]
        angle = 2 * np.pi * f * t - (joint - 1) * lag
        v = w_pitch * a * np.sin(angle + 0.3) + w_yaw * b * np.sin(angle - 1.1)
        return -v if inner else v

    for k, name in enumerate(gait.cables):
        kind, side, joint = name.split("_")
        assert np.allclose(table[:, k], expected(side, kind == "inner", int(joint)), atol=1e-12)


def _relative_angles(series: TimeSeries, a: str, b: str) -> np.ndarray:
    """(T, 3) roll, pitch, yaw of body b in body a's frame [deg]."""
    def rot(body: str) -> Rotation:
        return Rotation.from_quat(np.stack([series[f"quat_{c}/{body}"] for c in "xyzw"], 1))
    return (rot(a).inv() * rot(b)).as_euler("xyz", degrees=True)


@pytest.mark.parametrize(("mode", "axis"), [("pitch", 1), ("yaw", 2)])
def test_pitch_and_yaw_waves_bend_the_joints_that_way(mode, axis):
    p = preset("tetraspine3")
    structure = p.build()
    wave = SpineWave(frequency=0.25, joint_lag=math.pi, **{mode: (0.1, 0.0)})
    controller = SineController(wave.gait(structure), p.controller(), duration=5.0)
    result = tensim.simulate(tensim.compile_structure(structure), 5.0, controller=controller,
                             record_dt=0.02)
    # one whole period of the wave, after the first second of settling
    swing = np.ptp(_relative_angles(result.trajectory, "segment_0", "segment_1")[50:], axis=0)
    # the named bending dominates the other two rotations of the joint several times over
    assert swing[axis] > 10.0  # degrees
    assert swing[axis] > 3 * np.delete(swing, axis).max()


# -- goal objective -------------------------------------------------------------------------


def test_goal_progress_is_the_reduction_of_horizontal_distance():
    t = np.linspace(0.0, 1.0, 11)
    zeros = np.zeros_like(t)
    straight = _series(t, com=(3 * t, 4 * t, 0.2 + zeros))  # (0, 0) -> (3, 4), 5 m
    assert goal_progress(straight, (3.0, 4.0)) == pytest.approx(5.0)
    assert goal_progress(straight, (-3.0, -4.0)) == pytest.approx(-5.0)  # moving away
    # off the line: from 4 m to sqrt(3^2 + 0^2) ... distances by Pythagoras
    assert goal_progress(straight, (0.0, 4.0)) == pytest.approx(4.0 - 3.0)
    angle = np.pi * t  # half a circle of radius 2 around the target: no progress
    circle = _series(t, com=(1 + 2 * np.cos(angle), 2 * np.sin(angle), zeros))
    assert goal_progress(circle, (1.0, 0.0)) == pytest.approx(0.0, abs=1e-12)
    assert goal_objective((3.0, 4.0))(straight) == goal_progress(straight, (3.0, 4.0))
    summary = goal_summary(straight, (3.0, 4.0))
    assert summary["start_distance_m"] == 5.0 and summary["final_distance_m"] == 0.0
    assert summary["reached"] and REACHED_RADIUS == 0.25
    assert summary["reached_time_s"] == 1.0  # 5 (1 - t) <= 0.25 first at the sample t = 1
    midway = goal_summary(straight, (1.5, 2.0))  # passed through at t = 0.5, then left
    assert midway["reached_time_s"] == 0.5 and midway["final_distance_m"] == 2.5
    missed = goal_summary(straight, (3.0, 4.26))  # passes 0.26 m away at the end
    assert not missed["reached"] and missed["reached_time_s"] is None


def test_goal_progress_ignores_height():
    t = np.linspace(0.0, 1.0, 5)
    climb = _series(t, com=(np.zeros_like(t), np.zeros_like(t), 5 * t))
    assert goal_progress(climb, (2.0, 0.0)) == 0.0


# -- scenario figures -----------------------------------------------------------------------


def test_wall_progress_counts_segments_on_and_past_the_wall():
    t = np.array([0.0, 1.0])
    wall = Wall(height=0.1, distance=0.5, thickness=0.2)
    series = _series(
        t, segment_0=(np.array([0.2, 0.9]), np.zeros(2), np.array([0.1, 0.25])),  # past
        segment_1=(np.array([0.0, 0.6]), np.zeros(2), np.array([0.1, 0.2])),  # on top
        segment_2=(np.array([-0.2, 0.45]), np.zeros(2), np.array([0.1, 0.1])),  # before it
        com=(np.zeros(2), np.zeros(2), np.zeros(2)))
    figures = wall_progress(series, wall)
    assert figures["segments_past_wall"] == 1
    assert figures["segments_on_wall"] == 1
    assert figures["front_height_reached_m"] == pytest.approx(0.15)


def test_transferred_cpg_keeps_the_short_spines_values_by_name():
    short = load_controller("tetraspine3_cpg").gait
    long = transferred_cpg("tetraspine3_cpg", amplitude=0.05, frequency=1.0)
    assert len(long.cables) == 66 and len(short.cables) == 12
    source = dict(zip(short.layout.names, short.values, strict=True))
    for name, value in zip(long.layout.names, long.values, strict=True):
        expected = {"amplitude": 0.05, "frequency": 1.0}.get(name, source[name])
        assert value == expected, name


def test_sideways_share():
    assert sideways_share({"body_forward_m": 0.3, "body_sideways_m": -0.4}) == 0.8
    assert sideways_share({}) == 0.0


# -- short end-to-end runs (the real scenarios last 60 s) ------------------------------------


def _check_common(summary: dict) -> None:
    for key in ("max_tension_N", "max_system_tension_N", "com_displacement_m",
                "real_time_factor", "height_reached_m", "planar_displacement_m", "direction"):
        assert key in summary, key
    assert len(summary["max_tension_N"]) == 66
    assert 0 < summary["max_system_tension_N"] < 50.0  # the motors' force limit


def test_climb_runs_toward_the_wall_and_reports_it():
    wall = Wall(height=0.05, distance=0.3, thickness=0.2, friction=1.0)
    result, summary, config, terrain = run_climb(terrain=wall, duration=1.5)
    _check_common(summary)
    assert terrain == wall and config.duration == 1.5
    assert summary["segments_on_wall"] == summary["segments_past_wall"] == 0  # 1.5 s: not yet
    assert summary["terrain"] == \
        "wall:height=0.05,distance=0.3,thickness=0.2,width=4.0,friction=1.0"
    # nothing went through the ground: every segment stays above z = 0
    assert min(result.trajectory.matrix("pos_z").min(axis=0)) > 0.0


def test_the_shipped_sidewinding_gait_moves_the_spine_across_its_axis():
    _, summary, config, terrain = run_sidewind(duration=10.0)
    _check_common(summary)
    assert terrain == Flat()  # the robot's own friction
    assert config.description.startswith("12-segment Tetraspine sidewinding")
    # learned at 1.2 m per 20 s; in 10 s (the first second settling) well over 0.3 m, to the
    # robot's left, and mostly across its own axis
    assert summary["body_sideways_m"] > 0.3
    assert summary["sideways_share"] > 0.8
    assert abs(summary["heading_change_deg"]) < 30.0


def test_a_tetraspine3_cpg_transfers_onto_the_long_spine():
    config = transferred_controller("tetraspine3_cpg_cma", 2.0, frequency=1.4)
    assert config.model == "tetraspine" and config.duration == 2.0
    assert len(config.gait.cables) == 66
    assert dict(zip(config.gait.layout.names, config.gait.values, strict=True))[
        "frequency"] == 1.4


def test_the_shipped_goal_gait_approaches_its_target_on_rough_ground():
    result, summary, config, terrain = run_goal(duration=8.0)
    assert terrain == GOAL_TERRAIN and summary["target_xy_m"] == list(GOAL_TARGET)
    assert config.description.startswith("12-segment Tetraspine toward a target")
    # learned at 1.43 m per 30 s; 8 s bring it well over 0.2 m closer, not sideways off
    assert summary["goal_progress_m"] > 0.2
    assert abs(summary["body_sideways_m"]) < summary["body_forward_m"]
    # every segment's centre of mass stays above the ground under it: none fell through
    series, ground = result.trajectory, terrain.geometry()
    clearance = series.matrix("pos_z") - ground.height(series.matrix("pos_x"),
                                                       series.matrix("pos_y"))
    assert clearance.min() > 0.0


def test_goal_run_writes_its_folder(tmp_path):
    rough = Rough(roughness=0.005, correlation=0.1, seed=2, size=2.5, resolution=0.05)
    result, summary, config, terrain = run_goal(target_xy=(1.0, 0.5), terrain=rough,
                                                duration=1.0)
    _check_common(summary)
    assert summary["goal_progress_m"] == pytest.approx(
        goal_progress(result.trajectory, (1.0, 0.5)), abs=1e-4)  # rounded to 0.1 mm
    write_goal(tmp_path, result, summary, config, terrain)
    written = json.loads((tmp_path / "summary.json").read_text())
    assert written["target_xy_m"] == [1.0, 0.5]
    for name in (*written["figures"], "controller.yaml", "trajectory.parquet"):
        assert (tmp_path / name).exists(), name


def test_goal_from_the_command_line_with_a_target(tmp_path, capsys):
    out = tmp_path / "goal"
    assert main(["--quiet", "experiment", "goal", "--duration", "0.5", "--target=-2,1",
                 "--terrain", "rough:roughness=0.005,seed=3,size=3", "--out", str(out)]) == 0
    assert "target (-2.0, 1.0) m" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["target_xy_m"] == [-2.0, 1.0]
    assert main(["experiment", "goal", "--target", "1;2", "--out", str(out)]) == 2
    assert "expected two numbers X,Y" in capsys.readouterr().err
    assert main(["experiment", "climb", "--target", "1,2", "--out", str(out)]) == 2
    assert "--target is for the goal experiment" in capsys.readouterr().err


def test_climb_from_the_command_line(tmp_path, capsys):
    out = tmp_path / "climb"
    assert main(["--quiet", "experiment", "climb", "--duration", "1", "--terrain",
                 "wall:height=0.04,distance=0.3,friction=0.8", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "segments rose up to" in printed and "0 on the wall" in printed
    summary = json.loads((out / "summary.json").read_text())
    assert parse_terrain(summary["terrain"]) == Wall(height=0.04, distance=0.3, friction=0.8)
    # the controller file it wrote holds the same gait, for `tensim simulate --controller`
    again = load_controller(out / "controller.yaml")
    gait = climb_controller().gait
    times = np.linspace(0.0, 2.0, 21)
    assert again.model == "tetraspine" and again.gait.cables == gait.cables
    assert np.allclose(again.gait.table(times), gait.table(times), atol=1e-12)
