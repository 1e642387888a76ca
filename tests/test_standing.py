"""Rolling robots stand as built: the presets' build pose is their static pose on frictionless
feet (tensim.models._standing), so released at their default step they neither sag nor creep
on MuJoCo's soft friction."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from tensim.design.inverse import feet, settle, with_rest_lengths
from tensim.model import WorldOptions, compile_structure
from tensim.models import six_bar, superball, three_bar
from tensim.models.three_bar import DEFAULT_TIMESTEP
from tensim.sim import COM, simulate

DRIFT = 5e-3  # m in 5 s: the bar a robot standing as built must meet


def _drift(structure) -> tuple[float, float]:
    """(centre of mass, farthest node) displacement [m] over 5 s from the build pose."""
    compiled = compile_structure(structure, WorldOptions(timestep=DEFAULT_TIMESTEP))
    ts = simulate(compiled, 5.0, record_dt=5.0).trajectory
    com = np.array([[ts[f"pos_{a}/{COM}"][k] for a in "xyz"] for k in (0, -1)])
    moved = 0.0
    for group in structure.rigid_groups():
        pose = []
        for k in (0, -1):
            rot = np.zeros(9)
            mujoco.mju_quat2Mat(rot, np.array([ts[f"quat_{a}/{group.name}"][k] for a in "wxyz"]))
            pose.append((np.array([ts[f"pos_{a}/{group.name}"][k] for a in "xyz"]),
                         rot.reshape(3, 3)))
        for node in group.nodes:
            local = compiled.index.node_local[node]
            (p0, r0), (p1, r1) = pose
            moved = max(moved, float(np.linalg.norm(p1 + r1 @ local - p0 - r0 @ local)))
    return float(np.linalg.norm(com[1] - com[0])), moved


@pytest.mark.parametrize("build", [three_bar, superball, six_bar])
def test_a_rolling_preset_stands_still_as_built(build):
    """Measured: the 3-bar's centre of mass 0.4 mm and its farthest node 0.6 mm, SUPERball's
    0.5 mm and 0.5 mm (the feet sinking into MuJoCo's soft ground), the six-bar's 0.6 mm and 0.6 mm.
    Held where its feet first touched instead, the 3-bar's feet pushed outward and crept 14 mm
    in 5 s; the six-bar built 5 cm up in its symmetric form settled 33 mm in its first second."""
    com, node = _drift(build())
    assert com < DRIFT and node < DRIFT


def _frictionless(structure):
    return dataclasses.replace(structure, rods=tuple(dataclasses.replace(r, friction=0.0)
                                                     for r in structure.rods))


def test_on_frictionless_ground_the_build_pose_needs_no_sideways_push():
    """With the rods' friction 0 the ground can only push straight up: the 3-bar built in
    its static pose on frictionless feet stays put (measured 0.18 mm), while the pose with
    its feet held where they first touched slides until its feet no longer push outward
    (measured 3.9 mm; with friction that push made it creep 14 mm)."""
    assert _drift(_frictionless(three_bar()))[1] < 5e-4
    raw = three_bar(standing=False)  # the lying form, unsettled
    raw = with_rest_lengths(raw, np.array([raw.rest_length(c) for c in raw.cables]))
    held = settle(raw, feet(raw)).pose
    assert _drift(_frictionless(held))[1] > 2e-3


def test_settle_from_a_start_pose_keeps_the_structures_rest_lengths():
    """Newton from another pose must reach the static pose of the structure's own rest
    lengths (2 % shorter here), not of the start's: the start lends positions only."""
    built = three_bar()
    shorter = with_rest_lengths(built, 0.98 * np.array([built.rest_length(c)
                                                         for c in built.cables]))
    pinned = feet(built)
    direct = settle(shorter, pinned, sliding=True)
    from_build = settle(shorter, pinned, sliding=True, start=built)
    unchanged = settle(built, pinned, sliding=True)
    moved = max(np.linalg.norm(direct.pose.position(n.name) - unchanged.pose.position(n.name))
                for n in built.nodes)
    assert moved > 1e-3  # the shorter cables do move the pose
    for node in built.nodes:
        assert np.allclose(from_build.pose.position(node.name), direct.pose.position(node.name),
                           atol=1e-6)
    assert np.allclose(from_build.tensions, direct.tensions, rtol=1e-6, atol=1e-6)
