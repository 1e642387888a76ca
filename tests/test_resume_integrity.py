"""A resumed learning run proves it continues the same problem: an edited robot file or
configuration, and a damaged, duplicated or out-of-sequence evaluation log are refused, naming
the file and what differs; nothing non-finite reaches summary.json."""

from __future__ import annotations

import json
import math

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from tensim.learn import (
    InlineExecutor,
    LearningSettings,
    OptimizerSettings,
    RunFolderError,
    SphereProblem,
    learn,
    resume,
)
from tensim.learn.store import CONFIG, EVALUATIONS, SUMMARY

SETTINGS = LearningSettings(OptimizerSettings("ntrt", monte_carlo=4, batch=3), 10, seed=3)


@pytest.fixture(scope="module")
def sphere_run(tmp_path_factory):
    """A finished 10-evaluation sphere run (copied by each test that edits it)."""
    out = tmp_path_factory.mktemp("runs") / "sphere"
    learn(SphereProblem(3), SETTINGS, out, executor=InlineExecutor)
    return out


def _copy(src, dst):
    import shutil

    shutil.copytree(src, dst, ignore=shutil.ignore_patterns(".lock"))
    return dst


def _lines(folder):
    return (folder / EVALUATIONS).read_text().splitlines()


def _write_lines(folder, lines):
    (folder / EVALUATIONS).write_text("".join(line + "\n" for line in lines))


def test_an_untouched_run_resumes_and_extends(sphere_run, tmp_path):
    run = _copy(sphere_run, tmp_path / "run")
    result = resume(run, 13, executor=InlineExecutor)
    assert result.nfev == 13
    json.loads((run / SUMMARY).read_text())  # plain JSON


@pytest.mark.parametrize(("edit", "named"), [
    (lambda c: c["problem"].update(center=0.9), "problem (config.json)"),
    (lambda c: c.update(seed=4), "seed (config.json)"),
    (lambda c: c["optimizer"].update(batch=4), "optimizer (config.json)"),
    (lambda c: c.pop("defines_sha256"), "holds no 'defines_sha256'"),
])
def test_an_edited_configuration_is_refused_naming_what_differs(sphere_run, tmp_path, edit,
                                                                named):
    run = _copy(sphere_run, tmp_path / "run")
    config = json.loads((run / CONFIG).read_text())
    edit(config)
    (run / CONFIG).write_text(json.dumps(config))
    with pytest.raises(RunFolderError, match=re_escape(named)):
        resume(run, 13, executor=InlineExecutor)


def re_escape(text: str) -> str:
    import re

    return re.escape(text)


def _edit_line(folder, k, **changes):
    lines = _lines(folder)
    record = json.loads(lines[k])
    record.update(changes)
    lines[k] = json.dumps(record)
    _write_lines(folder, lines)


@pytest.mark.parametrize(("changes", "match"), [
    ({"score": math.nan}, r"line 3 is damaged \(score nan"),
    ({"score": math.inf}, r"line 3 is damaged \(score inf"),
    ({"score": -math.inf}, r"line 3 is damaged \(score -inf"),
    ({"index": 1}, r"line 3 is damaged \(evaluation 1 recorded a second time"),
    ({"index": -2}, r"line 3 is damaged \(a negative index"),
    ({"index": 2.5}, r"line 3 is damaged \(index must be a whole number"),
    ({"index": True}, r"line 3 is damaged \(index must be a whole number"),
    ({"index": "2"}, r"line 3 is damaged \(index must be a whole number"),
    ({"index": 10**400}, r"evaluation 10{400} is out of sequence|damaged"),
    ({"score": 1e400}, r"line 3 is damaged \(score inf"),
])
def test_a_damaged_evaluation_log_is_refused_naming_the_line(sphere_run, tmp_path, changes,
                                                             match):
    run = _copy(sphere_run, tmp_path / "run")
    _edit_line(run, 2, **changes)
    with pytest.raises(RunFolderError, match=match):
        resume(run, 13, executor=InlineExecutor)
    assert "Infinity" not in (run / SUMMARY).read_text()


