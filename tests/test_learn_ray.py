"""Ray: a running cluster is joined as it is, and its failures are told apart from a trial's own.

A killed worker is retried, a trial that always kills its worker is ``lost`` alone, and a killed
node that Ray cannot make good stops the run without recording its trials, so that resuming
ends with the evaluations of an uninterrupted run.
"""

from __future__ import annotations

import dataclasses
import json
import os
import secrets
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from tensim.learn import (
    ClusterError,
    InlineExecutor,
    LearningSettings,
    OptimizerSettings,
    RayExecutor,
    RunStore,
    SphereProblem,
    learn,
    resume,
)
from tensim.learn.problem import LOST, OK, Outcome

ray = pytest.importorskip("ray")
# the test problems below travel to Ray's workers by value (this module is not importable there)
ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])

SETTINGS = LearningSettings(OptimizerSettings("ntrt", monte_carlo=8, batch=4), 16, seed=4)


def _records(folder: Path) -> list[tuple[int, tuple[float, ...], float, str]]:
    evaluations = RunStore(folder).evaluations()
    return [(i, e.unit, e.score, e.status) for i, e in sorted(evaluations.items())]


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory) -> list[tuple[int, tuple[float, ...], float, str]]:
    out = tmp_path_factory.mktemp("inline") / "run"
    learn(SphereProblem(3), SETTINGS, out, executor=InlineExecutor)
    return _records(out)


@pytest.fixture
def running_cluster():
    """The address and token of a Ray cluster of one CPU, with token authentication, started
    (and stopped) by another process."""
    temp = tempfile.mkdtemp(prefix="ray", dir="/tmp")  # Ray's socket paths must stay short
    script = ("import sys, ray; ray.init(address='local', num_cpus=1, include_dashboard=False,"
              " _temp_dir=sys.argv[1]); print(ray.get_runtime_context().gcs_address, "
              "flush=True); sys.stdin.read(); ray.shutdown()")
    token = secrets.token_hex(32)  # given to both sides: no token file is written
    head = subprocess.Popen([sys.executable, "-c", script, temp], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                            env={**os.environ, "RAY_AUTH_MODE": "token",
                                 "RAY_AUTH_TOKEN": token})
    try:
        address = head.stdout.readline().strip()
        assert address, "the cluster did not start"
        yield address, token
    finally:
        head.stdin.close()  # the head process shuts its cluster down and exits
        head.wait(timeout=120)
        shutil.rmtree(temp, ignore_errors=True)


_JOIN = """
import json, sys
from tensim.learn import RunStore, SphereProblem, learn, make_executor
from tests_settings import SETTINGS
with make_executor(SphereProblem(3), 2, ray=True) as executor:
    cpus = executor.workers
learn(SphereProblem(3), SETTINGS, sys.argv[1], executor=lambda p: make_executor(p, 2, ray=True))
logged = sorted(RunStore(sys.argv[1]).evaluations().items())
records = [(i, e.unit, e.score, e.status) for i, e in logged]
print(json.dumps({"cpus": cpus, "records": records}))
"""


def test_ray_joins_the_cluster_ray_address_names_without_asking_for_cpus(
        tmp_path, running_cluster, uninterrupted):
    # a process set up as docs/learning.md says: RAY_ADDRESS, and for a cluster with token
    # authentication RAY_AUTH_MODE=token and its token
    address, token = running_cluster
    (tmp_path / "tests_settings.py").write_text(
        "from tensim.learn import LearningSettings, OptimizerSettings\n"
        f"SETTINGS = LearningSettings(OptimizerSettings('ntrt', monte_carlo=8, batch=4), 16, "
        f"seed={SETTINGS.seed})\n")
    src = str(Path(__file__).resolve().parents[1] / "src")
    env = {**os.environ, "RAY_ADDRESS": address, "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": token,
           "PYTHONPATH": os.pathsep.join([src, str(tmp_path)])}
    done = subprocess.run([sys.executable, "-c", _JOIN, str(tmp_path / "run")], env=env,
                          capture_output=True, text=True, timeout=300, check=True)
    joined = json.loads(done.stdout.strip().split("\n")[-1])
    assert joined["cpus"] == 1  # the cluster's own CPUs, not the 2 asked of a local Ray
    assert [(i, tuple(u), s, st) for i, u, s, st in joined["records"]] == uninterrupted


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


def test_a_killed_worker_is_retried_and_only_the_trial_that_kills_it_is_lost(tmp_path,
                                                                             monkeypatch):
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    problem = _DyingSphere(2, marker=str(tmp_path / "died_once"))
    points = [np.array([0.5, 0.05]), np.array([0.5, 0.95]), np.array([0.3, 0.3]),
              np.array([0.6, 0.6])]
    with RayExecutor(problem, workers=2) as executor:  # two tasks of two trials
        results = {e.index: e for e in executor.run(list(enumerate(points)))}
    assert sorted(results) == [0, 1, 2, 3]
    assert results[0].status == LOST and "died in each of 3 tries" in results[0].reason
    for i in (1, 2, 3):  # its task-mate too: retried alone and scored as if nothing happened
        assert results[i].status == OK
        assert results[i].score == problem.evaluate(points[i]).score


@dataclasses.dataclass(frozen=True)
class _SlowOnceSphere(SphereProblem):
    """Writes ``marker`` and takes 600 s in its first trial (the node is killed meanwhile, so
    the trial never ends by itself: a slow kill cannot let it finish)."""

    marker: str = ""

    def evaluate(self, unit: np.ndarray) -> Outcome:
        if not os.path.exists(self.marker):
            Path(self.marker).touch()
            time.sleep(600.0)
        return super().evaluate(unit)


def test_a_killed_node_stops_the_run_unrecorded_and_resume_ends_as_an_uninterrupted_run(
        tmp_path, monkeypatch, uninterrupted):
    from ray.cluster_utils import Cluster

    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 0,
                                                            "include_dashboard": False})
    try:
        node = cluster.add_node(num_cpus=1)
        marker = tmp_path / "started"
        problem = _SlowOnceSphere(3, marker=str(marker))

        def kill_the_node() -> None:  # while the first trial runs
            while not marker.exists():
                time.sleep(0.05)
            cluster.remove_node(node, allow_graceful=False)

        killer = threading.Thread(target=kill_the_node, daemon=True)
        killer.start()
        out = tmp_path / "run"
        ray.init(address=cluster.address, log_to_driver=False)
        try:
            with pytest.raises(ClusterError, match="NodeDiedError"):
                learn(problem, SETTINGS, out,
                      executor=lambda p: RayExecutor(p, max_attempts=1))  # no retry
            killer.join()
            assert len(_records(out)) < 16  # the trials on the dead node are not recorded
            assert all(status == OK for *_, status in _records(out))
            cluster.add_node(num_cpus=1)  # a fresh node (Ray starts nodes from the main thread)
            resume(out, executor=lambda p: RayExecutor(p))
        finally:
            ray.shutdown()
        assert _records(out) == uninterrupted
    finally:
        cluster.shutdown()
