"""Parallel trials: the pool and Ray give the inline results, failures are recorded not lost."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest

from tensim.learn import (
    InlineExecutor,
    LearningSettings,
    OptimizerSettings,
    ProcessPoolExecutor,
    RunStore,
    SphereProblem,
    learn,
)
from tensim.learn.problem import ERROR, LOST, OK, Outcome

SETTINGS = LearningSettings(OptimizerSettings("ntrt", monte_carlo=8, batch=4), 16, seed=4)


def _records(folder: Path) -> list[tuple[int, tuple[float, ...], float, str]]:
    evaluations = RunStore(folder).evaluations()
    return [(i, e.unit, e.score, e.status) for i, e in sorted(evaluations.items())]


@dataclasses.dataclass(frozen=True)
class _RaisingSphere(SphereProblem):
    """Raises for points whose first coordinate is below 0.2."""

    def evaluate(self, unit: np.ndarray) -> Outcome:
        if unit[0] < 0.2:
            raise RuntimeError("bad point")
        return super().evaluate(unit)


@dataclasses.dataclass(frozen=True)
class _DyingSphere(SphereProblem):
    """Kills its worker process: always at a point below 0.1, once at one above 0.9."""

    marker: str = ""

    def evaluate(self, unit: np.ndarray) -> Outcome:
        if unit[1] < 0.1:
            os._exit(1)  # the point that always kills its worker
        if unit[1] > 0.9 and not os.path.exists(self.marker):
            Path(self.marker).touch()
            os._exit(1)  # dies the first time only
        return super().evaluate(unit)


def test_process_pool_gives_the_inline_evaluations(tmp_path):
    learn(SphereProblem(3), SETTINGS, tmp_path / "inline", executor=InlineExecutor)
    learn(SphereProblem(3), SETTINGS, tmp_path / "pool",
          executor=lambda p: ProcessPoolExecutor(p, 2))
    assert _records(tmp_path / "pool") == _records(tmp_path / "inline")


def test_a_trial_that_raises_is_recorded_as_failed(tmp_path):
    learn(_RaisingSphere(3), SETTINGS, tmp_path, executor=lambda p: ProcessPoolExecutor(p, 2))
    evaluations = RunStore(tmp_path).evaluations()
    assert len(evaluations) == 16
    for e in evaluations.values():
        if e.unit[0] < 0.2:
            assert e.status == ERROR and "RuntimeError: bad point" in e.reason
            assert e.score == -100.0  # the problem's penalty
        else:
            assert e.status == OK


def test_dead_workers_are_replaced_and_a_trial_that_always_kills_is_lost(tmp_path):
    problem = _DyingSphere(2, marker=str(tmp_path / "died_once"))
    points = [np.array([0.5, 0.05]), np.array([0.5, 0.95]), np.array([0.3, 0.3]),
              np.array([0.6, 0.6])]
    with ProcessPoolExecutor(problem, 2, max_attempts=3) as pool:
        results = {e.index: e for e in pool.run(list(enumerate(points)))}
    assert sorted(results) == [0, 1, 2, 3]
    assert results[0].status == LOST and "died in each of 3 tries" in results[0].reason
    assert results[0].score == problem.penalty
    for i in (1, 2, 3):  # retried after the crashes and scored as if nothing happened
        assert results[i].status == OK
        assert results[i].score == problem.evaluate(points[i]).score


def test_ray_gives_the_process_pool_evaluations(tmp_path):
    ray = pytest.importorskip("ray")
    from tensim.learn import RayExecutor

    learn(SphereProblem(3), SETTINGS, tmp_path / "pool",
          executor=lambda p: ProcessPoolExecutor(p, 2))
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        learn(SphereProblem(3), SETTINGS, tmp_path / "ray", executor=RayExecutor)
    finally:
        ray.shutdown()
    assert _records(tmp_path / "ray") == _records(tmp_path / "pool")


def test_thread_batches_give_the_inline_evaluations():
    from tensim.learn.executors import ThreadBatchExecutor
    from tensim.learn.families import default_base
    from tensim.learn.problem import TrialProblem
    from tensim.models import preset

    structure = preset("tetraspine3").build()
    problem = TrialProblem(structure, default_base("tetraspine3", "cpg", structure), "cpg", 1.5,
                           model="tetraspine3")
    points = np.random.default_rng(3).random((7, problem.dimension))
    tasks = list(enumerate(points))
    inline = sorted(InlineExecutor(problem).run(tasks), key=lambda e: e.index)
    assert len({e.score for e in inline}) > 1  # the gaits differ
    for executor in (ThreadBatchExecutor(problem, 2, batch_size=3),  # 3 batches, 2 threads
                     # the gaits built on worker processes (the default without the compiled
                     # CPG integrator)
                     ThreadBatchExecutor(problem, 2, batch_size=3, process_builds=True),
                     ThreadBatchExecutor(problem, 1, batch_size=7)):  # 1 batch, 1 thread
        with executor:
            batched = sorted(executor.run(tasks), key=lambda e: e.index)
        for a, b in zip(inline, batched, strict=True):
            assert (a.index, a.unit, a.score, a.status, a.metrics) == \
                (b.index, b.unit, b.score, b.status, b.metrics)


class _LosingOnce:
    """An executor that loses its first trial (as a cluster did before this version recorded
    only the trials a dead worker could be blamed for) and then fails."""

    backend, workers = "losing", 1

    def __init__(self, problem):
        self.problem = problem

    def run(self, tasks):
        from tensim.learn import ClusterError
        from tensim.learn.problem import lost_evaluation

        index, unit = tasks[0]
        yield lost_evaluation(self.problem, index, unit, "lost: a node died")
        raise ClusterError("the Ray cluster could not run every trial")

    def close(self):
        pass


def test_resume_runs_again_a_lost_trial_of_the_generation_in_hand(tmp_path):
    from tensim.learn import ClusterError, resume

    learn(SphereProblem(3), SETTINGS, tmp_path / "inline", executor=InlineExecutor)
    with pytest.raises(ClusterError):
        learn(SphereProblem(3), SETTINGS, tmp_path / "run", executor=_LosingOnce)
    assert [status for *_, status in _records(tmp_path / "run")] == [LOST]
    resume(tmp_path / "run", executor=InlineExecutor)
    assert _records(tmp_path / "run") == _records(tmp_path / "inline")
