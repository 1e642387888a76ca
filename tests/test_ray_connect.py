"""A Ray cluster that cannot be reached fails fast, naming the address, and leaves no run
folder (ray.init alone retried an unreachable head for over 8 minutes)."""

from __future__ import annotations

import socket

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
