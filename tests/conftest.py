"""Suite-wide checks. With ``TENSIM_REQUIRE_COMPILED=1`` (CI sets it) a compiled cable law,
CPG, record loop or RL observation (where the rl extra is installed) that is missing or stale
(built from older sources, or for another MuJoCo) fails the run at its start: otherwise the
tests of the compiled paths skip, and a stale build would pass unseen."""

from __future__ import annotations

import importlib.util
import os

import pytest


def pytest_sessionstart(session: pytest.Session) -> None:
    if os.environ.get("TENSIM_REQUIRE_COMPILED") != "1":
        return
    from tensim.control import cpg
    from tensim.sim import _law, _record_native

    missing = [name for name, ok in (("cable law", _law.compiled_available()),
                                     ("CPG", cpg.compiled_available()),
                                     ("record loop", _record_native.available())) if not ok]
    if importlib.util.find_spec("gymnasium") is not None:
        from tensim.rl import _observe_native

        if not _observe_native.available():
            missing.append("RL observation")
    if missing:
        raise pytest.UsageError(
            f"TENSIM_REQUIRE_COMPILED=1 but the compiled {' and '.join(missing)} did not load "
            "(not built, or built from older sources): rebuild with "
            "`python setup.py build_ext --inplace` or reinstall with pip")
