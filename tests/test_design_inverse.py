"""Inverse statics verified by simulating the returned rest lengths."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tensim
from tensim.design import DesignError
from tensim.design.inverse import feet, inverse_statics
from tensim.hardware import node_positions
from tensim.models.prisms import prism

NODES = ("t0", "t1", "t2", "b0", "b1", "b2")


def _standing() -> tensim.Structure:
    """The 3-prism standing on its end spheres (radius 0.015 m) on the ground."""
    return prism(3, elevation=0.015)


def _turn(structure: tensim.Structure, degrees: float) -> np.ndarray:
    """The displacement of t0 when rod_0 tips ``degrees`` about its foot b0, sideways (a
    displacement that keeps the rod's length, so the target is reachable exactly)."""
    b0, t0 = structure.position("b0"), structure.position("t0")
    side = np.cross(t0 - b0, [0.0, 0.0, 1.0])
    turn = Rotation.from_rotvec(np.radians(degrees) * np.cross([0.0, 0.0, 1.0], side)
                                / np.linalg.norm(side))
    return b0 + turn.apply(t0 - b0) - t0


def test_simulated_robot_settles_at_the_target() -> None:
    structure = _standing()
    move = _turn(structure, 6.0)  # ~3 cm sideways
    result = inverse_statics(structure, {"t0": tuple(move)})
    assert feet(structure) == ("b0", "b1", "b2")
    assert np.all(result.tensions >= 1.0 - 1e-6)
    assert max(result.friction_needed.values()) <= 1.0  # the rods' friction coefficient
    compiled = tensim.compile_structure(structure)
    run = tensim.simulate(compiled, 4.0, controller=result.command())
    settled = node_positions(run.trajectory, compiled, NODES)
    for node in NODES:
        end = settled[node]
        # still: under 0.1 mm in the last second
        assert np.linalg.norm(end[-1] - end[-100]) < 1e-4, node
        # within 2.5 mm of the static answer, for a ~30 mm move: MuJoCo's soft contact lets
        # the feet sink ~0.4 mm and slide ~1.5 mm while the motors wind, where the statics
        # holds them
        assert np.linalg.norm(end[-1] - result.target.position(node)) < 2.5e-3, node
    # and the move happened: t0 went where it was asked (from its standing pose)
    assert np.linalg.norm(settled["t0"][-1] - structure.position("t0") - move) < 5e-3
    assert np.linalg.norm(move) > 0.025


def test_unreachable_target_says_how_far_it_goes() -> None:
    structure = _standing()
    # straight up along x: the rod on its foot cannot stretch, and the motors' 500 N cap
    # stops them long before 20 cm
    with pytest.raises(DesignError, match=r"unreachable: asked to move t0 by .* nearest static "
                       r"pose moves t0 by"):
        inverse_statics(structure, {"t0": (0.2, 0.0, 0.0)})
    with pytest.raises(DesignError, match="is a foot"):
        inverse_statics(structure, {"b0": (0.01, 0.0, 0.0)})
    with pytest.raises(DesignError, match="unknown node 'zz'"):
        inverse_statics(structure, {"zz": (0.01, 0.0, 0.0)})


def test_pull_command_refuses_an_unreachable_target_and_writes_nothing(tmp_path,
                                                                        capsys) -> None:
    from tensim.cli import main

    out = tmp_path / "pull"
    assert main(["design", "pull", "prism3", "--move", "t0=0.2,0,0", "--out", str(out)]) == 2
    assert "unreachable" in capsys.readouterr().err
    assert not out.exists()


def test_verify_winds_slowly_and_reports_small_errors() -> None:
    from tensim.design.verify import settle_errors

    structure = _standing()
    result = inverse_statics(structure, {"t0": tuple(_turn(structure, 4.0))})
    errors, duration = settle_errors(structure, result)
    # the slowest motor winds |change| / 0.01 m/s, then 2 s of rest
    assert duration == pytest.approx(round(np.abs(result.change).max() / 0.01 + 2.0, 1))
    assert set(errors) == set(NODES)
    assert max(errors.values()) < 2.5e-3  # m, as in the fast-wind test above


def test_the_feet_use_at_most_half_their_friction_cone() -> None:
    # The statics may lean on half the feet's friction, inside the cone |f_t| <= mu f_z: a
    # 3-prism on rods of friction 0.1 is held with its feet pushing outward, at the
    # linearised pyramid's bound |f_x|, |f_y| <= 0.5 mu f_z / sqrt(2) on one axis of each foot,
    # so inside |f_t| <= 0.5 mu f_z on all (measured 0.35-0.41 mu). Half the cone replaced by
    # the whole, or the pyramid's sqrt(2) dropped, went unseen: they reach 0.82 mu and 0.58 mu.
    import dataclasses

    structure = _standing()
    structure = dataclasses.replace(structure, rods=tuple(
        dataclasses.replace(r, friction=0.1) for r in structure.rods))
    result = inverse_statics(structure, {"t0": tuple(_turn(structure, 3.0))})
    for foot, force in result.feet.items():
        assert np.hypot(force[0], force[1]) <= 0.5 * 0.1 * force[2] * (1 + 1e-6), foot
    assert max(result.friction_needed.values()) > 0.3 * 0.1  # the bound is what holds them


def test_a_step_that_crosses_a_cables_anchors_is_a_design_error() -> None:
    """A cable anchored anchor_offset from its nodes has no pose with its nodes closer than
    twice that: a solve that steps there has no answer (a DesignError the rolling gait and
    the other callers handle), not a malformed structure."""
    import dataclasses

    from tensim.design._bodies import bodies
    from tensim.design.inverse import _move
    from tensim.models import three_bar

    robot = three_bar()
    cables = list(robot.cables)
    cables[0] = dataclasses.replace(cables[0], anchor_offset=0.05)
    robot = dataclasses.replace(robot, cables=tuple(cables))
    body_set = bodies(robot)
    a, b = robot.cables[0].nodes
    k = body_set.node_body[b]
    twist = np.zeros(6 * len(body_set.com))
    twist[6 * k:6 * k + 3] = robot.position(a) - robot.position(b)  # node b onto node a
    with pytest.raises(DesignError, match="anchor_offset"):
        _move(robot, body_set, twist)
