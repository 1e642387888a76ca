"""Compilation into MuJoCo: bodies, masses, inertia regularization of thin rods, cable anchors."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from tensim.model import ModelError, WorldOptions, compile_structure
from tensim.models import tetraspine3
from tensim.sim import Simulation
from tensim.structure import Cable, Node, PointMass, Rod, Structure

LENGTH, RADIUS, LAMBDA = 0.8, 0.005, 0.12  # thin rod: 0.8 m long, 5 mm radius, 0.12 kg/m


def _stick() -> Structure:
    nodes = (Node("a", (0.0, 0.0, 0.5)), Node("b", (LENGTH, 0.0, 0.5)))
    return Structure("stick", nodes, (Rod("pole", ("a", "b"), RADIUS, linear_density=LAMBDA,
                                          tags=("stick",)),))


def _body_id(model: mujoco.MjModel, name: str) -> int:
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)


def test_thin_rod_inertia_is_regularized():
    world = WorldOptions(min_inertia_ratio=0.01)
    compiled = compile_structure(_stick(), world)
    assert compiled.inertia_adjusted == ("stick",)
    body = _body_id(compiled.model, "stick")
    moments = np.sort(compiled.model.body_inertia[body])
    mass = LAMBDA * LENGTH
    # closed form for a solid cylinder: m r^2 / 2 about the axis, m (3 r^2 + L^2) / 12 across
    axial, across = 0.5 * mass * RADIUS**2, mass * (3 * RADIUS**2 + LENGTH**2) / 12
    assert axial < world.min_inertia_ratio * across  # the rod really is thin
    assert compiled.model.body_mass[body] == pytest.approx(mass, rel=1e-12)  # rounding only
    # MuJoCo diagonalises the full inertia itself; its eigen-solver is accurate to ~1e-10 rel
    assert moments[2] == pytest.approx(across, rel=1e-9)
    assert moments[1] == pytest.approx(across, rel=1e-9)
    assert moments[0] >= world.min_inertia_ratio * moments[2] * (1 - 1e-9)
    # raised exactly to the floor, not beyond (same eigen-solver accuracy)
    assert moments[0] == pytest.approx(world.min_inertia_ratio * across, rel=1e-9)


def test_thin_rod_can_be_refused():
    with pytest.raises(ModelError, match="'stick'"):
        compile_structure(_stick(), WorldOptions(thin_body="refuse"))


def test_body_with_end_masses_is_left_alone():
    """A rod with heavy end masses is not thin: its inertia stays exactly what physics says."""
    masses = (PointMass("a", 1.0, 0.1), PointMass("b", 1.0, 0.1))
    s = Structure("dumbbell", _stick().nodes, _stick().rods, point_masses=masses)
    compiled = compile_structure(s, WorldOptions(thin_body="refuse"))
    assert compiled.inertia_adjusted == ()
    moments = np.sort(compiled.model.body_inertia[_body_id(compiled.model, "stick")])
    rod = LAMBDA * LENGTH
    sphere = 0.4 * 1.0 * 0.1**2
    axial = 0.5 * rod * RADIUS**2 + 2 * sphere
    across = rod * (3 * RADIUS**2 + LENGTH**2) / 12 + 2 * (sphere + 1.0 * (LENGTH / 2) ** 2)
    # MuJoCo's eigen-decomposition of the full inertia: ~1e-10 relative
    np.testing.assert_allclose(moments, [axial, across, across], rtol=1e-9)


def test_fixed_node_and_world_anchor():
    """A fixed node without a rod is a world point; a rod touching a fixed node is welded."""
    nodes = (Node("w", (0.0, 0.0, 2.0), fixed=True), Node("a", (0.0, 0.0, 1.0), fixed=True),
             Node("b", (1.0, 0.0, 1.0)))
    s = Structure("fixed", nodes, (Rod("r", ("a", "b"), 0.01, linear_density=0.1),),
                  (Cable("c", ("w", "b"), 50.0, pretension=2.0),))
    compiled = compile_structure(s, WorldOptions(ground=False))
    assert compiled.index.node_body["w"] == 0
    assert compiled.model.nv == 0  # the only body is welded
    with Simulation(compiled) as sim:
        # the tendon spans the build-pose distance sqrt(2) m between the two nodes
        assert sim.data.ten_length[0] == pytest.approx(math.sqrt(2), abs=1e-12)  # rounding


# -- Tetraspine3 against the hardware paper's numbers ------------------------------------------


def test_tetraspine3_geometry_and_masses():
    s = tetraspine3()
    compiled = compile_structure(s)
    with Simulation(compiled) as sim:
        length = sim.data.ten_length[compiled.index.tendon].copy()  # MuJoCo's own tendons
        tension0 = sim.drive.tension.copy()
    names = compiled.index.cables
    outer = np.array([n.startswith("outer") for n in names])
    assert outer.sum() == 6 and (~outer).sum() == 6
    # reference anchor-to-anchor lengths, given to 1e-4 m in the reference
    np.testing.assert_allclose(length[outer], 0.22365, atol=1e-4)
    np.testing.assert_allclose(length[~outer], 0.21395, atol=1e-4)
    # reference segment masses, given to the gram
    masses = compiled.model.body_mass[compiled.index.body]
    np.testing.assert_allclose(masses, [0.713, 0.913, 0.723], atol=1e-3)
    # rest length = length - pretension / stiffness (pretension 20 N top, 7 N sides)
    pretension = np.array([20.0 if n.split("_")[1] == "top" else 7.0 for n in names])
    stiffness = np.array([c.stiffness for c in s.cables])
    # exact geometry from MuJoCo's tendon vs the structure's: both rounding-level (~1e-15 m)
    np.testing.assert_allclose(compiled.rest_length, length - pretension / stiffness,
                               rtol=0, atol=1e-12)
    # and the load cells read the pretension at t = 0 (k times a ~1e-15 m rounding error)
    np.testing.assert_allclose(tension0, pretension, rtol=0, atol=1e-9)
