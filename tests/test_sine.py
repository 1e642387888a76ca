"""Sine gaits on V*: the wave, the hand-tuned Tetraspine sign and phase pattern, the controller."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tensim.control.sine import SineController, SineGait, tagged_sine, tetraspine_sine
from tensim.model import compile_structure
from tensim.models import tetraspine, tetraspine3
from tensim.models.tetraspine import impedance_controller
from tensim.sim import MODE_IMPEDANCE, Simulation

SIDES = ("top", "left", "right")


def test_table_matches_hand_computed_values():
    gait = SineGait(("a", "b"), (0.01, -0.02), 0.5, (0.0, math.pi / 2), (0.0, 0.003))
    table = gait.table([0.0, 0.5, 1.0])
    # a: 0.01 sin(π t) at t = 0, 0.5, 1 -> 0, 0.01, 0; b: 0.003 − 0.02 sin(π t + π/2) = 0.003 −
    # 0.02 cos(π t) -> −0.017, 0.003, 0.023; only float rounding of sin/cos differs
    np.testing.assert_allclose(table, [[0.0, -0.017], [0.01, 0.003], [0.0, 0.023]],
                               rtol=0, atol=1e-15)
    assert table.shape == (3, 2)


@pytest.mark.parametrize("kwargs, message", [
    ({"cables": ()}, "at least one"),
    ({"cables": ("a", "a")}, "duplicate"),
    ({"amplitude": (0.1,)}, "one value per cable"),
    ({"frequency": -1.0}, "frequency"),
    ({"phase": float("nan")}, "finite"),
    ({"offset": float("inf")}, "finite"),
])
def test_invalid_gaits_are_refused(kwargs, message):
    args = {"cables": ("a", "b"), "amplitude": 0.1, "frequency": 1.0} | kwargs
    with pytest.raises(ValueError, match=message):
        SineGait(**args)


def _columns(gait: SineGait, times: np.ndarray) -> dict[str, np.ndarray]:
    return dict(zip(gait.cables, gait.table(times).T, strict=True))


def test_tetraspine_inner_cables_mirror_outer_and_rear_joint_is_half_a_period_behind():
    f, amplitude, offset = 0.8, 0.01, 0.002
    gait = tetraspine_sine(tetraspine3(), amplitude, f, phase=0.3, offset=offset)
    assert len(gait.cables) == 12
    t = np.linspace(0.0, 5.0, 501)
    v = _columns(gait, t)
    half = 1 / (2 * f)  # π of phase at f
    for side in SIDES:
        for joint in (1, 2):
            # inside cables have the inverse sign of the outside ones (offset included)
            np.testing.assert_allclose(v[f"inner_{side}_{joint}"], -v[f"outer_{side}_{joint}"],
                                       rtol=0, atol=1e-15)  # exact up to sin rounding
        # the rear joint is π behind the front: it shows the front's value half a period later
        front = _columns(gait, t)[f"outer_{side}_1"]
        rear_later = _columns(gait, t + half)[f"outer_{side}_2"]
        np.testing.assert_allclose(rear_later, front, rtol=0, atol=1e-15)
        # with a π lag and an offset the two joints are mirrored about the offset
        np.testing.assert_allclose(v[f"outer_{side}_2"] - offset, -(v[f"outer_{side}_1"] - offset),
                                   rtol=0, atol=1e-15)
    # the front outer wave itself: offset + A sin(2π f t + phase)
    np.testing.assert_allclose(v["outer_top_1"], offset + amplitude * np.sin(2 * np.pi * f * t
                                                                            + 0.3),
                               rtol=0, atol=1e-15)


def test_joint_lag_direction_on_a_longer_spine():
    # a quarter-period lag tells "behind" from "ahead" (π cannot): joint j + 1 repeats joint j's
    # value a quarter period later
    f = 0.5
    gait = tetraspine_sine(tetraspine(4), 0.01, f, joint_lag=math.pi / 2)
    t = np.linspace(0.0, 4.0, 401)
    now, later = _columns(gait, t), _columns(gait, t + 1 / (4 * f))
    for joint in (1, 2):
        for kind in ("outer_left", "inner_top"):
            np.testing.assert_allclose(later[f"{kind}_{joint + 1}"], now[f"{kind}_{joint}"],
                                       rtol=0, atol=1e-15)  # sin rounding only


def test_tagged_sine_combines_signs_and_phases_of_tags():
    spine = tetraspine3()
    gait = tagged_sine(spine, 0.02, 1.0, sign={"inner": -1.0, "top": -1.0},
                       phase={"joint_2": 1.0, "left": 0.5}, cables=["inner_top_2", "outer_left_2"])
    assert gait.cables == ("inner_top_2", "outer_left_2")
    assert gait.amplitude == (0.02, 0.02)  # inner x top = (−1)(−1); outer left = +1
    assert gait.phase == (1.0, 1.5)


def test_tetraspine_sine_needs_inner_outer_and_joint_tags():
    spine = tetraspine3()
    untagged = spine.replace_cables(tags=("joint_1",))
    with pytest.raises(ValueError, match="inner"):
        tetraspine_sine(untagged, 0.01, 1.0)
    no_joint = spine.replace_cables(tags=("inner",))
    with pytest.raises(ValueError, match="joint"):
        tetraspine_sine(no_joint, 0.01, 1.0)


def test_controller_writes_the_sampled_gait_by_cable_name():
    structure = tetraspine3()
    compiled = compile_structure(structure)
    gait = tetraspine_sine(structure, 0.005, 0.5)
    controller = SineController(gait, impedance_controller(3), duration=0.4, sample_steps=5)
    with Simulation(compiled, controller=controller) as sim:
        drive = sim.drive
        assert drive.table_dt == pytest.approx(5 * sim.dt)
        times = np.arange(drive.target_velocity.shape[0]) * drive.table_dt
        assert times[-1] == pytest.approx(0.4)  # rows cover 0 .. duration inclusive
        expected = gait.table(times)
        for k, name in enumerate(gait.cables):
            np.testing.assert_array_equal(drive.target_velocity[:, sim.index.cable_id(name)],
                                          expected[:, k])
        assert (drive.mode == MODE_IMPEDANCE).all()
        sim.run(0.3)


def test_controller_validation():
    gait = SineGait(("outer_top_1", "nope"), 0.01, 1.0)
    with pytest.raises(ValueError, match="impedance gains"):
        SineController(gait, impedance_controller(3), duration=1.0)
    ok = SineGait(("outer_top_1",), 0.01, 1.0)
    with pytest.raises(ValueError, match="duration"):
        SineController(ok, impedance_controller(3), duration=0.0)
    with pytest.raises(ValueError, match="sample_steps"):
        SineController(ok, impedance_controller(3), duration=1.0, sample_steps=0)
