"""The benchmark's machinery (its figures are printed by `tensim bench`, never asserted here)."""

from __future__ import annotations

import math
import sys

import numpy as np

from tensim.benchmarks._machine import core_share, machine_note
from tensim.benchmarks.batch import bench_batch, format_batch
from tensim.benchmarks.engine import Timing, bench_model
from tensim.cli.bench import format_table
from tensim.terrain import Rough


def test_a_bench_case_runs_on_a_terrain_and_names_it():
    ground = Rough(roughness=0.005, correlation=0.1, seed=2, size=1.0, resolution=0.05)
    case = bench_model("prism3", duration=0.05, repeats=2, terrain=ground)
    assert case.name == "prism3 on rough"
    assert len(case.tensim.cpu) == len(case.engine.wall) == 2  # every run kept
    for figure in case.figures().values():
        assert math.isfinite(figure) and figure > 0
    assert bench_model("prism3", 0.05, 1, controlled=False).name == "prism3 (passive)"
    assert "prism3 on rough" in format_table([{"name": case.name, **case.figures()}], 2)


def test_a_bench_case_with_contact_cables_names_them():
    case = bench_model("prism3", duration=0.05, repeats=1, controlled=False,
                       contact_tags=("bottom",))
    assert case.name == "prism3 (passive), contact cables bottom"
    assert all(math.isfinite(f) and f > 0 for f in case.figures().values())


def test_timings_give_best_and_median_per_kind():
    timing = Timing(cpu=(30.0, 10.0, 20.0), wall=(12.0, 40.0, 11.0))
    assert timing.best() == 10.0 and timing.median() == 20.0
    assert timing.best("wall") == 11.0 and timing.median("wall") == 12.0


def test_core_share_is_cpu_over_wall_per_thread():
    # runs that held a core half, all and all of their wall time: the median is 1
    assert core_share(cpu=(1.0, 2.0, 3.0), wall=(2.0, 2.0, 3.0)) == 1.0
    # 2 threads, 3 s of CPU in 2 s of wall: each held a core 75 % of the time
    assert core_share(cpu=(3.0,), wall=(2.0,), threads=2) == 0.75
    assert Timing(cpu=(1.0,), wall=(4.0,)).core_share() == 0.25


def test_the_machine_note_says_when_wall_times_mean_nothing():
    busy = machine_note({"tensim": 0.98, "engine": 0.5}, load_at_start=3.2)
    assert "TOO BUSY" in busy and "50%" in busy and "(engine)" in busy and "3.20" in busy
    assert "TOO BUSY" not in machine_note({"tensim": 0.97, "engine": 0.95}, 0.1)


def test_the_batch_bench_gives_ratios_in_cpu_time_beside_wall_time():
    report = bench_batch(trials=2, duration=0.05, repeats=1)
    for threads in (1, 2):
        batch, engine = report[f"batch_{threads}"], report[f"rollout_{threads}"]
        assert report["batch_over_rollout_cpu"][threads] == engine["cpu_best_s"] / \
            batch["cpu_best_s"]
        # a thread holds at most its core (slack: clocks read at slightly different moments)
        assert 0 < batch["core_share"] <= 1.2
    text = format_batch(report)
    assert "in CPU time" in text and "machine: " in text


def test_the_busy_mode_keeps_a_core_busy_and_ends_with_its_block():
    """The busy loops run while the block does (they take CPU that this process does not),
    and are gone after it."""
    import multiprocessing
    import time

    from tensim.benchmarks._machine import busy

    with busy(1) as loops:
        assert loops == 1
        children = multiprocessing.active_children()
        assert len(children) == 1 and children[0].is_alive()
        time.sleep(0.2)
    assert not children[0].is_alive()


def test_a_whole_process_run_reports_its_cpu_time_and_memory(tmp_path):
    from tensim.benchmarks.process import run_process

    cpu, wall, peak = run_process(["info", "tetraspine3"])
    assert 0 < cpu and 0 < wall and 20 < peak < 2000  # an interpreter with numpy: tens of MiB


def test_the_rl_bench_times_every_case_against_the_engine_and_the_plain_env():
    import pytest

    pytest.importorskip("stable_baselines3", reason="the rl extra is not installed")
    from tensim.benchmarks.rl import CASES, bench_rl, format_rl

    report = bench_rl(envs=(2,), periods=2, repeats=1)
    rows = report["envs"][2]
    assert tuple(rows) == CASES
    for row in rows.values():
        assert math.isfinite(row["cpu_rate"]) and row["cpu_rate"] > 0
    assert rows["raw engine"]["per_engine"] == 1.0
    assert rows["plain MujocoEnv"]["per_plain"] == 1.0
    assert rows["SB3VecEnv"]["per_engine"] == pytest.approx(
        rows["SB3VecEnv"]["cpu_rate"] / rows["raw engine"]["cpu_rate"])
    assert "2 robots" in format_rl(report)


