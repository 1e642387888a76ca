"""A simulation's ``ctrl`` rows (InputPlan.control): the cable commands alone come as they are."""

from __future__ import annotations

import numpy as np

from tensim.control import load_controller
from tensim.model import compile_structure
from tensim.models import preset
from tensim.sim import Simulation, ramp_hold_release


def _reference(plan, first: int, count: int) -> np.ndarray:
    """The rows as built before: zeros, the cable commands, then each load's forces."""
    steps = np.arange(first, first + count)
    out = np.zeros((count, plan.nu))
    n = plan.drive.stiffness.size
    out[:, :n] = plan.drive.commands(steps, plan.dt)
    for column, load in zip(plan._column, plan.loads, strict=True):
        out[:, column:column + 3] += load.forces_at(steps * plan.dt)
    return out


def test_rows_equal_the_reference_with_and_without_load_inputs() -> None:
    structure = preset("tetraspine3").build()
    push = ramp_hold_release("s2_tip", (0.0, 1.0, 0.5), 8.0, 0.1, 0.1, 0.1, 0.1)
    gait = load_controller("tetraspine3_sine", structure).with_duration(0.5)
    for compiled, loads in ((compile_structure(structure), ()),
                            (compile_structure(structure, load_nodes=("s2_tip",)), ()),
                            (compile_structure(structure, load_nodes=("s2_tip",)), (push,))):
        sim = Simulation(compiled, controller=gait.build(compiled.model.opt.timestep),
                         loads=loads)
        plan = sim.inputs()
        for first, count in ((0, 1), (7, 300), (450, 200), (0, 0)):
            rows = plan.control(first, count)
            assert rows.dtype == np.float64 and rows.flags.c_contiguous
            assert rows.shape == (count, plan.nu)
            np.testing.assert_array_equal(rows, _reference(plan, first, count))
        assert np.ptp(plan.control(0, 500)[:, :12], axis=0).max() > 0  # the gait moves
