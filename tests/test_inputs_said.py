"""Inputs that say one thing and must not run another, and resumes that see every input: a NaN
knot time, a ramp that exactly fills its window, a repeated randomised parameter, an edited
height-field file under a learning run, and refused or failed learning runs that must leave no
folder behind."""

from __future__ import annotations

import numpy as np
import pytest

from tensim.cli import main
from tensim.learn import (
    InlineExecutor,
    LearningSettings,
    OptimizerSettings,
    RunFolderError,
    SphereProblem,
    TrialProblem,
    create_run,
    default_base,
    learn,
    resume,
)
from tensim.learn.objective import Objective
from tensim.loads import LoadError, load_loads, parse_push
from tensim.model import WorldOptions
from tensim.models import PRESETS
from tensim.terrain import parse_terrain

# -- loads --------------------------------------------------------------------------------


@pytest.mark.parametrize("times", ["[0, .nan, 2]", "[.nan, 1, 2]", "[0, 1, .inf]"])
def test_a_non_finite_knot_time_is_refused_naming_the_entry(tmp_path, times):
    path = tmp_path / "loads.yaml"
    path.write_text(f"loads:\n  - {{node: t0, times: {times}, "
                    "forces: [[0, 0, 0], [5, 0, 0], [0, 0, 0]]}\n")
    with pytest.raises(LoadError, match=r"loads\[0\]: .*times must be finite"):
        load_loads(path)


@pytest.mark.parametrize(("window", "ramp"), [("0.1-0.3", "0.1"), ("0.7-1.3", "0.3"),
                                              ("1-1.2", "0.1")])
def test_a_ramp_that_exactly_fills_its_window_is_taken(window, ramp):
    load = parse_push(f"t0:5,0,0@{window}/{ramp}")
    start, stop = (float(x) for x in window.split("-"))
    # up to the full force at the window's middle and straight back down
    np.testing.assert_allclose(load.times, [start, (start + stop) / 2, stop])
    np.testing.assert_allclose(load.forces[:, 0], [0, 5, 0])
    with pytest.raises(LoadError, match="must be > 0 and fit twice"):
        parse_push(f"t0:5,0,0@{window}/{float(ramp) * 1.01}")


# -- learning runs: repeated names, refused starts, every input in the fingerprint -----------


def _trial(structure_name="prism3", terrain="flat", randomize=()):
    robot = PRESETS[structure_name].build()
    return TrialProblem(robot, default_base(structure_name, "sine", robot), "sine", 0.02,
                        Objective(), WorldOptions(terrain=parse_terrain(terrain)),
                        model=structure_name, randomize=randomize)


def test_a_repeated_randomised_parameter_is_refused():
    with pytest.raises(ValueError, match="randomize friction: given more than once"):
        _trial(randomize=(("friction", 0.7, 1.3), ("friction", 0.9, 1.1)))


def test_a_refused_learning_run_leaves_no_folder(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["--quiet", "learn", "--model", "prism3", "--controller", "sine",
                 "--randomize", "friction=0.7:1.3,friction=0.9:1.1", "--evaluations", "1",
                 "--trial-duration", "0.02", "--out", str(out)]) == 2
    assert "given more than once" in capsys.readouterr().err
    assert not out.exists()


def test_a_run_whose_executor_cannot_start_leaves_no_folder(tmp_path):
    def broken(problem):
        raise RuntimeError("no executor")

    settings = LearningSettings(OptimizerSettings("ntrt", monte_carlo=1, batch=1), 1)
    for out in (tmp_path / "new", tmp_path / "empty"):
        if out.name == "empty":
            out.mkdir()
        with pytest.raises(RuntimeError, match="no executor"):
            learn(SphereProblem(2), settings, out, executor=broken)
        assert (not out.exists()) if out.name == "new" else not list(out.iterdir())
        learn(SphereProblem(2), settings, out, executor=InlineExecutor)  # nothing refuses it


def test_a_failed_creation_removes_what_it_wrote(tmp_path, monkeypatch):
    from tensim.learn import store as store_module

    def full(self, config):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(store_module.RunStore, "write_config", full)
    out = tmp_path / "run"
    with pytest.raises(OSError):
        create_run(out, SphereProblem(2), LearningSettings(OptimizerSettings("ntrt"), 1))
    assert not out.exists()
    # a folder that holds a run is refused and kept whole
    monkeypatch.undo()
    learn(SphereProblem(2), LearningSettings(OptimizerSettings("ntrt", monte_carlo=1,
                                                               batch=1), 1), out,
          executor=InlineExecutor)
    before = sorted(p.name for p in out.iterdir())
    with pytest.raises(RunFolderError, match="already holds a learning run"):
        create_run(out, SphereProblem(2), LearningSettings(OptimizerSettings("ntrt"), 1))
    assert sorted(p.name for p in out.iterdir()) == before


def test_a_resume_refuses_an_edited_height_field_file(tmp_path):
    field = tmp_path / "ground.npy"
    np.save(field, np.zeros((5, 5)))
    problem = _trial(terrain=f"heightfield:file={field},length=4")
    run = tmp_path / "run"
    settings = LearningSettings(OptimizerSettings("ntrt", monte_carlo=1, batch=1), 1)
    learn(problem, settings, run, executor=InlineExecutor)
    np.save(field, np.full((5, 5), 0.2))  # another ground under the same name
    with pytest.raises(RunFolderError, match=f"terrain file {field} changed since the run"):
        resume(run, 2, executor=InlineExecutor)
    np.save(field, np.zeros((5, 5)))  # restored: the run continues
    assert resume(run, 2, executor=InlineExecutor).nfev == 2