def test_bad_robot_counts_are_refused_by_option():
    import pytest

    from tensim import InputError
    from tensim.cli.bench import _worlds

    assert _worlds("16,64", "--envs", "16,64") == [16, 64]
    for text in ("0,16", "x", ""):
        with pytest.raises(InputError, match="--envs: expected batch sizes such as 16,64"):
            _worlds(text, "--envs", "16,64")


def test_the_plain_env_of_the_rl_bench_observes_what_the_rolling_observation_holds(tmp_path):
    import mujoco
    import pytest

    pytest.importorskip("gymnasium", reason="the rl extra is not installed")
    from tensim.benchmarks.rl import plain_env
    from tensim.io._mjcf_motors import NODE_SITE
    from tensim.io.mjcf import save_mjcf
    from tensim.model import compile_structure
    from tensim.rl._robot import Robot, load_robot
    from tensim.rl.train import TrainSettings

    config = TrainSettings("three_bar", task="roll").env_config()
    robot, structure = Robot(config), load_robot("three_bar")
    mjcf = save_mjcf(compile_structure(structure, config.world), tmp_path / "robot.xml")
    start = mujoco.MjData(robot.model)
    mujoco.mj_setState(robot.model, start, robot.initial_state,
                       mujoco.mjtState.mjSTATE_INTEGRATION)
    ends = [(f"{NODE_SITE}{a}", f"{NODE_SITE}{b}") for a, b in (r.nodes for r in structure.rods)]
    env = plain_env(mjcf, config.control_steps, robot.motors, start.qpos.copy(), ends)
    obs, _ = env.reset(seed=0)
    assert obs.shape == env.observation_space.shape == robot.observation_space.shape
    for _ in range(25):  # settle onto the ground, the motors at their middle tension
        obs, *_ = env.step(np.zeros(robot.motors.size))
    part = {k: obs[a:b] for k, (a, b) in robot.layout.items()}
    np.testing.assert_allclose(part["cable_length"], env.data.ten_length)
    np.testing.assert_allclose(np.linalg.norm(part["rod_axis"].reshape(-1, 3), axis=1), 1.0)
    np.testing.assert_allclose(part["task"], [1.0, 0.0], atol=1e-12)  # the heading, own frame
    tips = env.data.site_xpos[env.ends]
    flagged = part["end_contact"] == 1.0
    assert flagged.any() and (tips[flagged, 2] < 0.1).all()  # end caps on the ground: 25 mm


def test_the_cable_law_bench_shows_what_the_implicit_step_couples():
    """The explicit law's three free bodies are three constraint islands, on Euler's and on
    the discrete step alike (no cable in the metric); the implicit law puts every taut cable
    of the prestressed spine into the discrete step's metric, which joins them into one, and
    so do the cables handed over as tendon springs. Split by cable at 1 ms, the implicit law
    hands over none of the spine's cables (their explicit bound is 6.3 ms): the explicit
    law's islands."""
    from tensim.benchmarks.engine import (
        DISCRETE_EXPLICIT,
        DISCRETE_TENDONS,
        bench_laws,
        format_laws,
        split_row,
    )

    report = bench_laws(duration=0.02, repeats=1)
    laws = report["laws"]
    split = split_row(4.0)
    assert set(laws) == {"explicit", "implicit", "implicitfast", split, DISCRETE_EXPLICIT,
                         DISCRETE_TENDONS}
    for row in ("explicit", DISCRETE_EXPLICIT, split):
        assert laws[row]["islands_per_step"] == 3 and laws[row]["integrator_cables_per_step"] == 0
    assert laws["implicit"]["islands_per_step"] == 1
    assert laws["implicit"]["integrator_cables_per_step"] == 12
    assert laws[DISCRETE_TENDONS]["islands_per_step"] == 1
    assert laws[DISCRETE_TENDONS]["integrator_cables_per_step"] == 12
    assert laws["explicit"]["ratio_to_explicit"] == 1
    assert all(f["solver_iterations_per_step"] > 0 for f in laws.values())
    assert DISCRETE_EXPLICIT in format_laws(report)


def test_no_cases_runs_only_the_batch_and_alone_is_refused(capsys):
    from tensim.cli import main

    assert main(["bench", "--no-cases"]) != 0
    assert "--no-cases leaves nothing to run" in capsys.readouterr().err
    assert main(["bench", "--no-cases", "--batch", "2", "--duration", "0.05",
                 "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert "batch (tetraspine3 cpg, 2 trials of 0.05 s)" in out
    assert "us per physics step" not in out  # no single-run case ran


def test_a_whole_process_run_keeps_its_bytecode_in_the_folder_given(tmp_path, monkeypatch):
    """Timed runs read compiled bytecode, as an installed package does, even where the
    environment turns its writing off."""
    from tensim.benchmarks.process import run_process

    monkeypatch.setenv("PYTHONDONTWRITEBYTECODE", "1")
    run_process(["--help"], bytecode=str(tmp_path))
    # the prefix mirrors each source file's path: .../tensim/cli/__init__.<tag>.pyc
    compiled = {p.parts[-3:] for p in tmp_path.rglob("*.pyc")}
    assert ("tensim", "cli", f"__init__.{sys.implementation.cache_tag}.pyc") in compiled
