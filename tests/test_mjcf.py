"""MJCF export: the file loads in plain MuJoCo, matches the compiled model, and its tendon
springs reproduce the cable law while the cables are taut."""

from __future__ import annotations

import dataclasses
import pickle

import mujoco
import numpy as np
import pytest

from tensim.cli import main
from tensim.io import mjcf_spec, save_mjcf, to_mjcf
from tensim.model import WorldOptions, compile_spec, compile_structure, without_cable_law
from tensim.models import preset, six_bar
from tensim.models.six_bar import six_bar_nodes
from tensim.sim import Simulation
from tensim.structure import Cable, Node, PointMass, Rod, Structure


def _routed() -> Structure:
    """Two rods joined by a cable routed through a free point mass."""
    nodes = (Node("a0", (0.0, 0.0, 0.3)), Node("a1", (0.0, 0.3, 0.3)),
             Node("b0", (0.5, 0.0, 0.3)), Node("b1", (0.5, 0.3, 0.3)),
             Node("v", (0.25, 0.15, 0.5)))
    rods = (Rod("ra", ("a0", "a1"), 0.01, linear_density=0.2),
            Rod("rb", ("b0", "b1"), 0.01, linear_density=0.2))
    cables = (Cable("c", ("a0", "b1"), 100.0, damping=1.0, pretension=2.0, via=("v",)),)
    return Structure("routed", nodes, rods, cables, (PointMass("v", 0.05, 0.01),))


MODELS = {"prism3": lambda: preset("prism3").build(), "six_bar": lambda: preset("six_bar").build(),
          "tetraspine3": lambda: preset("tetraspine3").build(), "routed": _routed}


@pytest.mark.parametrize("name", sorted(MODELS))
def test_export_loads_back_with_the_same_model(name, tmp_path):
    compiled = compile_structure(MODELS[name]())
    path = save_mjcf(compiled, tmp_path / f"{name}.xml", springs=False)
    # the file holds the robot without tensim's law: each cable a plain force input
    m, c = mujoco.MjModel.from_xml_path(str(path)), compile_spec(without_cable_law(compiled))
    # and a hidden site marking each node (for import-mjcf)
    assert m.nsite == c.nsite + len(compiled.structure.nodes)
    c = compile_spec(mjcf_spec(compiled, springs=False))
    assert (m.nbody, m.ngeom, m.nsite, m.ntendon, m.nu, m.nq) == \
        (c.nbody, c.ngeom, c.nsite, c.ntendon, c.nu, c.nq)
    for kind, count in ((mujoco.mjtObj.mjOBJ_BODY, c.nbody), (mujoco.mjtObj.mjOBJ_TENDON,
                                                               c.ntendon)):
        assert [mujoco.mj_id2name(m, kind, i) for i in range(count)] == \
            [mujoco.mj_id2name(c, kind, i) for i in range(count)]
    # MuJoCo writes 6 significant digits: masses and inertias agree to that
    np.testing.assert_allclose(m.body_mass, c.body_mass, rtol=1e-5)
    np.testing.assert_allclose(m.body_inertia, c.body_inertia, rtol=2e-5, atol=1e-12)
    np.testing.assert_allclose(m.tendon_num, c.tendon_num)
    # stepping with zero control (no cable forces): the same trajectory. Positions written
    # with 6 digits are off by < 1e-6 m and masses by < 1e-5 relative; over 0.1 s of falling
    # and ground contact that moves the bodies apart by at most a few micrometres
    d_file, d_model = mujoco.MjData(m), mujoco.MjData(c)
    for _ in range(100):
        mujoco.mj_step(m, d_file)
        mujoco.mj_step(c, d_model)
    moved = np.abs(d_model.qpos - c.qpos0).max()
    assert moved > 1e-3  # the comparison is not trivial: things moved
    np.testing.assert_allclose(d_file.qpos, d_model.qpos, rtol=0, atol=2e-5)


def _six_bar_axis_aligned() -> Structure:
    """The six-bar's symmetric form with its struts along x, y and z, 5 cm up: round numbers
    (the preset stands on a face in its settled pose instead)."""
    form = six_bar(standing=False)
    nodes = six_bar_nodes()
    lift = 0.05 - min(p[2] for p in nodes.values())
    return dataclasses.replace(form, nodes=tuple(
        dataclasses.replace(n, position=(nodes[n.name][0], nodes[n.name][1],
                                         nodes[n.name][2] + lift)) for n in form.nodes))


@pytest.mark.parametrize(("name", "atol"), [
    ("six_bar", 1e-6),  # every number of its model fits in 6 digits: rounding of sums only
    ("prism3", 3e-5),  # node positions like 0.0133975 m carry the XML's 6-digit rounding
])
def test_tendon_springs_reproduce_the_cable_law_while_taut(name, atol):
    robot = preset(name).build() if name != "six_bar" else _six_bar_axis_aligned()
    compiled = compile_structure(robot, WorldOptions())
    m = mujoco.MjModel.from_xml_string(to_mjcf(compiled, springs=True))
    data = mujoco.MjData(m)
    with Simulation(compiled, backend="python") as sim:
        for _ in range(1000):  # 1 s: the structure drops 2-5 cm onto the ground and settles
            sim.step(1)
            while data.time < sim.data.time - 1e-9:
                mujoco.mj_step(m, data)
            # the dead-band spring is the cable law exactly while every cable is taut and
            # pulling (MuJoCo also damps slack tendons, which never happens here)
            assert sim.drive.tension.min() > 0 and sim.drive.applied.min() > 0
        np.testing.assert_allclose(data.qpos, sim.data.qpos, rtol=0, atol=atol)
    assert np.abs(sim.data.qpos - compiled.model.qpos0).max() > 1e-2  # it did move


def test_springs_hold_the_rest_lengths():
    compiled = compile_structure(_routed())
    m = mujoco.MjModel.from_xml_string(to_mjcf(compiled))
    np.testing.assert_allclose(m.tendon_stiffness, compiled.law().stiffness)
    np.testing.assert_allclose(m.tendon_damping, compiled.law().damping)
    np.testing.assert_allclose(m.tendon_lengthspring[:, 1], compiled.rest_length, rtol=1e-5)
    np.testing.assert_array_equal(m.tendon_lengthspring[:, 0], 0.0)
    bare = mujoco.MjModel.from_xml_string(to_mjcf(compiled, springs=False))
    np.testing.assert_array_equal(bare.tendon_stiffness, 0.0)


def test_a_pickled_model_still_exports():
    compiled = compile_structure(preset("prism3").build())
    copy = pickle.loads(pickle.dumps(compiled))
    assert copy.spec is None  # an MjSpec does not pickle; export compiles the structure again
    assert to_mjcf(copy) == to_mjcf(compiled)


def test_cli_writes_a_loadable_file(tmp_path, capsys):
    out = tmp_path / "sub" / "prism3.xml"
    assert main(["export-mjcf", "prism3", "--out", str(out)]) == 0
    assert "9 tendons" in capsys.readouterr().out
    m = mujoco.MjModel.from_xml_path(str(out))
    assert m.ntendon == 9 and np.all(m.tendon_stiffness > 0)
    assert [p.name for p in out.parent.iterdir()] == ["prism3.xml"]  # no temporary file left
