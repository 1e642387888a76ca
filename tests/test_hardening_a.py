"""Silently wrong results and tracebacks of the first hardening round's part A, each now a
clear refusal: a sine gait above the command rate's Nyquist frequency, contact options that
change nothing, DC-motor randomisation on a robot without DC motors, a learning run whose every
trial failed, and huge numbers in ``--contact`` (explicit cases, then hypothesis)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensim import InputError
from tensim.cli import main
from tensim.cli._common import contact_options
from tensim.control.sine import SineController, SineGait, tetraspine_sine
from tensim.model import WorldOptions, compile_structure
from tensim.models.tetraspine import impedance_controller, tetraspine3
from tensim.sim import Simulation

FUZZ = settings(max_examples=60, derandomize=True, database=None, deadline=None)

# -- a sine gait sampled below its Nyquist rate ---------------------------------------------


@pytest.mark.parametrize(("frequency", "steps"),
                         [(500.0, 1), (100.0, 5), (1e6, 1), (50.0, 10)])
def test_a_sine_at_or_above_the_command_nyquist_frequency_is_refused(frequency, steps):
    structure = tetraspine3()
    gait = tetraspine_sine(structure, 0.01, frequency)
    controller = SineController(gait, impedance_controller(3), duration=0.1, sample_steps=steps)
    nyquist = 0.5 / (steps * 1e-3)
    with pytest.raises(InputError, match=re.escape(f"at {frequency:g} Hz is at or above the "
                                                   f"Nyquist frequency {nyquist:g} Hz of its "
                                                   "command period")):
        Simulation(compile_structure(structure), controller=controller)
    with pytest.raises(InputError, match="Nyquist"):
        gait.velocity_table(0.1, steps * 1e-3)


def test_on_main_the_aliased_sine_read_as_zero():
    # the case the refusal guards: 500 Hz sampled every 1 ms is sin(pi k) = 0 at every sample
    gait = SineGait(("c",), 0.03, 500.0)
    assert np.abs(gait.table(np.arange(100) * 1e-3)).max() < 1e-10
    gait.velocity_table(1.0, 1e-3 * 0.999)  # just below Nyquist: accepted


@FUZZ
@given(st.floats(0.0, 1e9), st.integers(1, 20))
def test_any_sine_frequency_is_sampled_faithfully_or_refused(frequency, steps):
    gait = SineGait(("c",), 0.03, frequency)
    period = steps * 1e-3
    try:
        table = gait.velocity_table(0.2, period)
    except InputError:
        assert frequency >= 0.5 / period
        return
    assert frequency < 0.5 / period and table.values.shape[0] >= 2


# -- contact options that change nothing, and huge numbers ---------------------------------


@pytest.mark.parametrize(("text", "match"), [
    ("torsional=0.01", "torsional= acts at condim 4 or 6 only, and condim is 3"),
    ("condim=3,torsional=0.01", "torsional= acts at condim 4"),
    ("rolling=0.001", "rolling= acts at condim 6 only, and condim is 3"),
    ("condim=4,rolling=0.001", "rolling= acts at condim 6 only, and condim is 4"),
    ("noslip=" + "9" * 5000, r"noslip expects int, got '9{12}\.\.\.\(5000 characters\)'"),
    ("condim=" + "4" * 4000, r"condim expects int, got '4{12}\.\.\.\(4000 characters\)'"),
    ("torsional=" + "1" * 400, r"torsional expects float"),
])
def test_contact_options_that_change_nothing_or_are_absurd_are_refused(text, match):
    with pytest.raises(ValueError, match=match):
        WorldOptions(**contact_options(text))


@pytest.mark.parametrize("text", ["noslip=1000000000000000000000", "noslip=-1",
                                  "condim=444444444444444444444", "torsional=1e400",
                                  "rolling=nan,condim=6", "noslip=1001"])
def test_huge_or_non_finite_contact_numbers_are_refused_not_tracebacks(text, capsys):
    assert main(["simulate", "prism3", "--duration", "0.01", "--contact", text]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tensim: error:") and "Traceback" not in err and len(err) < 300


@pytest.mark.parametrize("text", ["condim=4,torsional=0.01", "condim=6,rolling=0.001",
                                  "condim=6,torsional=0.01,rolling=0.001"])
def test_contact_options_at_their_condim_are_taken(text):
    options = WorldOptions(**contact_options(text))
    assert options.condim in (4, 6)


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(["cone", "noslip", "condim", "torsional",
                                           "rolling", "bogus"]),
                          st.one_of(st.integers(-10**30, 10**30).map(str),
                                    st.floats(allow_nan=True).map(repr),
                                    st.text("0123456789.e-+nai", max_size=40),
                                    st.sampled_from(["elliptic", "pyramidal", "3", "4", "6"]))),
                max_size=4))
def test_any_contact_string_gives_world_options_or_a_value_error(entries):
    text = ",".join(f"{k}={v}" for k, v in entries)
    try:
        options = WorldOptions(**contact_options(text))
    except ValueError as err:
        assert len(str(err)) < 300
        return
    assert options.noslip_iterations <= 1000
    assert options.torsional_friction == 0.005 or options.condim >= 4
    assert options.rolling_friction == 0.0001 or options.condim == 6


# -- randomising what the robot lacks ------------------------------------------------------


@pytest.mark.parametrize("name", ["motor_stall", "motor_inertia", "motor_friction"])
def test_dc_motor_randomisation_on_a_robot_without_dc_motors_is_refused(name):
    from tensim.learn import Objective, TrialProblem, default_base

    robot = tetraspine3()
    with pytest.raises(ValueError, match=f"randomize {name}: robot 'tetraspine3' has no DC "
                                         "motors"):
        TrialProblem(robot, default_base("tetraspine3", "cpg", robot), "cpg", 0.5,
                     Objective(), randomize=((name, 0.8, 1.2),), robots=2)
    TrialProblem(robot, default_base("tetraspine3", "cpg", robot), "cpg", 0.5, Objective(),
                 randomize=(("stiffness", 0.8, 1.2),), robots=2)  # a robot has cables


def test_the_command_line_refuses_it_too(tmp_path, capsys):
    code = main(["learn", "--model", "tetraspine3", "--controller", "cpg", "--evaluations",
                 "1", "--trial-duration", "0.2", "--randomize", "motor_stall=0.8:1.2",
                 "--out", str(tmp_path / "run")])
    assert code == 2 and "has no DC motors" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


# -- a learning run whose every trial failed ---------------------------------------------


def test_a_run_whose_every_trial_failed_fails(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["--quiet", "learn", "--model", "tetraspine3", "--controller", "sine-pattern",
                 "--evaluations", "2", "--trial-duration", "0.2", "--max-tilt", "1e-6",
                 "--workers", "0", "--monte-carlo", "2", "--batch", "2", "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 1
    assert "every one of the 2 trials failed (2 flipped" in captured.err
    assert "best score" not in captured.out
    assert math.isfinite(-1.0)  # the penalty is recorded, not reported as a result


# -- render and replay of a run folder edited by hand ----------------------------------------


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "run"
    assert main(["--quiet", "simulate", "prism3", "--duration", "0.2", "--out", str(out)]) == 0
    return out


def _edited(recorded, tmp_path, edit=None, summary=None):
    import shutil

    from tensim.sim import TimeSeries

    run = tmp_path / "run"
    shutil.copytree(recorded, run)
    if edit is not None:
        series = TimeSeries.from_parquet(run / "trajectory.parquet")
        time, channels = series.time.copy(), {k: v.copy() for k, v in series.channels.items()}
        edit(time, channels)
        TimeSeries(time, channels).to_parquet(run / "trajectory.parquet")
    if summary is not None:
        import json

        data = json.loads((run / "summary.json").read_text())
        data.update(summary)
        (run / "summary.json").write_text(json.dumps(data))
    return run


def _set(column, row, value):
    def edit(time, channels):
        (time if column == "time" else channels[column])[row] = value
    return edit


@pytest.mark.parametrize(("edit", "match"), [
    (_set("pos_z/rod_0", 7, math.nan), r"column 'pos_z/rod_0', row 7 .* nan is not a finite"),
    (_set("quat_w/rod_1", 3, math.inf), r"column 'quat_w/rod_1', row 3 .* inf is not"),
    (_set("time", 5, 0.0), r"column 'time' does not increase at row 5"),
    (_set("time", 9, math.nan), r"column 'time', row 9: nan is not a finite time"),
    (lambda t, c: t.__setitem__(slice(None), t[::-1].copy()), "does not increase at row 1"),
])
def test_a_hand_edited_trajectory_is_refused_naming_column_and_row(recorded, tmp_path, edit,
                                                                   match, capsys):
    from tensim.viz.replay import RunFolderError, load_run

    run = _edited(recorded, tmp_path, edit)
    with pytest.raises(RunFolderError, match=match):
        load_run(run)
    assert main(["render", str(run), "--out", str(tmp_path / "v.mp4")]) == 2
    assert "trajectory.parquet: column" in capsys.readouterr().err


@pytest.mark.parametrize("summary", [
    {"noslip_iterations": 10**30}, {"noslip_iterations": 1e300}, {"condim": 1e308},
    {"dt_s": 1e308}, {"dt_s": -1}, {"dt_s": "fast"}, {"cone": ["x"]}, {"condim": None},
    {"torsional_friction_m": 10**400}, {"terrain": "rough:roughness=" + "9" * 400},
    {"model": 5}, {"contact_timeconst_s": 0},
])
def test_a_summary_with_absurd_options_is_refused_not_a_traceback(recorded, tmp_path, summary):
    from tensim.viz.replay import RunFolderError, load_run

    run = _edited(recorded, tmp_path, summary=summary)
    with pytest.raises(RunFolderError, match=r"summary\.json"):
        load_run(run)


def test_a_damaged_trajectory_file_is_refused(recorded, tmp_path):
    from tensim.viz.replay import RunFolderError, load_run

    run = _edited(recorded, tmp_path)
    (run / "trajectory.parquet").write_bytes(b"PAR1 not really")
    with pytest.raises(RunFolderError, match=r"trajectory\.parquet: cannot be read"):
        load_run(run)


@pytest.mark.parametrize("name", ["trajectory.parquet", "summary.json", "structure.yaml"])
def test_render_out_onto_the_runs_own_files_is_refused(recorded, tmp_path, name, capsys):
    run = _edited(recorded, tmp_path)
    before = (run / name).read_bytes()
    assert main(["render", str(run), "--out", str(run / name)]) == 2
    assert f"is the run's own {name}" in capsys.readouterr().err
    assert (run / name).read_bytes() == before


def test_render_out_onto_its_model_file_is_refused(recorded, tmp_path, capsys):
    import shutil

    model = tmp_path / "robot.yaml"
    shutil.copy(recorded / "structure.yaml", model)
    assert main(["render", str(model), "--out", str(model), "--duration", "0.1"]) == 2
    assert "is the input" in capsys.readouterr().err


# -- a DC motor's spool, a batch's size and Ctrl-C -------------------------------------------


@pytest.mark.parametrize("radius", [1e-300, 1e-200, 1e-160, 1e160, 1e300, 5e-324])
def test_an_absurd_spool_radius_is_refused_not_a_traceback(radius):
    from tensim.structure import DCMotor, StructureError

    with pytest.raises(StructureError,
                       match=re.escape(f"spool_radius {radius:g} m makes the motor's")):
        DCMotor(spool_radius=radius)


@FUZZ
@given(st.floats(allow_nan=True, allow_infinity=True),
       st.floats(1e-6, 1e3), st.floats(1e-6, 1e3))
def test_any_spool_gives_finite_motor_figures_or_a_structure_error(radius, torque, speed):
    from tensim.structure import DCMotor, StructureError

    try:
        motor = DCMotor(spool_radius=radius, stall_torque=torque, no_load_speed=speed)
    except StructureError:
        return
    line = motor.line()
    assert all(math.isfinite(v) for v in line.values()) and line["stall_force"] > 0


def test_a_batch_past_the_step_limit_is_refused_before_it_runs(monkeypatch):
    from tensim.limits import MAX_STEPS
    from tensim.sim import Trial, _batch, run_batch

    def never(*args, **kwargs):
        raise AssertionError("the batch was set up before its size was checked")

    monkeypatch.setattr(_batch, "_BatchRun", never)
    monkeypatch.setattr(_batch, "SoloTrial", never)
    compiled = compile_structure(tetraspine3())
    with pytest.raises(InputError, match=r"4 trials of 100000 s at a physics step of 0.001 s: "
                                         r"physics steps: 4e\+08 is more than the limit"):
        run_batch(compiled, [Trial(impedance_controller(3))] * 4, 1e5, record_dt=10.0)
    assert MAX_STEPS == 100_000_000


def test_a_long_batch_stops_promptly_on_ctrl_c():
    # judged in simulated time, not wall time: Ctrl-C arrives (from another thread, as from a
    # terminal) while the batch steps; it must stop at the end of the block of steps under
    # way, so at most one more progress report (about one simulated second) follows it
    import os
    import signal
    import threading

    from tensim.sim import Trial, run_batch

    compiled = compile_structure(tetraspine3())
    sent = threading.Event()
    after: list[float] = []

    def progress(done, total):
        if sent.is_set():
            after.append(done)
        elif done > 0:
            threading.Thread(target=lambda: (os.kill(os.getpid(), signal.SIGINT), sent.set())
                             ).start()

    with pytest.raises(KeyboardInterrupt):
        run_batch(compiled, [Trial(impedance_controller(3))] * 2, 600.0, threads=2,
                  record_dt=1.0, progress=progress)
    assert len(after) <= 1, after


# -- messages name --out and the file's line, not staging folders, lock files or whole files --


def test_a_long_out_name_writes_the_run_and_names_no_staging_folder(tmp_path, capsys):
    out = tmp_path / ("r" * 250)
    assert main(["--quiet", "simulate", "prism3", "--duration", "0.05", "--out", str(out)]) == 0
    assert (out / "summary.json").is_file()
    assert [p.name for p in tmp_path.iterdir()] == [out.name]  # no staging folder left
    assert ".partial-" not in capsys.readouterr().out


def test_a_write_error_in_a_run_folder_names_out_not_the_staging_folder(tmp_path):
    from tensim.runs import replace_folder

    out = tmp_path / "run"
    with pytest.raises(InputError) as info, replace_folder(out) as stage:
        (stage / "figures" / "a.png").write_bytes(b"")  # no such subfolder
    message = str(info.value)
    assert message.startswith(f"--out {out}: cannot be written while writing figures/a.png")
    assert ".partial-" not in message and not out.exists()
    # an error about another file is not rewritten
    with pytest.raises(FileNotFoundError), replace_folder(out):
        (tmp_path / "elsewhere" / "x").read_text()


def test_a_learning_run_whose_lock_cannot_be_opened_names_the_folder(tmp_path, capsys):
    from tensim.learn import InlineExecutor, LearningSettings, OptimizerSettings, SphereProblem
    from tensim.learn import learn as learn_run

    out = tmp_path / "run"
    settings = LearningSettings(OptimizerSettings("ntrt", monte_carlo=2, batch=2), 2)
    learn_run(SphereProblem(2), settings, out, executor=InlineExecutor)
    (out / ".lock").unlink()
    (out / ".lock").mkdir()
    assert main(["--quiet", "learn", "--resume", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{out}: cannot be opened as a learning run folder" in err and ".lock" not in err


@pytest.mark.parametrize("content", ["- " + "\n- ".join(f"node{i}" for i in range(300)),
                                     "a long line of text " * 200,
                                     "nodes:\n  a: [0, 0, " + ", ".join(["1"] * 500) + "]"])
def test_an_included_file_is_named_with_its_line_not_echoed(tmp_path, content, capsys):
    (tmp_path / "sub.yaml").write_text(content + "\n")
    (tmp_path / "top.yaml").write_text("substructures:\n  a:\n    path: sub.yaml\n")
    assert main(["import-ntrt", str(tmp_path / "top.yaml"), "--units", "m", "--out",
                 str(tmp_path / "out.yaml")]) == 2
    err = capsys.readouterr().err
    assert f"{tmp_path / 'sub.yaml'}:" in err and len(err) < 300


@pytest.mark.parametrize(("section", "entry"), [("cables", list(range(2000))),
                                                ("rods", "x" * 5000), ("nodes", [[0] * 999])])
def test_a_structure_entry_of_the_wrong_kind_is_described_not_echoed(tmp_path, section, entry,
                                                                     capsys):
    import yaml

    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump({"name": "r", section: [entry]}))
    assert main(["simulate", str(path), "--duration", "0.01"]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and len(err) < 400


@settings(max_examples=30, derandomize=True, database=None, deadline=None)
@given(st.sampled_from(["time", "pos_x/rod_0", "pos_z/rod_2", "quat_w/rod_1", "quat_z/rod_0",
                        "tension/top_0"]),
       st.integers(0, 20), st.floats(allow_nan=True, allow_infinity=True))
def test_any_edited_trajectory_cell_replays_faithfully_or_is_refused(recorded, tmp_path_factory,
                                                                    column, row, value):
    from tensim.viz.replay import PoseReplay, RunFolderError, load_run

    run = _edited(recorded, tmp_path_factory.mktemp("cell"), _set(column, row, value))
    try:
        replay = PoseReplay(load_run(run))
    except RunFolderError as err:
        assert "trajectory.parquet: column" in str(err)
        return
    assert np.all(np.diff(replay.time) > 0) and np.all(np.isfinite(replay._qpos))


def test_a_batch_scaling_dc_motors_the_robot_lacks_is_refused():
    from tensim.sim import PhysicsScale, Trial, run_batch

    compiled = compile_structure(tetraspine3())
    with pytest.raises(ValueError, match="trial 1: physics motor_stall scales DC motors, and "
                                         "the robot has none"):
        run_batch(compiled, [Trial(impedance_controller(3)),
                             Trial(impedance_controller(3), physics=PhysicsScale(
                                 motor_stall=1.2))], 0.01)
