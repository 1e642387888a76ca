"""System identification: named parameters change the right fields, and a simulated log
with known perturbed parameters, quantisation, noise, offset and delay is identified back."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tensim.control import load_controller, tetraspine_sine
from tensim.hardware import (
    PAPER_LOADCELL,
    SensorModel,
    SysidSpace,
    apply_physical,
    identify,
    simulated_log,
)
from tensim.hardware.parameters import parse_assignments, parse_bounds
from tensim.models import tetraspine3

STIFFNESS = 229.16  # N/m, the preset's cables


def test_physical_parameters_change_the_structure():
    robot = tetraspine3()
    changed = apply_physical(robot, {"stiffness": 1.1 * STIFFNESS, "friction": 0.1,
                                     "damping": 30.0, "max_speed": 0.05, "mass_scale": 1.2,
                                     "offset": 3.0, "vstar_scale": 2.0})
    np.testing.assert_allclose([c.stiffness for c in changed.cables], 1.1 * STIFFNESS)
    np.testing.assert_allclose([c.damping for c in changed.cables], 30.0)
    np.testing.assert_allclose([c.motor.max_speed for c in changed.cables], 0.05)
    np.testing.assert_allclose([r.friction for r in changed.rods], 0.1)
    assert changed.total_mass() - robot.total_mass() == pytest.approx(
        0.2 * sum(p.mass for p in robot.point_masses))
    # pretension is kept: the rest length follows the new stiffness
    cable, new = robot.cables[0], changed.cables[0]
    assert changed.rest_length(new) == pytest.approx(
        robot.cable_length(cable) - cable.pretension / (1.1 * STIFFNESS))
    unchanged = dataclasses.replace(changed, cables=robot.cables, rods=robot.rods,
                                    point_masses=robot.point_masses)
    assert unchanged == robot  # measurement and input parameters leave the structure alone


def test_space_bounds_and_parsing():
    space = SysidSpace.build(tetraspine3(), ["friction", "delay"], bounds={"delay": (0, 0.1)})
    np.testing.assert_allclose(space.low, [0.25 * 0.075, 0.0])
    np.testing.assert_allclose(space.start, [0.075, 0.0])
    np.testing.assert_allclose(space.from_unit(space.to_unit([0.1, 0.05])), [0.1, 0.05])
    with pytest.raises(ValueError, match=r"'friction'.*outside"):
        SysidSpace.build(tetraspine3(), ["friction"], bounds={"friction": (0.2, 0.5)})
    with pytest.raises(KeyError, match="unknown parameter 'fricton'"):
        SysidSpace.build(tetraspine3(), ["fricton"])
    assert parse_assignments("friction=0.1, stiffness=250", "--set") == {
        "friction": 0.1, "stiffness": 250.0}
    assert parse_bounds("friction=0.02:0.3") == {"friction": (0.02, 0.3)}
    with pytest.raises(ValueError, match="--set: expected NAME=NUMBER, got 'friction'"):
        parse_assignments("friction", "--set")
    with pytest.raises(ValueError, match="--bounds: expected NAME=LOW:HIGH"):
        parse_bounds("friction=0.02")


def test_sysid_identifies_perturbed_parameters():
    robot = tetraspine3()
    impedance = load_controller("tetraspine3_impedance", robot)
    # a strong excitation (the inner cables' motors run at their speed limit), so stiffness
    # shows in the tensions despite the impedance law
    gait = impedance.with_gait(tetraspine_sine(robot, 0.05, 1.0))
    truth = {"stiffness": 1.1 * STIFFNESS, "friction": 0.1}
    sensor = SensorModel(offset=0.5, noise=0.1, delay=0.03, loadcell=PAPER_LOADCELL)
    log = simulated_log(robot, gait, 6.0, parameters=truth, sensor=sensor,
                        rng=np.random.default_rng(0))
    result = identify([log], robot, impedance, ["stiffness", "friction", "offset", "delay"])
    fitted = result.space.as_dict(result.fitted)
    # Tolerances: the residual floor is ~0.11 N (0.1 N noise, 0.045 N rounding, and the
    # irregular ~0.03 N changes contacts make for any parameter change). Over 4 seeds the fit
    # landed within 1 % on stiffness, 0.004 on friction, 0.02 N and 2 ms; allow about twice.
    assert fitted["stiffness"] == pytest.approx(truth["stiffness"], rel=0.025)
    assert fitted["friction"] == pytest.approx(truth["friction"], abs=0.01)
    assert fitted["offset"] == pytest.approx(0.5, abs=0.05)
    assert fitted["delay"] == pytest.approx(0.03, abs=0.005)
    summary = result.summary()
    assert summary["rmse_after_N"] < 0.4 * summary["rmse_before_N"]  # the gap shrinks
    assert summary["rmse_after_N"] < 0.2  # down to about the sensor's own noise
    assert (summary["max_system_tension_error_after_percent"]
            < summary["max_system_tension_error_before_percent"])
    assert result.simulations <= 60  # the default budget
    np.testing.assert_allclose([c.stiffness for c in result.structure.cables],
                               fitted["stiffness"])
    assert result.sensor.delay == pytest.approx(fitted["delay"])
