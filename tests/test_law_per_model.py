"""The cable law's body is chosen per model: a simulation on the Python reference law beside
one on the compiled law leaves each running its own, bit for bit as when alone."""

from __future__ import annotations

import logging

import mujoco
import numpy as np
import pytest

from tensim.model import CABLE_MARKER, compile_structure
from tensim.model import _law_layout as layout
from tensim.models import preset
from tensim.sim import Simulation, compiled_available, installed_backend

needs_compiled = pytest.mark.skipif(not compiled_available(), reason="compiled law not built")
STEPS, CHUNK = 300, 50


@pytest.fixture(scope="module")
def robot():
    p = preset("tetraspine3")
    return compile_structure(p.build()), p.controller()


def _alone(robot, backend: str) -> np.ndarray:
    compiled, controller = robot
    with Simulation(compiled, controller=controller, backend=backend) as sim:
        sim.step(STEPS)
        return np.concatenate([sim.data.qpos, sim.data.act])


@needs_compiled
def test_a_reference_simulation_leaves_a_live_compiled_one_on_the_compiled_law(robot,
                                                                              monkeypatch):
    from tensim.sim import _law

    compiled, controller = robot
    reference_alone, compiled_alone = _alone(robot, "python"), _alone(robot, "compiled")
    calls = []
    real = _law._python_dyn
    monkeypatch.setattr(_law, "_python_dyn", lambda m, d, i: calls.append(i) or real(m, d, i))
    fast = Simulation(compiled, controller=controller)  # first, then the reference one
    slow = Simulation(compiled, controller=controller, backend="python")
    n = compiled.n_cables
    for _ in range(STEPS // CHUNK):
        calls.clear()
        fast.step(CHUNK)
        assert calls == []  # the compiled body ran it
        slow.step(CHUNK)
        assert len(calls) == CHUNK * n  # the reference body ran every cable of every step
        assert installed_backend() == "compiled"
    np.testing.assert_array_equal(np.concatenate([fast.data.qpos, fast.data.act]),
                                  compiled_alone)
    np.testing.assert_array_equal(np.concatenate([slow.data.qpos, slow.data.act]),
                                  reference_alone)
    assert np.all(slow.model.actuator_dynprm[:n, layout.P_MARKER] == layout.REFERENCE_MARKER)
    assert np.all(fast.model.actuator_dynprm[:n, layout.P_MARKER] == CABLE_MARKER)
    assert np.all(compiled.model.actuator_dynprm[:n, layout.P_MARKER] == CABLE_MARKER)
    slow.close()
    fast.close()


@needs_compiled
def test_data_stepped_outside_its_simulation_gets_nan_forces_and_an_error(robot, caplog):
    compiled, _ = robot
    with Simulation(compiled, backend="python") as sim:
        stray = mujoco.MjData(sim.model)
        mujoco.mj_resetDataKeyframe(sim.model, stray, 0)
        with caplog.at_level(logging.ERROR, logger="tensim.sim._law"):
            mujoco.mj_forward(sim.model, stray)
        assert np.isnan(stray.actuator_force[:compiled.n_cables]).all()
        assert "without a simulation" in caplog.text
        sim.step(5)  # the simulation's own data still runs
        assert np.isfinite(sim.data.actuator_force).all()


@needs_compiled
def test_closing_releases_the_data(robot):
    from tensim.sim import _law

    compiled, _ = robot
    before = len(_law._reference)
    with Simulation(compiled, backend="python"):
        assert len(_law._reference) == before + 1
    assert len(_law._reference) == before
