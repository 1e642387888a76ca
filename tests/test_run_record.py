"""A run folder records what it takes to replay and rerun it: robot, controller, ground, step."""

from __future__ import annotations

import json

import numpy as np

from tensim.cli import main
from tensim.control import load_controller
from tensim.models import preset
from tensim.structure import load_structure
from tensim.terrain import Hills, Slope, parse_terrain
from tensim.viz.replay import load_run


def test_simulate_on_a_terrain_replays_on_that_terrain(tmp_path):
    out = tmp_path / "run"
    assert main(["--quiet", "simulate", "prism3", "--terrain", "hills:height=0.05",
                 "--duration", "0.1", "--dt", "0.002", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert parse_terrain(summary["terrain"]) == Hills(height=0.05)
    assert summary["controller"] == "none (passive cables)"
    assert summary["dt_s"] == 0.002 and summary["self_collision"] is True
    run = load_run(out)
    assert run.compiled.world.terrain == Hills(height=0.05)
    assert run.compiled.model.opt.timestep == 0.002
    # the robot as built (compiling lifts it onto the hills, in the run as in the replay)
    assert load_structure(out / "structure.yaml") == preset("prism3").build()
    assert {"tensions.png", "lengths.png", "path.png"} <= set(summary["figures"])


def test_a_gait_run_keeps_its_controller_robot_and_world_options(tmp_path):
    out = tmp_path / "cpg"
    assert main(["--quiet", "experiment", "cpg", "--terrain", "slope:angle=2",
                 "--no-self-collision", "--contact", "cone=elliptic,condim=6,rolling=0.001",
                 "--duration", "0.2", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert {"structure.yaml", "controller.yaml"} <= set(summary["files"])
    run = load_run(out)
    assert run.compiled.world.terrain == Slope(angle=2.0)
    assert run.compiled.world.self_collision is False
    world = run.compiled.world  # the contact model too, as given and as defaulted
    assert (world.cone, world.condim, world.rolling_friction) == ("elliptic", 6, 0.001)
    assert (world.noslip_iterations, world.torsional_friction) == (0, 0.005)
    config = load_controller(out / "controller.yaml", run.compiled.structure)
    assert config.gait is not None and config.model == "tetraspine3"


def test_the_disturbance_summary_names_the_controller_that_ran(tmp_path):
    out = tmp_path / "d"
    assert main(["--quiet", "experiment", "disturbance", "--duration", "0.1",
                 "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert "impedance" in summary["controller"] and summary["terrain"] == "flat"
    assert (out / "controller.yaml").is_file()


def test_the_timestep_study_runs_as_long_as_asked(tmp_path):
    out = tmp_path / "ts"
    assert main(["--quiet", "experiment", "timestep", "--duration", "0.2",
                 "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["duration_s"] == 0.2
    assert set(summary["max_change_percent"]) == {"250", "4000"}


def test_a_robot_of_hundreds_of_cables_prints_a_summary_not_every_cable(capsys, tmp_path):
    from tensim.cli._common import LISTED_CABLES, TOP_CABLES, print_summary

    tensions = {f"c{k}": float(k) for k in range(3 * LISTED_CABLES)}
    print_summary({"duration_s": 1.0, "wall_s": 0.1, "real_time_factor": 10.0,
                   "max_tension_N": tensions, "max_system_tension_N": 89.0}, tmp_path)
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 3 + TOP_CABLES
    assert "90 cables" in out[2] and "median 44.500 N" in out[2]
    assert out[3].split() == ["c89", "89.000"]  # the most loaded first


def test_simulate_prints_the_peaks_the_law_tracked_beside_each_tension(capsys, tmp_path):
    """The per-cable table carries summary.json's tracked peaks, each in its own column and
    row (a swapped key or a shifted row would show)."""
    from tensim.cli._common import print_summary

    summary = {"duration_s": 1.0, "wall_s": 0.1, "real_time_factor": 10.0,
               "max_tension_N": {"a": 10.0, "b": 20.0}, "max_system_tension_N": 20.0,
               "max_line_speed_m_s": {"a": 0.25, "b": 0.0},
               "max_power_W": {"a": 2.5, "b": 0.0}}
    print_summary(summary, tmp_path)
    out = capsys.readouterr().out.splitlines()
    assert "line speed [m/s] and power [W]" in out[2]
    assert out[3].split() == ["a", "10.000", "0.2500", "2.500"]
    assert out[4].split() == ["b", "20.000", "0.0000", "0.000"]
    # an older summary without the peaks prints tensions alone
    del summary["max_line_speed_m_s"], summary["max_power_W"]
    print_summary(summary, tmp_path)
    assert capsys.readouterr().out.splitlines()[3].split() == ["a", "10.000"]


def _model_bytes(model) -> bytes:
    import mujoco
    import numpy as np

    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return buffer.tobytes()


def test_the_report_frames_the_model_simulate_ran_which_the_folder_rebuilds(tmp_path,
                                                                             monkeypatch):
    # simulate hands its compiled robot to the report's frame instead of compiling the
    # folder's structure file again: that model must be the one a replay of the folder builds,
    # byte for byte (a controller and a terrain on, so the world and the run both count)
    from tensim.viz import replay

    handed = []
    real = replay.recorded_run

    def spy(folder, summary, series, compiled=None):
        handed.append(compiled)
        return real(folder, summary, series, compiled)

    monkeypatch.setattr(replay, "recorded_run", spy)
    out = tmp_path / "run"
    assert main(["--quiet", "simulate", "tetraspine3", "--controller", "tetraspine3_sine",
                 "--terrain", "slope:angle=2", "--duration", "0.05", "--out", str(out)]) == 0
    if not handed:  # no offscreen OpenGL here: the report drew no frame
        return
    assert handed[0] is not None
    assert _model_bytes(handed[0].model) == _model_bytes(load_run(out).compiled.model)


def test_a_trajectory_file_reads_back_bit_for_bit(tmp_path) -> None:
    """Parquet without dictionary pages still stores every sample exactly: constant, repeated,
    signed-zero, NaN and infinite values, in the channels' order."""
    from tensim.sim import TimeSeries

    time = np.arange(7) * 0.01
    channels = {"tension/a": np.array([0.0, -0.0, 1.5, 1.5, np.nan, np.inf, 1e-300]),
                "length/a": np.full(7, 0.1), "rest_length/a": np.random.default_rng(1).random(7)}
    TimeSeries(time, channels).to_parquet(tmp_path / "t.parquet")
    back = TimeSeries.from_parquet(tmp_path / "t.parquet")
    assert back.time.tobytes() == time.tobytes()
    assert list(back.channels) == list(channels)
    for name, values in channels.items():
        assert back[name].tobytes() == values.tobytes()


def test_simulate_timings_print_each_stage_and_add_up_to_the_whole_command(tmp_path, capsys):
    """--timings prints the CPU seconds of every stage of the command, the start-up, the rest
    and the child processes, which add up to the whole command's (to the printed rounding)."""
    out = tmp_path / "run"
    assert main(["--quiet", "simulate", "prism3", "--duration", "0.05", "--no-figures",
                 "--timings", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    table = text[text.index("CPU time by stage [s]:"):].splitlines()[1:]
    rows = {line[:-8].strip(): float(line[-8:]) for line in table}
    for stage in ("Python start-up and the command line's imports", "load the structure",
                  "pre-run check (tensim check)", "compile", "simulate",
                  "trajectory.parquet, structure.yaml, report, frame.png",
                  "the rest of the command", "child processes (drawing, the OpenGL frame)"):
        assert rows[stage] >= 0, stage
    whole = rows.pop("whole command")
    assert abs(sum(rows.values()) - whole) <= 0.005 * len(rows) + 1e-9  # each row rounded
