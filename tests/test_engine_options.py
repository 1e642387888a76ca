"""Engine options: the midphase default is exact; self-collision off drops only robot pairs."""

from __future__ import annotations

import mujoco
import numpy as np

from tensim import Node, Rod, Structure, WorldOptions, compile_structure, simulate
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