def test_an_out_of_sequence_evaluation_is_refused(sphere_run, tmp_path):
    run = _copy(sphere_run, tmp_path / "run")
    lines = _lines(run)
    # a record far ahead of the optimizer (the told ones intact)
    _write_lines(run, [*lines, json.dumps({**json.loads(lines[0]), "index": 40})])
    with pytest.raises(RunFolderError, match="evaluation 40 is out of sequence"):
        resume(run, 13, executor=InlineExecutor)
    # one the told prefix lacks: the existing check refuses it too
    _write_lines(run, [*lines[:8], json.dumps({**json.loads(lines[9]), "index": 20})])
    with pytest.raises(RunFolderError, match="agree on only"):
        resume(run, 13, executor=InlineExecutor)


@settings(max_examples=40, derandomize=True, database=None, deadline=None)
@given(st.integers(0, 9), st.sampled_from(["index", "score", "unit", "values", "status"]),
       st.one_of(st.integers(-3, 30), st.floats(allow_nan=True, allow_infinity=True),
                 st.text(max_size=3), st.none(), st.lists(st.floats(), max_size=4)))
def test_any_edited_log_line_resumes_consistently_or_is_refused(sphere_run, tmp_path_factory,
                                                               k, field, value):
    run = _copy(sphere_run, tmp_path_factory.mktemp("fuzz") / "run")
    _edit_line(run, k, **{field: value})
    try:
        resume(run, 12, executor=InlineExecutor)
    except RunFolderError:
        return
    # accepted: the summary is plain JSON with finite figures
    summary = json.loads((run / SUMMARY).read_text(),
                         parse_constant=lambda c: pytest.fail(f"summary.json holds {c}"))
    assert math.isfinite(summary["best_score"])


def test_an_edited_structure_is_refused(tmp_path):
    from tensim.learn import TrialProblem, default_base
    from tensim.learn.objective import Objective
    from tensim.models import tetraspine3

    robot = tetraspine3()
    problem = TrialProblem(robot, default_base("tetraspine3", "sine-pattern", robot),
                           "sine-pattern", 0.05, Objective(), model="tetraspine3")
    run = tmp_path / "trial"
    learn(problem, LearningSettings(OptimizerSettings("ntrt", monte_carlo=1, batch=1), 1),
          run, executor=InlineExecutor)
    data = yaml.safe_load((run / "structure.yaml").read_text())
    data["cables"][0]["stiffness"] *= 2  # another robot
    (run / "structure.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    with pytest.raises(RunFolderError, match=r"structure\.yaml changed since the run was "
                                             "created"):
        resume(run, 2, executor=InlineExecutor)


@pytest.mark.parametrize("score", [math.nan, math.inf, -math.inf])
def test_a_trial_whose_score_is_not_finite_fails_with_the_penalty(score, tmp_path):
    import dataclasses

    from tensim.learn.problem import ERROR, Outcome

    @dataclasses.dataclass(frozen=True)
    class Broken(SphereProblem):
        def evaluate(self, unit):
            return Outcome(score, metrics={"distance_m": score, "steps": 3.0})

    result = learn(Broken(2), LearningSettings(OptimizerSettings("ntrt", monte_carlo=2,
                                                                 batch=2), 2),
                   tmp_path / "run", executor=InlineExecutor)
    assert result.summary["failed"] == {ERROR: 2}
    assert result.summary["best_score"] == Broken(2).penalty
    text = (tmp_path / "run" / SUMMARY).read_text()
    json.loads(text, parse_constant=lambda c: pytest.fail(f"summary.json holds {c}"))
    json.loads(_lines(tmp_path / "run")[0], parse_constant=lambda c: pytest.fail(c))
