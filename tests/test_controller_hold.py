"""The disturbance test with its controller held over several physics steps
(tensim.experiments.controller_hold): with a period of one step it is the plain run, and over a
period its motors take the step that a run at the period's length takes."""

import numpy as np
import pytest

from tensim.control import ControllerConfig
from tensim.experiments.controller_hold import held_run
from tensim.experiments.disturbance import disturbance_loads, run_disturbance
from tensim.model import WorldOptions, compile_structure
from tensim.model._law_layout import A_REST
from tensim.models import preset
from tensim.sim import Simulation
from tensim.sim._law import cable_actuators


@pytest.mark.parametrize("law", ["explicit", "implicit"])
def test_a_period_of_one_step_is_the_plain_run(law):
    held = held_run(4e-3, 1, law, duration=1.0)
    plain = run_disturbance(dt=4e-3, duration=1.0,
                            world=WorldOptions(timestep=4e-3, cable_law=law))[0]
    # the same law, motor updates and MuJoCo steps in the same order: the same floats
    np.testing.assert_array_equal(held.peak_tension, plain.peak_tension)


def test_over_a_period_the_motors_take_the_long_step():
    # four 1 ms steps under a 4 ms controller move each rest length as one 4 ms step does:
    # the law is evaluated on the same state at the same step length
    held = held_run(1e-3, 4, duration=4e-3)
    model = preset("tetraspine3")
    compiled = compile_structure(model.build(), WorldOptions(timestep=4e-3))
    controller = ControllerConfig(model.controller(), model="tetraspine3").build(4e-3)
    with Simulation(compiled, controller=controller, loads=disturbance_loads(),
                    record_dt=4e-3) as sim:  # construction takes the first step
        ids = cable_actuators(sim.model)
        rest = sim.data.act[sim.model.actuator_actadr[ids] + A_REST]
        np.testing.assert_allclose(held.rest_length, rest, rtol=0, atol=1e-12)  # rounding
    structure = compiled.structure
    built = np.array([structure.rest_length(c) for c in structure.cables])
    assert np.abs(held.rest_length - built).max() > 1e-4  # the motors did move (0.28 mm)


def test_a_delayed_push_is_the_push_shifted_in_time():
    times = np.linspace(29.0, 46.0, 171)
    for plain, later in zip(disturbance_loads(), disturbance_loads(start=30.002), strict=True):
        np.testing.assert_allclose(later.forces_at(times + 0.002), plain.forces_at(times),
                                   atol=1e-12)  # rounding of the shifted times


def test_a_period_below_one_step_is_refused():
    with pytest.raises(ValueError, match="period"):
        held_run(1e-3, 0)
