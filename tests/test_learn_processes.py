"""Learning runs and processes: the folder lock, data-only folders, the rebuilt optimizer, no
orphaned workers, and one line on Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from tensim.learn import (
    InlineExecutor,
    LearningSettings,
    OptimizerSettings,
    RunStore,
    SphereProblem,
    learn,
    resume,
)
from tensim.learn.run import _Session
from tensim.learn.store import RunFolderError

SETTINGS = LearningSettings(OptimizerSettings("cma", batch=6), 30, seed=4)


def test_a_second_writer_is_refused_while_the_first_holds_the_lock(tmp_path):
    learn(SphereProblem(3), SETTINGS, tmp_path, executor=InlineExecutor)
    first = RunStore(tmp_path)
    with first.locked(), pytest.raises(RunFolderError, match=f"pid {os.getpid()}"):
        resume(tmp_path, 40, executor=InlineExecutor)
    assert len(RunStore(tmp_path).evaluations()) == 30  # the refused writer added nothing
    resume(tmp_path, 36, executor=InlineExecutor)  # released: the next writer goes on
    assert len(RunStore(tmp_path).evaluations()) == 36


def test_a_new_writer_deletes_temporary_files_a_killed_one_left(tmp_path):
    learn(SphereProblem(3), SETTINGS, tmp_path, executor=InlineExecutor)
    stale = tmp_path / ".summary.json.x1y2.tmp"
    stale.write_text("{half")
    resume(tmp_path, executor=InlineExecutor)
    assert not stale.exists()


def test_a_learning_run_does_not_write_into_a_folder_holding_other_files(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(RunFolderError, match="not empty"):
        learn(SphereProblem(3), SETTINGS, tmp_path, executor=InlineExecutor)
    assert sorted(p.name for p in tmp_path.iterdir()) == [".lock", "notes.txt"]


def test_a_run_folder_holds_data_only(tmp_path):
    learn(SphereProblem(3), SETTINGS, tmp_path, executor=InlineExecutor)
    for path in tmp_path.iterdir():
        head = path.read_bytes()[:8]
        assert not head.startswith(b"\x80"), path  # every pickle (protocol >= 2) opens so
    assert json.loads((tmp_path / "checkpoint.json").read_text())["told"] == 30


def test_a_resume_rebuilds_the_cma_state_bit_for_bit(tmp_path):
    problem = SphereProblem(4)
    learn(problem, SETTINGS, tmp_path, executor=InlineExecutor)
    # the reference: the same optimizer driven by hand through the same 5 batches
    reference = SETTINGS.optimizer.build(4, SETTINGS.seed, problem.start())
    for _ in range(5):
        points = reference.ask()
        reference.tell(points, np.array([-problem.evaluate(u).score for u in points]))
    store = RunStore(tmp_path)
    session = _Session(store, problem, store.read_config(), store.load_checkpoint(), None)
    rebuilt = session.optimizer.es
    np.testing.assert_array_equal(rebuilt.mean, reference.es.mean)
    np.testing.assert_array_equal(rebuilt.C, reference.es.C)
    assert rebuilt.sigma == reference.es.sigma and rebuilt.countiter == reference.es.countiter
    np.testing.assert_array_equal(session.optimizer.ask(), reference.ask())


def test_a_log_from_another_run_is_refused_on_resume(tmp_path):
    learn(SphereProblem(3), SETTINGS, tmp_path / "a", executor=InlineExecutor)
    other = LearningSettings(SETTINGS.optimizer, 30, seed=5)
    learn(SphereProblem(3), other, tmp_path / "b", executor=InlineExecutor)
    (tmp_path / "a" / "evaluations.jsonl").write_bytes(
        (tmp_path / "b" / "evaluations.jsonl").read_bytes())
    with pytest.raises(RunFolderError, match="different runs"):
        resume(tmp_path / "a", 40, executor=InlineExecutor)


_SLOW = """
import dataclasses, time
from tensim.learn import SphereProblem
from tensim.learn.problem import Outcome

@dataclasses.dataclass(frozen=True)
class SlowSphere(SphereProblem):
    def evaluate(self, unit):
        time.sleep(120)
        return Outcome(0.0)
"""

_MAIN = """
import sys
import numpy as np

if __name__ == "__main__":
    sys.path.insert(0, sys.argv[1])
    from slow import SlowSphere
    from tensim.learn.executors import ProcessPoolExecutor
    pool = ProcessPoolExecutor(SlowSphere(2), 2)
    pool.warm_up()
    print("ready", flush=True)
    list(pool.run([(i, np.full(2, 0.5)) for i in range(4)]))
"""


def _descendants(pid: int) -> list[int]:
    out = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        for child in (task / "children").read_text().split():
            out += [int(child), *_descendants(int(child))]
    return out


def _running(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0]
    except FileNotFoundError:
        return False
    return state != "Z"  # a zombie has exited; only its exit status is left


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="needs Linux /proc")
def test_worker_processes_exit_when_the_parent_is_killed(tmp_path):
    (tmp_path / "slow.py").write_text(textwrap.dedent(_SLOW))
    (tmp_path / "main.py").write_text(textwrap.dedent(_MAIN))
    parent = subprocess.Popen([sys.executable, str(tmp_path / "main.py"), str(tmp_path)],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert parent.stdout.readline().strip() == "ready"
        time.sleep(0.5)  # the two trials are running in the workers
        children = _descendants(parent.pid)
        assert len(children) >= 3  # two workers, the fork server (and the resource tracker)
    finally:
        parent.send_signal(signal.SIGKILL)  # no chance to shut the pool down
        parent.wait()
    # a hang guard, not a time limit: the workers normally exit within 0.1 s, and only a real
    # hang (workers that never notice their parent is gone) reaches it
    deadline = time.monotonic() + 600
    while any(_running(c) for c in children) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = [c for c in children if _running(c)]
    for pid in left:  # do not leave them behind if the test fails
        os.kill(pid, signal.SIGKILL)
    assert not left


def test_ctrl_c_prints_one_line_and_leaves_no_partial_folder(tmp_path):
    out = tmp_path / "run"
    command = [sys.executable, "-c", "import sys; from tensim.cli import main; "
               "sys.exit(main())", "simulate", "prism3", "--duration", "500", "--out", str(out)]
    process = subprocess.Popen(command, stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    first = process.stderr.readline()
    while first and not first.startswith("prism3 ["):  # the compiler's notes come first
        first = process.stderr.readline()
    # a progress line: the simulation is running
    process.send_signal(signal.SIGINT)
    rest = process.stderr.read()
    process.wait(timeout=60)
    assert first.startswith("prism3 [") and process.returncode == 130
    assert "Traceback" not in rest
    lines = [line for line in rest.splitlines() if not line.startswith("prism3 [")]
    assert len(lines) == 1 and lines[0].startswith("tensim: interrupted")
    assert list(tmp_path.iterdir()) == []  # neither the folder nor its staging copy
