"""Spine waves as a learnable layout, and sidewinding's direction on the 12-segment robot."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tensim.control import SpineWave, spine_wave_parameters
from tensim.control.wave import WAVE_NAMES
from tensim.experiments.scenarios import run_scenario, wave_controller
from tensim.learn import Objective, TrialProblem, default_base
from tensim.models import preset
from tensim.terrain import Flat


def test_layout_values_make_the_same_gait_as_the_wave():
    structure = preset("tetraspine").build()
    wave = SpineWave(frequency=0.4, joint_lag=0.8, axial=(0.01, 0.2), pitch=(0.06, 1.5),
                     yaw=(0.07, -0.3))
    layout = spine_wave_parameters(structure)
    assert layout.names == WAVE_NAMES and layout.size == 8
    times = np.linspace(0.0, 4.0, 41)
    assert np.array_equal(layout.gait(wave.values()).table(times),
                          wave.gait(structure).table(times))
    assert layout.wave(wave.values()) == wave
    # a unit-cube point maps to the same wave as its physical values
    unit = layout.to_unit(wave.values())
    assert np.allclose(layout.from_unit(unit), wave.values(), atol=1e-15)


def test_layout_starts_from_a_wave_clipped_into_its_bounds():
    structure = preset("tetraspine3").build()
    layout = spine_wave_parameters(structure, SpineWave(9.0, 0.5, pitch=(0.5, 1.0)))
    start = layout.as_dict(layout.nominal)
    assert start["frequency"] == layout.high[0]  # 9 Hz clipped to the upper bound
    assert start["pitch_amplitude"] == layout.high[4]
    assert (start["joint_lag"], start["pitch_phase"]) == (0.5, 1.0)
    with pytest.raises(ValueError, match="outside their bounds"):
        layout.gait([10.0, *layout.nominal[1:]])


def test_layout_refuses_a_structure_it_cannot_place():
    untagged = preset("prism3").build()  # no spine joints
    with pytest.raises(ValueError, match="joint_<j>"):
        spine_wave_parameters(untagged)


def test_wave_family_learns_on_the_long_spine():
    structure = preset("tetraspine").build()
    problem = TrialProblem(structure, default_base("tetraspine", "wave", structure), "wave",
                           0.3, Objective(target_xy=(1.0, 0.0)), model="tetraspine")
    assert problem.dimension == 8
    outcome = problem.evaluate(problem.start())
    assert outcome.status == "ok"
    assert outcome.score == outcome.metrics["distance_m"]
    assert math.isfinite(outcome.metrics["target_distance_m"])


@pytest.mark.parametrize("lead", [1, -1])
def test_pitch_a_quarter_period_off_the_yaw_wave_winds_sideways(lead):
    # sidewinding: the spine bends sideways (yaw) and lifts (pitch) a quarter period apart, so
    # each section is lifted while it swings one way and set down while it swings back. The
    # robot then moves across its own axis, and the side is set by which wave leads: the
    # mirror image of the gait is the same gait with the pitch wave's lead reversed.
    wave = SpineWave(frequency=0.3, joint_lag=0.8, pitch=(0.1, lead * math.pi / 2),
                     yaw=(0.1, 0.0))
    _, summary = run_scenario("sidewind", wave_controller(wave, 10.0), Flat())
    side, forward = summary["body_sideways_m"], summary["body_forward_m"]
    assert lead * side > 0.05  # at least 5 cm in 10 s, to the side the lead picks
    assert abs(side) > abs(forward)
