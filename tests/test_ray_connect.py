"""A Ray cluster that cannot be reached fails fast, naming the address, and leaves no run
folder (ray.init alone retried an unreachable head for over 8 minutes)."""

from __future__ import annotations

import socket

import numpy as np
import pytest

from tensim.cli import main
from tensim.learn.executors import ClusterError, check_reachable

pytest.importorskip("ray")


def _closed_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]  # nothing listens there once it is closed


def test_an_unreachable_address_is_refused_naming_it():
    port = _closed_port()
    with pytest.raises(ClusterError, match=rf"--ray-address ray://127.0.0.1:{port}: the Ray "
                                           r"head cannot be reached \(.*refused"):
        check_reachable(f"ray://127.0.0.1:{port}", "--ray-address")
    # a head that does not answer at all: the time-out, not Ray's minutes of retries
    # (192.0.2.0/24 is reserved for documentation: nothing routes there)
    with pytest.raises(ClusterError, match=r"RAY_ADDRESS 192.0.2.1:6379: .*within 0.2 s"):
        check_reachable("192.0.2.1:6379", "RAY_ADDRESS", timeout=0.2)
    check_reachable("auto", "RAY_ADDRESS")  # left to Ray


def test_learn_on_an_unreachable_cluster_fails_and_leaves_no_folder(tmp_path, capsys,
                                                                    monkeypatch):
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    out = tmp_path / "run"
    port = _closed_port()
    assert main(["--quiet", "learn", "--model", "prism3", "--controller", "sine",
                 "--evaluations", "2", "--trial-duration", "0.02",
                 "--ray-address", f"127.0.0.1:{port}", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert f"--ray-address 127.0.0.1:{port}: the Ray head cannot be reached" in err
    assert "the run never started, so no run folder was left" in err and not out.exists()


class _HeadStopsAfterOneGeneration:
    """An executor whose cluster answers one generation of trials and then loses its head."""

    backend, workers = "ray", 1

    def __init__(self, problem):
        from tensim.learn.executors import InlineExecutor

        self.inline, self.calls = InlineExecutor(problem), 0

    def run(self, tasks):
        self.calls += 1
        if self.calls > 1:
            raise ClusterError("lost the Ray cluster (ConnectionError: GCS unreachable): its "
                               "head node stopped or cannot be reached")
        yield from self.inline.run(tasks)

    def close(self):
        self.inline.close()


def test_a_head_node_that_dies_ends_the_run_with_a_resume_hint(tmp_path, capsys, monkeypatch):
    """The driver loses the head after the first generation: tensim's message, the folder
    kept with every finished evaluation, and the command that resumes it (not a bare exit 1
    with Ray's traceback)."""
    import tensim.learn

    monkeypatch.setattr(tensim.learn, "make_executor",
                        lambda problem, *a, **k: _HeadStopsAfterOneGeneration(problem))
    out = tmp_path / "run"
    assert main(["--quiet", "learn", "--model", "prism3", "--controller", "sine",
                 "--evaluations", "8", "--batch", "2", "--trial-duration", "0.02",
                 "--ray", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "tensim: lost the Ray cluster" in err and "head node stopped" in err
    assert f"continue with: tensim learn --resume {out}" in err
    assert "Traceback" not in err
    lines = (out / "evaluations.jsonl").read_text().splitlines()
    assert 1 <= len(lines) < 8  # the first generation's evaluations were kept


def test_ray_losing_its_head_mid_run_is_a_cluster_error(monkeypatch):
    """RayExecutor.run: ray.wait failing to reach the head (the GCS) raises ClusterError
    naming it, which the command line turns into the message above."""
    import ray

    from tensim.learn.executors import RayExecutor

    executor = RayExecutor.__new__(RayExecutor)
    executor.problem, executor.max_attempts, executor.workers = None, 1, 1
    executor._problem_ref = None
    executor._remote = type("Remote", (), {"remote": staticmethod(lambda *a: object())})()

    def unreachable(*args, **kwargs):
        raise ConnectionError("GCS has been unreachable for 60 s")

    monkeypatch.setattr(ray, "wait", unreachable)
    with pytest.raises(ClusterError, match=r"lost the Ray cluster \(ConnectionError: GCS has "
                                           r"been unreachable.*head node stopped"):
        list(executor.run([(0, np.zeros(2))]))
