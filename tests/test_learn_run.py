"""Run folders: every evaluation logged, resume equals an uninterrupted run, torn logs survive."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from tensim.learn import (
    InlineExecutor,
    LearningSettings,
    OptimizerSettings,
    RunFolderError,
    RunStore,
    SphereProblem,
    learn,
    resume,
)
from tensim.learn.problem import Outcome
from tensim.learn.store import EVALUATIONS


class _Interrupt(Exception):
    """Stands for Ctrl-C or a killed machine in the middle of a run."""


def _stop_after(k: int):
    def progress(done: int, total: int, best: float | None, failed: int) -> None:
        if done >= k:
            raise _Interrupt

    return progress


def _records(folder) -> list[tuple[int, tuple[float, ...], float]]:
    evaluations = RunStore(folder).evaluations()
    return [(i, evaluations[i].unit, evaluations[i].score) for i in sorted(evaluations)]


@dataclasses.dataclass(frozen=True)
class _CountingSphere(SphereProblem):
    """A sphere that also counts its trials (in this process: an inline executor)."""

    calls: list = dataclasses.field(default_factory=list, compare=False)

    def evaluate(self, unit: np.ndarray) -> Outcome:
        self.calls.append(1)
        return super().evaluate(unit)


@pytest.mark.parametrize("name", ["ntrt", "cma", "nelder-mead"])
@pytest.mark.parametrize("stop", [13, 37])
def test_interrupted_and_resumed_run_ends_with_the_uninterrupted_evaluations(tmp_path, name,
                                                                            stop):
    settings = LearningSettings(OptimizerSettings(name, monte_carlo=16, batch=5), 60, seed=11)
    learn(SphereProblem(5), settings, tmp_path / "whole", executor=InlineExecutor)
    problem = _CountingSphere(5)
    with pytest.raises(_Interrupt):
        learn(problem, settings, tmp_path / "cut", executor=InlineExecutor,
              progress=_stop_after(stop))  # stops inside a batch: some of it logged, not told
    assert len(RunStore(tmp_path / "cut").evaluations()) == stop
    counting = _CountingSphere(5)
    result = resume(tmp_path / "cut", executor=lambda _: InlineExecutor(counting))
    assert len(counting.calls) == 60 - stop  # no finished trial is run again
    assert _records(tmp_path / "cut") == _records(tmp_path / "whole")  # bit for bit
    assert result.nfev == 60


def test_a_budget_extended_by_resume_equals_the_larger_budget_from_the_start(tmp_path):
    # 23 ends inside an NTRT batch of 8: that batch is evaluated, told only after extension
    short = LearningSettings(OptimizerSettings("ntrt", monte_carlo=16), 23, seed=5)
    learn(SphereProblem(4), short, tmp_path / "short", executor=InlineExecutor)
    resume(tmp_path / "short", 50, executor=InlineExecutor)
    long = dataclasses.replace(short, evaluations=50)
    learn(SphereProblem(4), long, tmp_path / "long", executor=InlineExecutor)
    assert _records(tmp_path / "short") == _records(tmp_path / "long")
    config = json.loads((tmp_path / "short" / "config.json").read_text())
    assert config["evaluations"] == 50


def test_summary_reports_the_logged_run(tmp_path):
    settings = LearningSettings(OptimizerSettings("cma"), 30, seed=2)
    result = learn(SphereProblem(3), settings, tmp_path, executor=InlineExecutor)
    summary = json.loads((tmp_path / "summary.json").read_text())
    scores = [e.score for e in RunStore(tmp_path).evaluations().values()]
    assert summary["evaluations"] == 30 == result.nfev
    assert summary["best_score"] == max(scores) == result.best_score == -result.fun
    # evaluations_per_s is rounded to 4 decimals
    assert summary["evaluations_per_s"] == pytest.approx(30 / summary["wall_s"], abs=1e-4)
    assert summary["config"]["seed"] == 2 and summary["config"]["versions"]["tensim"]
    assert (tmp_path / "learning_curve.png").stat().st_size > 0


def test_a_torn_last_log_line_is_dropped_and_rerun(tmp_path):
    settings = LearningSettings(OptimizerSettings("ntrt", monte_carlo=8, batch=4), 12, seed=0)
    learn(SphereProblem(3), settings, tmp_path / "whole", executor=InlineExecutor)
    with pytest.raises(_Interrupt):
        learn(SphereProblem(3), settings, tmp_path / "cut", executor=InlineExecutor,
              progress=_stop_after(6))
    log = tmp_path / "cut" / EVALUATIONS
    log.write_text(log.read_text() + '{"index": 6, "unit": [0.1')  # killed mid-write
    assert len(RunStore(tmp_path / "cut").evaluations()) == 6
    resume(tmp_path / "cut", executor=InlineExecutor)
    assert _records(tmp_path / "cut") == _records(tmp_path / "whole")


def test_a_run_folder_is_never_overwritten_and_must_exist_to_resume(tmp_path):
    settings = LearningSettings(OptimizerSettings("ntrt", monte_carlo=4), 4)
    learn(SphereProblem(2), settings, tmp_path / "run", executor=InlineExecutor)
    with pytest.raises(RunFolderError, match="already holds"):
        learn(SphereProblem(2), settings, tmp_path / "run", executor=InlineExecutor)
    with pytest.raises(RunFolderError, match="not a learning run folder"):
        resume(tmp_path / "nothing", executor=InlineExecutor)


def test_best_so_far_skips_failed_trials_and_the_comparison_plot_is_written(tmp_path):
    from matplotlib.image import imread

    from tensim.learn.plots import best_so_far, plot_best_so_far
    from tensim.learn.problem import FLIPPED, OK, Evaluation

    def trial(i: int, score: float, status: str = OK) -> Evaluation:
        return Evaluation(i, (0.5,), (0.5,), score, status, "", 0.1)

    # a failed first trial leaves no best yet; a failed trial's penalty never counts
    runs = [trial(0, -1.0, FLIPPED), trial(1, 0.2), trial(2, 0.1), trial(3, 5.0, FLIPPED),
            trial(4, 0.3)]
    np.testing.assert_array_equal(best_so_far(runs), [np.nan, 0.2, 0.2, 0.2, 0.3])
    path = plot_best_so_far({"a": runs, "b": runs[1:3]}, tmp_path / "best.png",
                            styles={"a": {"color": "tab:red"}})
    assert imread(path).shape[:2] == (504, 900)  # 7.5 x 4.2 in at 120 dpi


def test_warp_with_worker_processes_is_refused_before_a_run_folder_exists(tmp_path):
    from tensim.cli import main

    out = tmp_path / "run"
    assert main(["--quiet", "learn", "--backend", "warp", "--processes", "--evaluations", "2",
                 "--out", str(out)]) != 0
    assert not out.exists()


def test_the_log_is_forced_to_disk_per_batch_not_per_evaluation(tmp_path, monkeypatch):
    """Each evaluation reaches the operating system as it finishes (read back mid-run, before
    any disk flush), and the log is forced to disk once per batch and on close (with the
    one-second timer held back): 4 batches of 10 are 4 flushes plus the close, not 40."""
    import tensim.learn.store as store

    synced: list[int] = []
    monkeypatch.setattr(store.os, "fsync", lambda fd: synced.append(fd))
    monkeypatch.setattr(store, "SYNC_EVERY_S", 1e9)
    seen: list[int] = []

    def progress(done: int, total: int, best: float | None, failed: int) -> None:
        lines = (tmp_path / "run" / EVALUATIONS).read_text().splitlines()
        seen.append(len(lines) - done)  # every finished evaluation is already in the file

    settings = LearningSettings(OptimizerSettings("cma", batch=10), 40, seed=3)
    learn(SphereProblem(3), settings, tmp_path / "run", executor=InlineExecutor,
          progress=progress)
    assert seen == [0] * 40
    assert len(synced) == 4 + 1
    assert len(RunStore(tmp_path / "run").evaluations()) == 40
