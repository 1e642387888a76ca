"""Engine options: the midphase default is exact; self-collision off drops only robot pairs;
torsional and rolling friction against their closed-form decelerations."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from tensim import (
    Node,
    PointMass,
    Rod,
    Simulation,
    Structure,
    WorldOptions,
    compile_structure,
    simulate,
)
from tensim.models import preset


def _crossed_rods() -> Structure:
    """Two separate rods (two bodies) crossing at the origin, 1 cm apart at the crossing."""
    nodes = (Node("a0", (-0.5, 0, 0.3)), Node("a1", (0.5, 0, 0.3)),
             Node("b0", (0, -0.5, 0.31)), Node("b1", (0, 0.5, 0.31)))
    rods = (Rod("a", ("a0", "a1"), radius=0.01, linear_density=0.1),
            Rod("b", ("b0", "b1"), radius=0.01, linear_density=0.1))
    return Structure("crossed", nodes=nodes, rods=rods)


def _contacts(world: WorldOptions) -> list[tuple[str, str]]:
    compiled = compile_structure(_crossed_rods(), world)
    model, data = compiled.model, mujoco.MjData(compiled.model)
    mujoco.mj_forward(model, data)

    def name(geom: int) -> str:
        return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom) or "ground"

    return sorted(tuple(sorted((name(c.geom1), name(c.geom2)))) for c in data.contact[:data.ncon])


def test_self_collision_off_drops_the_robots_own_pairs_and_keeps_the_ground():
    # the capsules overlap (radii 1 + 1 cm, axes 1 cm apart) and sit 0.3 m above the ground
    assert _contacts(WorldOptions()) == [("a", "b")]
    assert _contacts(WorldOptions(self_collision=False)) == []
    low = Structure("low", nodes=(Node("a0", (-0.5, 0, 0.005)), Node("a1", (0.5, 0, 0.005))),
                    rods=(Rod("a", ("a0", "a1"), radius=0.01, linear_density=0.1),))
    compiled = compile_structure(low, WorldOptions(self_collision=False))
    data = mujoco.MjData(compiled.model)
    mujoco.mj_forward(compiled.model, data)
    assert data.ncon > 0  # a rod lying on the ground still touches it


def test_the_midphase_is_off_by_default_and_changes_nothing():
    flag = mujoco.mjtDisableBit.mjDSBL_MIDPHASE
    robot = preset("prism3").build()
    off = compile_structure(robot)
    on = compile_structure(robot, WorldOptions(midphase=True))
    assert off.model.opt.disableflags & flag and not on.model.opt.disableflags & flag
    # a passive prism dropped onto the ground: the same contacts, so the same run, bit for bit
    runs = [simulate(c, 1.0).trajectory for c in (off, on)]
    assert np.array_equal(runs[0].matrix("tension"), runs[1].matrix("tension"))
    assert np.array_equal(runs[0]["pos_z/com"], runs[1]["pos_z/com"])


# -- contact friction options ------------------------------------------------------------------

BALL_R, G = 0.05, 9.81  # m, m/s^2


def _ball(world: WorldOptions) -> object:
    """A 1 kg solid sphere (a lone point mass) resting on the ground."""
    s = Structure("ball", nodes=(Node("n", (0.0, 0.0, BALL_R)),),
                  point_masses=(PointMass("n", 1.0, radius=BALL_R),))
    return compile_structure(s, world)


def _run_ball(world: WorldOptions, qvel: list[float], duration: float) -> np.ndarray:
    with Simulation(_ball(world)) as sim:
        sim.data.qvel[:] = qvel
        sim.run(duration)
        return sim.data.qvel.copy()


def test_torsional_friction_spins_a_ball_down_only_with_condim_4_or_6():
    # spinning in place at 10 rad/s: torsional friction mu_t N brakes it at
    # mu_t m g / I = 0.005 x 9.81 / (0.4 x 0.05^2) = 49 rad/s^2
    spin = [0.0, 0.0, 0.0, 0.0, 0.0, 10.0]
    assert _run_ball(WorldOptions(), spin, 0.1)[5] == pytest.approx(10.0, abs=1e-9)
    expected = 10.0 - 0.005 * G / (0.4 * BALL_R**2) * 0.1  # 5.1 rad/s
    for condim in (4, 6):
        # MuJoCo's soft contact reaches ~90 % of the Coulomb limit: 5.6 rad/s measured
        assert _run_ball(WorldOptions(condim=condim), spin, 0.1)[5] == pytest.approx(
            expected, abs=0.15 * (10.0 - expected))


def test_rolling_friction_slows_a_rolling_ball_only_with_condim_6():
    # rolling at 1 m/s: rolling friction mu_r N decelerates a solid sphere at
    # mu_r g / (1.4 R) = 0.005 x 9.81 / 0.07 = 0.70 m/s^2
    roll = [1.0, 0.0, 0.0, 0.0, 1.0 / BALL_R, 0.0]
    for condim in (3, 4):
        world = WorldOptions(condim=condim, rolling_friction=0.005)
        assert _run_ball(world, roll, 0.5)[0] == pytest.approx(1.0, abs=2e-3)
    expected = 1.0 - 0.005 * G / (1.4 * BALL_R) * 0.5  # 0.65 m/s
    slowed = _run_ball(WorldOptions(condim=6, rolling_friction=0.005), roll, 0.5)[0]
    # soft contact again: 0.68 m/s measured, within 15 % of the closed-form change
    assert slowed == pytest.approx(expected, abs=0.15 * (1.0 - expected))


def test_contact_options_reach_the_model_and_are_validated():
    model = _ball(WorldOptions(cone="elliptic", noslip_iterations=5, condim=6,
                               torsional_friction=0.01, rolling_friction=0.002)).model
    assert model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    assert model.opt.noslip_iterations == 5
    robot = model.geom_bodyid != 0
    assert set(model.geom_condim[robot]) == {6}
    np.testing.assert_array_equal(model.geom_friction[robot, 1:], [[0.01, 0.002]])
    for bad, match in ((dict(cone="round"), "cone must be"),
                       (dict(noslip_iterations=1.5), "noslip_iterations must be"),
                       (dict(condim=5), "condim must be 3, 4 or 6"),
                       (dict(torsional_friction=-1.0), "torsional_friction must be")):
        with pytest.raises(ValueError, match=match):
            WorldOptions(**bad)
