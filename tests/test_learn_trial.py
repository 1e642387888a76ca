"""Learning on the real robot: scoring, sine layouts, failed trials, the command end to end."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from tensim.cli import main
from tensim.control import (
    ControllerConfig,
    GaitError,
    load_controller,
    tetraspine_sine,
)
from tensim.control.sine_parameters import sine_parameters, tetraspine_sine_parameters
from tensim.learn import Objective, TrialProblem, default_base, parse_direction
from tensim.learn.objective import max_tilt, motor_work, target_progress
from tensim.learn.problem import FLIPPED, GAIT, OK, UNSTABLE
from tensim.model import WorldOptions, compile_structure
from tensim.models import tetraspine3
from tensim.sim import SimulationError, TimeSeries, simulate
from tensim.terrain import parse_terrain

# -- the objective on synthetic trajectories -----------------------------------------------------


def _series(x: np.ndarray, y: np.ndarray, *, tilt_deg: float = 0.0,
            tension: float = 10.0, rest: np.ndarray | None = None) -> TimeSeries:
    t = np.linspace(0.0, 1.0, x.size)
    half = math.radians(tilt_deg) / 2 * t  # a rotation about x growing to tilt_deg
    rest = np.full(t.size, 0.2) if rest is None else rest
    return TimeSeries(t, {
        "pos_x/com": x, "pos_y/com": y, "pos_x/seg": x, "pos_y/seg": y,
        "quat_w/seg": np.cos(half), "quat_x/seg": np.sin(half),
        "quat_y/seg": np.zeros_like(t), "quat_z/seg": np.zeros_like(t),
        "tension/c": np.full(t.size, tension), "rest_length/c": rest})


@pytest.mark.parametrize("direction, expected", [
    ("any", 0.5),            # |(0.3, -0.4)|
    ("forward", 0.3),
    ("backward", -0.3),
    ("left", -0.4),
    ("right", 0.4),
    ("sideways", 0.4),       # either way: |dy|
    ("45", (0.3 - 0.4) / math.sqrt(2)),
])
def test_scored_distance_follows_the_direction(direction, expected):
    series = _series(np.linspace(1.0, 1.3, 11), np.linspace(2.0, 1.6, 11))
    angle, either = parse_direction(direction)
    score, metrics, reason = Objective("com", angle, either).score(series, ("seg",))
    assert reason is None
    assert score == pytest.approx(expected, abs=1e-12)  # float rounding of cos/sin only
    assert (metrics["dx_m"], metrics["dy_m"]) == pytest.approx((0.3, -0.4), abs=1e-12)


def test_motor_work_and_energy_term():
    # the rest length goes 0.2 -> 0.1 -> 0.15 m under a constant 10 N: 10 (0.1 + 0.05) = 1.5 J
    rest = np.concatenate([np.linspace(0.2, 0.1, 6), np.linspace(0.1, 0.15, 6)[1:]])
    series = _series(np.linspace(0.0, 0.3, 11), np.zeros(11), rest=rest)
    assert motor_work(series) == pytest.approx(1.5, abs=1e-12)
    score, metrics, _ = Objective("com", energy_weight=0.1).score(series, ("seg",))
    assert metrics["work_J"] == pytest.approx(1.5, abs=1e-12)
    assert score == pytest.approx(0.3 - 0.1 * 1.5, abs=1e-12)


def test_tilt_past_the_limit_flips_the_trial():
    series = _series(np.zeros(11), np.zeros(11), tilt_deg=120.0)
    tilt, body, when = max_tilt(series, ("seg",))
    assert tilt == pytest.approx(120.0, abs=1e-9) and body == "seg" and when == 1.0
    _, _, reason = Objective(max_tilt_deg=90.0).score(series, ("seg",))
    assert reason is not None and "flipped over" in reason
    assert Objective(max_tilt_deg=180.0).score(series, ("seg",))[2] is None


def test_a_target_scores_the_progress_toward_it():
    # com (1, 2) -> (1.3, 1.6); target (4, 6): distance 5 -> |(2.7, 4.4)| by Pythagoras
    series = _series(np.linspace(1.0, 1.3, 11), np.linspace(2.0, 1.6, 11))
    score, metrics, reason = Objective(target_xy=(4.0, 6.0)).score(series, ("seg",))
    assert reason is None
    assert score == pytest.approx(5.0 - math.hypot(2.7, 4.4), abs=1e-12)
    assert metrics["target_distance_m"] == pytest.approx(math.hypot(2.7, 4.4), abs=1e-12)
    # along the path toward the target the progress is the distance travelled (0.5 m)
    ahead = (1.0 + 0.3 * 10, 2.0 - 0.4 * 10)
    assert Objective(target_xy=ahead).score(series, ("seg",))[0] == pytest.approx(0.5)
    # settling: only the second half counts, 0.25 m of the straight path
    settled = Objective(target_xy=ahead, settle_s=0.5).score(series, ("seg",))[0]
    assert settled == pytest.approx(0.25)
    assert "toward (4, 6) m" in Objective(target_xy=(4.0, 6.0)).describe()


def test_bad_objectives_are_refused():
    with pytest.raises(ValueError, match="direction"):
        parse_direction("upward")
    with pytest.raises(ValueError, match="energy_weight"):
        Objective(energy_weight=-1.0)
    with pytest.raises(ValueError, match="not both"):
        Objective(direction_deg=0.0, target_xy=(1.0, 0.0))
    with pytest.raises(ValueError, match="two finite coordinates"):
        Objective(target_xy=(1.0, math.nan))


# -- sine layouts ----------------------------------------------------------------------------------


def test_per_cable_sine_layout_starts_from_the_base_gait():
    robot = tetraspine3()
    base = tetraspine_sine(robot, 0.01, 0.5, phase=0.2)  # inner cables: negative amplitudes
    layout = sine_parameters(robot, start=base)
    assert layout.size == 2 * 12 + 1
    t = np.linspace(0.0, 4.0, 97)
    # a negative amplitude became the same wave with π more phase
    np.testing.assert_allclose(layout.gait().table(t), base.table(t), rtol=0, atol=1e-15)
    values = layout.from_unit(np.full(layout.size, 0.25))
    assert layout.gait(values).frequency == (values[-1],) * 12


def test_tetraspine_pattern_layout_with_pi_and_pi_is_the_papers_gait():
    robot = tetraspine3()
    layout = tetraspine_sine_parameters(robot)
    assert layout.names == ("amplitude", "frequency", "joint_lag", "inner_phase")
    gait = layout.gait([0.01, 0.5, math.pi, math.pi])
    t = np.linspace(0.0, 4.0, 97)
    reference = tetraspine_sine(robot, 0.01, 0.5).table(t)
    # sin(x + π) = −sin(x) and phase −π vs −π: equal up to sin rounding
    np.testing.assert_allclose(gait.table(t), reference, rtol=0, atol=1e-15)


# -- trials on the robot ---------------------------------------------------------------------------


def _problem(family: str = "cpg", duration: float = 0.5, **objective) -> TrialProblem:
    robot = tetraspine3()
    return TrialProblem(robot, default_base("tetraspine3", family, robot), family, duration,
                        Objective(**objective), model="tetraspine3")


def test_a_trial_scores_the_planar_displacement_of_the_simulated_robot():
    problem = _problem("sine-pattern", 0.5, segment="segment_0")
    unit = np.full(problem.dimension, 0.6)
    outcome = problem.evaluate(unit)
    assert outcome.status == OK
    # the same trial, set up by hand from the saved controller's pieces
    compiled = compile_structure(problem.structure)
    config = problem.base.with_gait(problem.layout.gait(problem.values(unit))).with_duration(0.5)
    result = simulate(compiled, 0.5, controller=config.build(compiled.model.opt.timestep))
    x, y = (result.trajectory[f"pos_{a}/segment_0"] for a in "xy")
    assert outcome.score == math.hypot(x[-1] - x[0], y[-1] - y[0])  # deterministic: exact


def test_failed_trials_get_the_penalty_and_a_reason(monkeypatch):
    problem = _problem("sine-pattern", 0.2, max_tilt_deg=1e-6)  # any wobble counts as flipped
    unit = np.full(problem.dimension, 0.5)
    flipped = problem.evaluate(unit)
    assert (flipped.status, flipped.score) == (FLIPPED, -1.0) and "tilted" in flipped.reason

    def unstable(*args, **kwargs):
        raise SimulationError("body 'segment_1' reached speed 500")

    monkeypatch.setattr("tensim.learn.problem.simulate", unstable)
    outcome = problem.evaluate(unit)
    assert outcome.status == UNSTABLE and "segment_1" in outcome.reason

    def bad_gait(self, dt):
        raise GaitError("CPG amplitude ran away")

    monkeypatch.setattr(ControllerConfig, "build", bad_gait)
    outcome = problem.evaluate(unit)
    assert (outcome.status, outcome.score) == (GAIT, -1.0) and "ran away" in outcome.reason


def test_unknown_segment_is_refused():
    with pytest.raises(ValueError, match="unknown segment 'tail'"):
        _problem(segment="tail")


# -- the command line ------------------------------------------------------------------------------


def test_learn_command_end_to_end_with_resume(tmp_path, capsys):
    out = tmp_path / "run"
    args = ["--quiet", "learn", "--model", "tetraspine3", "--controller", "cpg",
            "--optimizer", "ntrt", "--evaluations", "3", "--trial-duration", "0.5",
            "--seed", "1", "--workers", "2", "--monte-carlo", "2", "--batch", "2",
            "--direction", "sideways", "--out", str(out)]
    assert main(args) == 0
    assert main(["--quiet", "learn", "--resume", str(out), "--evaluations", "6"]) == 0
    printed = capsys.readouterr().out
    assert "best score" in printed and "tensim experiment cpg --controller" in printed
    assert re.search(r"best score -?\d+\.\d{4} m \(evaluation", printed)  # a distance [m]
    lines = (out / "evaluations.jsonl").read_text().splitlines()
    assert sorted(json.loads(line)["index"] for line in lines) == list(range(6))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["evaluations"] == 6 and summary["finished"]
    assert {"best_score", "wall_s", "evaluations_per_s"} <= set(summary)
    assert (out / "learning_curve.png").stat().st_size > 0
    # the best controller is an ordinary controller file that reproduces the best trial
    robot = tetraspine3()
    config = load_controller(out / "best_controller.yaml", robot)
    assert config.duration == 0.5
    compiled = compile_structure(robot)
    result = simulate(compiled, config.duration, controller=config.build(1e-3))
    dy = result.trajectory["pos_y/com"]
    assert abs(dy[-1] - dy[0]) == summary["best_score"]
    table = tmp_path / "v.txt"
    assert main(["export-trajectory", str(out / "best_controller.yaml"), "--out",
                 str(table)]) == 0
    assert table.exists()


def test_learn_command_toward_a_target_on_rough_ground(tmp_path, capsys):
    out = tmp_path / "goal"
    terrain = "rough:roughness=0.01,correlation=0.2,seed=4,size=2.0,friction=0.8"
    assert main(["--quiet", "learn", "--model", "tetraspine3", "--controller", "sine-pattern",
                 "--optimizer", "cma", "--evaluations", "2", "--trial-duration", "0.4",
                 "--workers", "0", "--target", "1,0.5", "--terrain", terrain,
                 "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"try it: tensim simulate tetraspine3 --controller {out}" in printed
    assert "--terrain 'rough:roughness=0.01," in printed
    config = json.loads((out / "config.json").read_text())["problem"]
    assert config["objective"]["target_xy"] == [1.0, 0.5]
    assert parse_terrain(config["terrain"]) == parse_terrain(terrain)
    # the best trial replays on that ground and scores the same progress
    robot = tetraspine3()
    best = load_controller(out / "best_controller.yaml", robot)
    compiled = compile_structure(robot, WorldOptions(terrain=parse_terrain(terrain)))
    result = simulate(compiled, best.duration, controller=best.build(1e-3))
    summary = json.loads((out / "summary.json").read_text())
    assert target_progress(result.trajectory, (1.0, 0.5)) == summary["best_score"]
    # the ground and the target are part of the run: a resume may not change them
    assert main(["learn", "--resume", str(out), "--terrain", "flat"]) == 2
    assert "--terrain" in capsys.readouterr().err


def test_learn_command_refuses_bad_input(tmp_path, capsys):
    assert main(["learn", "--target", "1", "--out", str(tmp_path / "t")]) == 2
    assert "expected two numbers X,Y" in capsys.readouterr().err
    assert main(["learn", "--target", "1,0", "--direction", "left", "--out",
                 str(tmp_path / "t")]) == 2
    assert "not both" in capsys.readouterr().err
    assert main(["learn", "--terrain", "lava", "--out", str(tmp_path / "t")]) == 2
    assert "unknown kind 'lava'" in capsys.readouterr().err
    assert main(["learn", "--resume", str(tmp_path), "--model", "six_bar"]) == 2
    assert "--resume takes the run's configuration" in capsys.readouterr().err
    assert main(["learn", "--segment", "tail", "--out", str(tmp_path / "x")]) == 2
    assert "unknown segment 'tail'" in capsys.readouterr().err
    assert main(["learn", "--resume", str(tmp_path / "none")]) == 2
    assert "not a learning run folder" in capsys.readouterr().err


def test_a_randomised_candidate_scores_the_mean_or_worst_of_its_robots():
    import dataclasses as dc

    from tensim.learn.families import default_base
    from tensim.learn.problem import TrialProblem
    from tensim.models import preset as get_preset
    from tensim.sim import PhysicsScale

    structure = get_preset("tetraspine3").build()
    problem = TrialProblem(structure, default_base("tetraspine3", "cpg", structure), "cpg", 1.5,
                           randomize=(("friction", 0.5, 1.5), ("stiffness", 0.9, 1.1)),
                           robots=3)
    draws = problem.physics
    assert len(set(draws)) == 3 and all(0.5 <= d.friction <= 1.5 for d in draws)
    unit = np.random.default_rng(2).random(problem.dimension)
    mean = problem.evaluate(unit)
    each = [dc.replace(problem, randomize=(), robots=1)._score(r) for r in _runs(problem, unit)]
    scores = [o.score for o in each]
    assert len(set(scores)) == 3  # the robots differ
    assert mean.score == pytest.approx(np.mean(scores), rel=1e-12)
    worst = dc.replace(problem, robust="worst").evaluate(unit)
    assert worst.score == min(scores)
    assert PhysicsScale() not in draws


def _runs(problem, unit):
    from tensim.sim import Trial, run_batch

    compiled = problem.compiled()
    controller = problem.controller(unit).build(compiled.model.opt.timestep)
    return [run_batch(compiled, [Trial(controller, physics=ps)], problem.duration_s)[0]
            for ps in problem.physics]


def test_learn_command_runs_its_trials_under_the_cable_law_it_is_given(tmp_path):
    out = tmp_path / "implicit"
    assert main(["--quiet", "learn", "--model", "tetraspine3", "--controller", "sine-pattern",
                 "--optimizer", "cma", "--evaluations", "2", "--trial-duration", "0.4",
                 "--workers", "0", "--target", "1,0.5", "--cable-law", "implicit",
                 "--out", str(out)]) == 0
    config = json.loads((out / "config.json").read_text())["problem"]
    assert config["world"]["cable_law"] == "implicit"
    # the best trial's score is that of its replay under the implicit law, not the explicit one
    robot = tetraspine3()
    best = load_controller(out / "best_controller.yaml", robot)
    score = json.loads((out / "summary.json").read_text())["best_score"]
    replay = {law: target_progress(simulate(compile_structure(robot, WorldOptions(
        cable_law=law)), best.duration, controller=best.build(1e-3)).trajectory, (1.0, 0.5))
        for law in ("implicit", "explicit")}
    assert replay["implicit"] == score
    assert replay["explicit"] != score  # the laws differ in the last digits at least
    # the law is part of the run: a resume may not change it
    assert main(["learn", "--resume", str(out), "--cable-law", "explicit"]) == 2
