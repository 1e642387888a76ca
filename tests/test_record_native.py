"""The compiled record loop (``sim/_record.c``) against the Python loop it replaces: the same
samples, state, checks and errors, bit for bit.

The Python loop (``_record_native.usable`` patched to False) steps each record with the
bindings' ``mj_step`` and checks in NumPy; the compiled one steps with MuJoCo's own
``mj_step`` and tests the common case of each check in C. Every run here must agree to the
bit in its channels, its final state, the ringing check's forces, the energy history (which
the compiled loop leaves to NumPy) and the peaks kept for a later message; failing runs must
fail with the same message at the same state.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable
from typing import TypeVar
from unittest import mock

import mujoco
import numpy as np
import pytest

import tensim
from tensim.model import compile_spec, compile_structure
from tensim.models import preset
from tensim.sim import (
    Controller,
    NodeLoad,
    Simulation,
    Trial,
    _record_native,
    compiled_available,
    ramp_hold_release,
    run_batch,
)
from tensim.sim._loop import ForceHistory
from tensim.structure import load_structure
from test_recorder import _robots as recorder_robots

pytestmark = pytest.mark.skipif(not _record_native.available() or not compiled_available(),
                                reason="the compiled record loop or cable law is not built")

HOPPER = "examples/design/hopper.yaml"
T = TypeVar("T")


def _both(run: Callable[[], T]) -> tuple[T, T]:
    """``run()`` with the compiled loop, then with the Python loop."""
    compiled = run()
    with mock.patch.object(_record_native, "usable", lambda sim: False):
        python = run()
    return compiled, python


def _robots() -> dict[str, tuple[tensim.Structure, Controller | None, tuple[NodeLoad, ...]]]:
    """The recorder tests' robots (no loads), the six-bar, and Tetraspine3 pushed."""
    robots = {name: (s, ctrl, ()) for name, (s, ctrl) in recorder_robots().items()}
    p = preset("tetraspine3")
    s = p.build()
    push = ramp_hold_release(s.nodes[0].name, (1.0, 0.0, 0.0), 20.0, 0.1, 0.2, 0.2, 0.2)
    return {**robots, "six-bar": (preset("six_bar").build(), None, ()),
            "a push": (s, p.controller(), (push,))}


@dataclasses.dataclass
class _Run:
    series: tuple[tensim.TimeSeries, ...]
    state: np.ndarray
    calls: list[tuple[float, float]]
    kept: tuple[np.ndarray, ...]  # the ringing check's forces, the energy history, the peaks
    peak_time: float
    used: bool


@pytest.mark.parametrize("robot", list(_robots()))
def test_the_compiled_loop_records_what_the_python_loop_records(robot: str) -> None:
    structure, controller, loads = _robots()[robot]
    compiled = compile_structure(structure)

    def run() -> _Run:
        calls: list[tuple[float, float]] = []
        with Simulation(compiled, controller=controller, loads=loads) as sim:
            used = _record_native.usable(sim)
            first = sim.run(1.23, progress=lambda done, total: calls.append((done, total)))
            second = sim.run(0.31)  # a run continuing the first
            peak_time, peaks = sim._peak_seen
            return _Run((first, second), sim.get_state(), calls,
                        (sim._forces.force, sim._forces.count, sim._energies.energy,
                         sim._energies.lowest, peaks), peak_time, used)

    fast, slow = _both(run)
    assert fast.used and not slow.used
    for a, b in zip(fast.series, slow.series, strict=True):
        assert a.channels.keys() == b.channels.keys()
        assert np.array_equal(a.time, b.time)
        for name in a.channels:
            assert np.array_equal(a.channels[name], b.channels[name], equal_nan=True), name
    assert np.array_equal(fast.state, slow.state)
    assert fast.calls == slow.calls and len(fast.calls) == 1
    assert all(np.array_equal(x, y, equal_nan=True)
               for x, y in zip(fast.kept, slow.kept, strict=True))
    assert fast.peak_time == slow.peak_time


def test_a_run_with_a_callback_per_record_records_in_python_the_same() -> None:
    p = preset("tetraspine3")
    compiled = compile_structure(p.build())
    seen: list[float] = []
    with Simulation(compiled, controller=p.controller()) as sim:
        hooked = sim.run(0.2, on_record=lambda s: seen.append(s.time))
    with Simulation(compiled, controller=p.controller()) as sim:
        plain = sim.run(0.2)
    assert len(seen) == 20
    assert all(np.array_equal(hooked.channels[k], plain.channels[k], equal_nan=True)
               for k in plain.channels)


def _failure(structure: tensim.Structure, dt: float, record_dt: float
             ) -> Callable[[], tuple[str, np.ndarray]]:
    compiled = compile_structure(structure, tensim.WorldOptions(timestep=dt))

    def run() -> tuple[str, np.ndarray]:
        with Simulation(compiled, record_dt=record_dt) as sim, \
                pytest.raises(tensim.SimulationError) as caught:
            sim.run(1.0)
        return str(caught.value), sim.get_state()
    return run


def _no_ringing(self: ForceHistory, ids: slice) -> np.ndarray:
    return np.zeros((len(self.force[ids]), len(self.band)), dtype=bool)


def test_a_run_that_rings_or_runs_away_stops_where_and_as_the_python_loop_stops() -> None:
    hopper = load_structure(HOPPER)
    fast, slow = _both(_failure(hopper, 5.2e-3, 10.4e-3))  # rings (tests/test_ringing.py)
    assert "rings at the step frequency" in fast[0]
    assert fast[0] == slow[0] and np.array_equal(fast[1], slow[1])
    with mock.patch.object(ForceHistory, "ringing", _no_ringing):  # the energy runs away
        fast, slow = _both(_failure(hopper, 6e-3, 6e-3))
    assert "mechanical energy" in fast[0]
    assert fast[0] == slow[0] and np.array_equal(fast[1], slow[1])


def test_a_mujoco_error_in_the_compiled_loop_is_raised_as_the_bindings_raise_it() -> None:
    # too little arena for the contacts the six-bar makes as it settles: mj_step fails
    compiled = compile_structure(preset("six_bar").build())
    assert compiled.spec is not None
    spec = compiled.spec.copy()
    spec.memory = 8000
    small = dataclasses.replace(compiled, model=compile_spec(spec))

    def run() -> tuple[str, float]:
        with Simulation(small) as sim, pytest.raises(mujoco.FatalError) as caught:
            sim.run(0.5)
        return str(caught.value), sim.data.time

    fast, slow = _both(run)
    assert re.match(r"mj_stackAlloc: out of memory", fast[0])
    assert fast == slow
    # MuJoCo's batch engine, on threads, still reports its own errors with the loop's hook in
    for k, trial in enumerate(run_batch(small, [Trial(), Trial()], 0.5, threads=2)):
        assert trial.error is not None
        assert trial.error.startswith(f"trial {k}: MuJoCo: mj_stackAlloc: out of memory")
    with Simulation(compiled) as sim:  # and the process goes on
        assert sim.run(0.05).time.size == 6
