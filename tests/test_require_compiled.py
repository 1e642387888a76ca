"""The suite's own guard: with ``TENSIM_REQUIRE_COMPILED=1`` a compiled law, CPG, record loop
or RL observation that did not load fails the test run at its start, naming what is missing;
without it the run goes on."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

PLUGIN = """
from tensim.control import cpg
from tensim.sim import _law, _record_native

_law.compiled_available = lambda: {law}
cpg.compiled_available = lambda: {cpg}
_record_native.available = lambda: {record}
try:
    from tensim.rl import _observe_native
except ImportError:  # (no rl extra: the guard leaves the RL observation out)
    pass
else:
    _observe_native.available = lambda: {observation}
"""


def _run(tmp_path: Path, *, require: bool, law: bool, cpg: bool,
         observation: bool = True, record: bool = True) -> subprocess.CompletedProcess[str]:
    (tmp_path / "fake_build.py").write_text(PLUGIN.format(law=law, cpg=cpg, record=record,
                                                          observation=observation))
    env = dict(os.environ)
    env.pop("TENSIM_REQUIRE_COMPILED", None)
    if require:
        env["TENSIM_REQUIRE_COMPILED"] = "1"
    env["PYTHONPATH"] = os.pathsep.join(
        [str(tmp_path), str(ROOT / "src"), env.get("PYTHONPATH", "")])
    return subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "fake_build", "-p", "no:cacheprovider",
         "--collect-only", "-q", "tests/test_law_layout.py"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize(("law", "cpg", "observation", "named"), [
    (False, True, True, "cable law"), (True, False, True, "CPG"),
    (False, False, True, "cable law and CPG"), (True, True, False, "RL observation")])
def test_a_missing_build_fails_the_run_when_required(
        tmp_path: Path, law: bool, cpg: bool, observation: bool, named: str) -> None:
    if not observation:
        pytest.importorskip("gymnasium", reason="the RL observation is checked with the rl extra")
    done = _run(tmp_path, require=True, law=law, cpg=cpg, observation=observation)
    assert done.returncode != 0
    assert f"the compiled {named} did not load" in done.stdout + done.stderr


def test_a_missing_record_loop_fails_the_run_when_required(tmp_path: Path) -> None:
    done = _run(tmp_path, require=True, law=True, cpg=True, record=False)
    assert done.returncode != 0
    assert "the compiled record loop did not load" in done.stdout + done.stderr


def test_without_the_flag_a_missing_build_only_skips(tmp_path: Path) -> None:
    done = _run(tmp_path, require=False, law=False, cpg=False)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "did not load" not in done.stdout + done.stderr


def test_a_loaded_build_passes_the_guard(tmp_path: Path) -> None:
    done = _run(tmp_path, require=True, law=True, cpg=True)
    assert done.returncode == 0, done.stdout + done.stderr
