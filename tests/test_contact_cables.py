"""Contact cables: one tendon over light collision beads, against closed forms (a slack cable
on the ground, a taut one over a block edge, the law on the whole path, a free cable against
the straight one) and the tunnelling check."""

from __future__ import annotations

import dataclasses
import logging
import math
import re

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensim import InputError
from tensim.model import WorldOptions, _beads, compile_structure
from tensim.sim import Simulation, SimulationError
from tensim.structure import (
    Cable,
    CableContact,
    Motor,
    Node,
    PointMass,
    Structure,
    StructureError,
    structure_from_dict,
    structure_to_dict,
)
from tensim.terrain import Wall

R = 0.005  # bead radius [m]
K = 1000.0  # cable stiffness [N/m]
G = 9.81


def _bead_contact_force(m: mujoco.MjModel, d: mujoco.MjData) -> np.ndarray:
    """(3,) the world's push on all beads [N]."""
    total = np.zeros(3)
    for i in range(d.ncon):
        contact, force = d.contact[i], np.zeros(6)
        names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in contact.geom]
        if not any("_bead" in n for n in names):
            continue
        mujoco.mj_contactForce(m, d, i, force)
        world_first = m.geom_bodyid[contact.geom[0]] == 0  # the frame's normal points 0 -> 1
        total += (1 if world_first else -1) * force[:3] @ contact.frame.reshape(3, 3)
    return total


def _hanging_over_edge(damping: float = 20.0, mass: float = 0.001) -> Structure:
    """A 1 kg mass on a cable from an anchor on top of a 0.3 m block, released level with the
    top beside the block's edge (x = 0, z = 0.3): it falls and hangs over the edge."""
    return Structure(
        "edge", (Node("a", (-0.08, 0.0, R), fixed=True), Node("b", (0.15, 0.0, R))),
        point_masses=(PointMass("b", 1.0, 0.002),),
        cables=(Cable("c", ("a", "b"), K, damping=damping, rest_length=0.2,
                      contact=CableContact(spacing=0.02, radius=R, mass=mass)),))


EDGE_WALL = Wall(height=0.3, distance=-0.1, thickness=0.1)  # top face x in [-0.1, 0]


def test_a_taut_cable_over_a_block_edge_pushes_it_with_the_sum_of_the_two_tensions():
    compiled = compile_structure(_hanging_over_edge(), WorldOptions(terrain=EDGE_WALL))
    with Simulation(compiled) as sim:
        sim.run(3.0)
        m, d = sim.model, sim.data
        push, pull = np.zeros(3), np.zeros(3)
        steps = 1000  # average over 1 s: the mass still swings a little on the cable
        for _ in range(steps):
            sim.step(1)
            path = d.wrap_xpos.reshape(-1, 3)[d.ten_wrapadr[0]:d.ten_wrapadr[0]
                                              + d.ten_wrapnum[0]]
            # the two straight parts (on the top face, hanging down the side) pull along
            # themselves, from the block toward anchor a and toward the mass
            ends = [(path[0] - path[1]), (path[-1] - path[-2])]
            pull += -d.actuator_force[0] * sum(e / np.linalg.norm(e) for e in ends) / steps
            push += -_bead_contact_force(m, d) / steps
        weight = G * m.body_mass[compiled.index.bead].sum()
        assert -d.actuator_force[0] > 5.0  # taut: the 1 kg mass hangs on it
        assert abs(pull[0]) > 5.0 and abs(pull[2]) > 5.0  # both tensions press on the block
        # the block takes the vector sum of the two tensions, plus at most the weight of the
        # beads on it and the span springs' pulls (a bead weight per span at most)
        np.testing.assert_allclose(push, pull, atol=2 * weight)
        # the path over the edge: bead centres ride R off the faces, and a span may cut the
        # corner by at most its length limit (1.5 build spans) times (sqrt 2 - 1)
        edge = np.array([0.0, 0.0, 0.3])
        closed = sum(np.linalg.norm(p - edge) for p in (path[0], path[-1]))
        span = np.max(m.tendon_range[1:, 1])
        assert closed - span * (math.sqrt(2) - 1) - 2 * R <= d.ten_length[0] <= closed + 2 * R


def test_a_slack_contact_cable_on_the_ground_carries_no_tension():
    s = Structure(
        "slack", (Node("a", (0.0, 0.0, R), fixed=True), Node("b", (0.3, 0.0, R), fixed=True)),
        cables=(Cable("c", ("a", "b"), K, damping=5.0, rest_length=0.4,
                      contact=CableContact(spacing=0.05, radius=R)),))
    with Simulation(compile_structure(s)) as sim:
        series = sim.run(1.0)
        m, d = sim.model, sim.data
        assert np.all(series["tension/c"] == 0.0)  # length 0.3 m < rest length 0.4 m
        assert d.actuator_force[0] == 0.0
        beads = d.xpos[[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"c_bead{k}")
                        for k in range(5)]]
        # the beads lie on the ground (centres one radius up, within MuJoCo's soft contact),
        # in order along the line between the anchors
        np.testing.assert_allclose(beads[:, 2], R, atol=2e-4)
        assert np.all(np.diff(beads[:, 0]) > 0)


def test_the_law_acts_on_the_whole_bead_path_and_each_anchor_feels_that_tension():
    s = _hanging_over_edge()
    compiled = compile_structure(s, WorldOptions(terrain=EDGE_WALL))
    with Simulation(compiled) as sim:
        sim.run(1.0)
        m, d = sim.model, sim.data
        x = d.ten_length[0]
        path = d.wrap_xpos.reshape(-1, 3)[d.ten_wrapadr[0]:d.ten_wrapadr[0] + d.ten_wrapnum[0]]
        # the tendon's length is the polyline through the anchors and every bead centre
        assert x == pytest.approx(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)),
                                  abs=1e-12)
        # the law on that length: k (x - l) + b dx/dt with the motor's new rest length l
        rest = d.act[0] + d.act_dot[0] * m.opt.timestep
        law = K * (x - rest) + 20.0 * d.ten_velocity[0]
        assert law > 1.0
        assert -d.actuator_force[0] == pytest.approx(law, rel=1e-12)
        # the cable's actuator pulls anchor b along the last span with the law's tension:
        # its generalized force on b's free joint is T times the unit vector toward the bead
        b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "b")
        dof = m.body_dofadr[b]
        pull = d.qfrc_actuator[dof:dof + 3]
        toward = (path[-2] - path[-1]) / np.linalg.norm(path[-2] - path[-1])
        np.testing.assert_allclose(pull, -d.actuator_force[0] * toward, rtol=1e-9, atol=1e-12)


def _swing(contact: bool) -> tuple[np.ndarray, float]:
    """Tension over the first quarter swing (0.4 s) of a 1 kg pendulum on an unloaded 0.3 m
    cable, released horizontal, far from anything (2 m above the ground), at 0.5 ms steps
    (light beads: 2 g and 3 g of armature each); and the beads' inertia [kg]."""
    cable = Cable("c", ("a", "b"), K, damping=5.0, rest_length=0.3,
                  contact=CableContact(spacing=0.05, radius=R, mass=2e-3) if contact else None)
    s = Structure("swing", (Node("a", (0, 0, 2.0), fixed=True), Node("b", (0.3, 0, 2.0))),
                  point_masses=(PointMass("b", 1.0, 0.005),), cables=(cable,))
    compiled = compile_structure(s, WorldOptions(timestep=5e-4))
    m, beads = compiled.model, compiled.index.bead
    inertia = m.body_mass[beads].sum() + m.dof_armature[m.body_dofadr[beads]].sum()
    with Simulation(compiled) as sim:
        return sim.run(0.4)["tension/c"], float(inertia)


def test_a_contact_cable_far_from_anything_carries_the_straight_cables_tension():
    (straight, _), (beaded, inertia) = _swing(False), _swing(True)
    assert straight.max() > 2.5 * G  # at the bottom: 3 m g less the cable's stretch
    assert 0.0 < inertia < 0.05
    # the beads add their inertia (mass and armature, 25 g) to the 1 kg that swings: the
    # tensions differ by about that share of the peak; at the start, with the cable
    # unloaded, the beads' lag sags it too: 1.5 times the share covers both
    assert np.max(np.abs(beaded - straight)) < 1.5 * inertia / 1.0 * straight.max()


def test_cables_without_contact_compile_as_before():
    s = _hanging_over_edge()
    plain = Structure(s.name, s.nodes, cables=(Cable("c", ("a", "b"), K, damping=20.0,
                                                     rest_length=0.2),),
                      point_masses=s.point_masses)
    m = compile_structure(plain, WorldOptions(terrain=EDGE_WALL)).model
    assert m.nbody == 2 and m.ntendon == 1 and m.neq == 0
    assert all(m.geom_contype[g] == 1 for g in range(m.ngeom) if m.geom_bodyid[g] == 0)



def _taut_along_y(name: str) -> Structure:
    """A taut contact cable along y at x = 0.15 m between fixed anchors, beads 3 cm apart."""
    return Structure(
        name, (Node("a", (0.15, -0.1, R), fixed=True), Node("b", (0.15, 0.1, R), fixed=True)),
        cables=(Cable("c", ("a", "b"), K, damping=5.0, pretension=5.0,
                      contact=CableContact(spacing=0.03, radius=R)),))

def test_a_cable_whipped_through_a_thin_wall_is_reported():
    # a taut cable along y, 3 cm beside a 3 cm wall; its beads are flung at the wall at
    # 40 m/s, 4 cm per step: they land inside it, which the check reports with what to change
    s = _taut_along_y("whip")
    wall = Wall(height=0.05, distance=0.09, thickness=0.03, width=0.4)
    with Simulation(compile_structure(s, WorldOptions(terrain=wall))) as sim:
        beads = [j for j in range(sim.model.njnt) if sim.model.jnt_type[j] == 2
                 and sim.model.jnt_axis[j, 0] == 1.0]
        sim.data.qvel[sim.model.jnt_dofadr[beads]] = -40.0
        with pytest.raises(SimulationError, match=r"contact cable tunnelled .* inside "
                           r"'terrain_box_0'.* smaller timestep \(--dt\) or a smaller bead "
                           r"spacing"):
            sim.step(2)  # the first step moves them, the second finds them inside


def test_a_cable_whose_beads_jumped_a_thin_plate_is_reported():
    # a taut cable along y, 4.5 cm beside a 5 mm plate; its beads put 2 cm past the plate
    # (as a step of 7 cm would, too fast to meet it): the spans from the anchors to the
    # outer beads now run through the plate, which the check reports
    s = _taut_along_y("jump")
    plate = Wall(height=0.05, distance=0.1, thickness=0.005, width=0.4)
    with Simulation(compile_structure(s, WorldOptions(terrain=plate))) as sim:
        m = sim.model
        beads = [j for j in range(m.njnt) if m.jnt_type[j] == 2 and m.jnt_axis[j, 0] == 1.0]
        sim.data.qpos[m.jnt_qposadr[beads]] = -0.07  # x = 0.08, the plate is x in [0.1, 0.105]
        mujoco.mj_forward(m, sim.data)
        with pytest.raises(SimulationError, match=r"span (0|6) of contact cable 'c' passes "
                           r"through 'terrain_box_0' \(5\.\d mm of it inside\)"):  # oblique span
            sim.check()


def test_a_cable_trapped_in_a_corner_stays_stable():
    # a 1 kg mass pulled by the motor into the corner between the ground and a wall: the
    # beads pile up in the corner, the simulation stays finite and the tension bounded
    s = Structure(
        "corner", (Node("a", (0.05, 0.0, 0.3), fixed=True), Node("b", (0.3, 0.0, 0.01))),
        point_masses=(PointMass("b", 1.0, 0.01),),
        cables=(Cable("c", ("a", "b"), K, damping=5.0, pretension=5.0,
                      contact=CableContact(spacing=0.03, radius=R)),))
    wall = Wall(height=0.2, distance=0.1, thickness=0.05, width=1.0)
    compiled = compile_structure(s, WorldOptions(terrain=wall))
    with Simulation(compiled) as sim:
        sim.drive.rest_command[:] = 0.05  # the motor reels in at its top speed
        series = sim.run(3.0)
        m, d = sim.model, sim.data
        beads = d.xpos[[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"c_bead{k}")
                        for k in range(12)]]
    assert np.all(np.isfinite(series["tension/c"]))
    # the motor stops at its tension limit (50 N); the cable's damping adds a little on top
    assert series["tension/c"].max() < 1.2 * compiled.law().max_tension[0]
    # the beads lie outside the wall (x >= 0.15) and above the ground, none inside
    assert np.all((beads[:, 0] >= 0.15 + R - 1e-3) | (beads[:, 2] >= 0.2 + R - 1e-3))
    assert np.all(beads[:, 2] >= R - 1e-3)


def test_contact_round_trips_and_bad_contact_is_refused():
    s = _hanging_over_edge()
    assert structure_from_dict(structure_to_dict(s)) == s
    data = structure_to_dict(s)
    short = {**data, "cables": [{**data["cables"][0], "contact": True}]}
    assert structure_from_dict(short).cables[0].contact == CableContact()
    with pytest.raises(StructureError, match="contact must be true, false or a mapping"):
        structure_from_dict({**data, "cables": [{**data["cables"][0], "contact": "yes"}]})
    with pytest.raises(StructureError, match="unknown field 'beads'"):
        structure_from_dict({**data, "cables": [{**data["cables"][0], "contact": {"beads": 3}}]})
    with pytest.raises(StructureError, match="spacing must be > 0"):
        CableContact(spacing=0.0)
    with pytest.raises(StructureError, match=r"cables\[0\] 'c' contact: radius must be > 0"):
        structure_from_dict({**data, "cables": [{**data["cables"][0],
                                                 "contact": {"radius": -1.0}}]})
    assert Cable("c", ("a", "b"), K, rest_length=0.5,
                 contact={"spacing": 0.1}).contact == CableContact(spacing=0.1)
    with pytest.raises(StructureError, match="not both"):
        Cable("c", ("a", "b"), K, rest_length=0.5, wrap=("bar",), contact=True)


def test_the_drawing_follows_the_bead_path():
    from tensim.viz.cables import CableArtist

    compiled = compile_structure(_hanging_over_edge(), WorldOptions(terrain=EDGE_WALL))
    with Simulation(compiled) as sim:
        sim.run(0.5)
        m, d = sim.model, sim.data
        artist = CableArtist(compiled)
        path = artist._path(d, 0)
        beads = d.xpos[[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"c_bead{k}")
                        for k in range(len(path) - 2)]]
        np.testing.assert_allclose(path[1:-1], beads, atol=1e-12)  # through every bead
        scene = mujoco.MjvScene(m, maxgeom=artist.max_geoms)
        artist.draw(scene, d, sim.drive.tension, sim.drive.rest)
        assert scene.ngeom == len(path) - 1  # one piece per span, within the budget


def test_a_contact_cable_spans_several_segments_through_via_nodes():
    # a -> v -> b, spans of 0.2 m and 0.1 m with beads at most 0.05 m apart: 3 and 1 beads
    s = Structure(
        "span", (Node("a", (0.0, 0.0, 0.5), fixed=True), Node("v", (0.2, 0.0, 0.5), fixed=True),
                 Node("b", (0.2, 0.1, 0.5), fixed=True)),
        cables=(Cable("c", ("a", "b"), K, pretension=5.0, via=("v",),
                      contact=CableContact(spacing=0.05, radius=R)),))
    compiled = compile_structure(s, WorldOptions(gravity=(0, 0, 0)))
    m = compiled.model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    sites = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, m.wrap_objid[m.tendon_adr[0] + k])
             for k in range(m.tendon_num[0])]
    assert sites == ["c_0", "c_bead0_site", "c_bead1_site", "c_bead2_site", "c_via0",
                     "c_bead3_site", "c_1"]
    # at build the beads sit on the straight spans: the routed length, and the pretension
    assert d.ten_length[0] == pytest.approx(s.cable_length(s.cables[0]), abs=1e-12)
    assert K * (d.ten_length[0] - compiled.rest_length[0]) == pytest.approx(5.0, abs=1e-9)


def test_a_recorded_run_replays_its_beads_where_they_were():
    from pathlib import Path

    from tensim.viz.replay import PoseReplay, RecordedRun

    compiled = compile_structure(_hanging_over_edge(), WorldOptions(terrain=EDGE_WALL))
    with Simulation(compiled) as sim:
        series = sim.run(0.5)
        d = sim.data
        # the bead channels hold the beads' last positions, which replay puts back
        np.testing.assert_array_equal(series["bead_x/c_bead3"][-1],
                                      d.xpos[compiled.index.bead[3]][0])
        path = d.wrap_xpos.reshape(-1, 3)[d.ten_wrapadr[0]:d.ten_wrapadr[0] + d.ten_wrapnum[0]]
        path = path.copy()
    replay = PoseReplay(RecordedRun(Path("."), {}, series, compile_structure(
        _hanging_over_edge(), WorldOptions(terrain=EDGE_WALL))))
    placed = replay.place(series.time.size - 1)
    t = compiled.index.tendon[0]
    replayed = placed.wrap_xpos.reshape(-1, 3)[placed.ten_wrapadr[t]:placed.ten_wrapadr[t]
                                              + placed.ten_wrapnum[t]]
    np.testing.assert_allclose(replayed, path, atol=1e-12)  # the drawn path, bead for bead


def test_beads_too_light_for_the_timestep_are_named_in_the_error(monkeypatch):
    # 1 g beads without the armature that makes up their inertia (about 40 g here;
    # examples/contact_cables.py finds 8 g or less unstable)
    monkeypatch.setattr("tensim.model._beads.SAFETY", 0.0)
    compiled = compile_structure(_hanging_over_edge(mass=1e-3), WorldOptions(terrain=EDGE_WALL))
    assert not compiled.model.dof_armature.any()
    with Simulation(compiled) as sim, pytest.raises(
            SimulationError, match=r"'c_bead\d+' is a contact cable's bead \(1 g of inertia\): "
                                   r"take a smaller timestep \(--dt\), or give its cable beads "
                                   r"of more mass than that \(contact: mass\)"):
        sim.run(1.0)


def test_the_batch_engine_runs_contact_cables_as_a_single_run_does():
    from tensim.sim import Trial, compiled_available, run_batch, simulate

    if not compiled_available():
        pytest.skip("the batch engine needs the compiled cable law")
    compiled = compile_structure(_hanging_over_edge(), WorldOptions(terrain=EDGE_WALL))
    single = simulate(compiled, 0.5)
    (trial,) = run_batch(compiled, [Trial(None)], 0.5)
    assert trial.ok, trial.error
    for name, values in single.trajectory.channels.items():  # beads' channels included
        np.testing.assert_array_equal(values, trial.result.trajectory[name], err_msg=name)


def _whipped_beads_by_a_wall():
    """The whipped contact cable beside a wall: its compiled model, its resting state and the
    state with every bead flung toward the wall at 40 m/s."""
    s = _taut_along_y("whip")
    wall = Wall(height=0.05, distance=0.09, thickness=0.03, width=0.4)
    compiled = compile_structure(s, WorldOptions(terrain=wall))
    with Simulation(compiled) as sim:
        m = sim.model
        beads = [j for j in range(m.njnt) if m.jnt_type[j] == 2 and m.jnt_axis[j, 0] == 1.0]
        still = sim.get_state()
        sim.data.qvel[m.jnt_dofadr[beads]] = -40.0
        return compiled, still, sim.get_state()


def test_the_batch_engine_fails_a_trial_whose_beads_went_through_a_wall():
    # the whipped cable of the test above, as one trial of a batch beside an undisturbed one:
    # only the whipped trial fails, with the single run's message
    from tensim.sim import Trial, compiled_available, run_batch

    if not compiled_available():
        pytest.skip("the batch engine needs the compiled cable law")
    compiled, _, whipped = _whipped_beads_by_a_wall()
    calm, flung = run_batch(compiled, [Trial(None), Trial(None, initial_state=whipped)], 0.2)
    assert calm.ok, calm.error
    assert not flung.ok
    assert re.search(r"trial 1: contact cable tunnelled at t = .* inside 'terrain_box_0'.* "
                     r"smaller timestep \(--dt\) or a smaller bead spacing", flung.error)


def test_the_warp_batch_fails_a_world_whose_beads_went_through_a_wall():
    # the same two trials on MuJoCo Warp (its CPU device): the whipped world fails with the
    # single run's message, the calm one runs on (removing the Warp batch's check went unseen)
    pytest.importorskip("mujoco_warp", reason="MuJoCo Warp (pip install 'tensim[gpu]') is "
                        "not installed")
    from tensim.sim import Trial, run_batch

    # (on Warp every trial or none has a start state)
    compiled, still, whipped = _whipped_beads_by_a_wall()
    calm, flung = run_batch(compiled, [Trial(None, initial_state=still),
                                       Trial(None, initial_state=whipped)], 0.02,
                            backend="warp", device="cpu")
    assert calm.ok, calm.error
    assert not flung.ok
    assert re.search(r"trial 1: contact cable tunnelled at t = .* inside 'terrain_box_0'.* "
                     r"smaller timestep \(--dt\) or a smaller bead spacing", flung.error)


def test_a_contact_cable_through_spans_of_different_lengths_holds_its_load():
    # a -> v: 0.6 m level (5 beads 0.1 m apart), v -> b: 0.05 m down to a 1 kg mass (1 bead
    # 0.025 m apart); the statics closed form: the mass hangs at T = m g, the routed length
    # x = l + m g / k, so the mass sits where it was built, straight below v
    weight, k = 1.0 * G, K
    s = Structure(
        "spans", (Node("a", (0.0, 0.0, 1.0), fixed=True), Node("v", (0.6, 0.0, 1.0), fixed=True),
                  Node("b", (0.6, 0.0, 0.95))),
        point_masses=(PointMass("b", 1.0, 0.002),),
        cables=(Cable("c", ("a", "b"), k, damping=20.0, via=("v",), pretension=weight,
                      contact=CableContact(spacing=0.1, radius=R)),))
    compiled = compile_structure(s, WorldOptions(ground=False))
    spans = compiled.model.tendon_range[1:]
    # each span's length limits follow its own build length (0.1 m and 0.025 m)
    np.testing.assert_allclose(spans[:, 1], [0.15] * 6 + [0.0375] * 2, rtol=1e-9)
    with Simulation(compiled) as sim:
        sim.run(2.0)
        d = sim.data
        beads = d.xpos[compiled.index.bead]
        b = d.xpos[compiled.index.node_body["b"]]
        # the beads' weight (1 g each) and the span springs' pulls: within 1 %
        assert sim.drive.tension[0] == pytest.approx(weight, rel=0.01)
        np.testing.assert_allclose(b, [0.6, 0.0, 0.95], atol=1e-3)
        assert np.all(np.diff(beads[:5, 0]) > 0.09)  # spread along the level span, in order
        # the short span's bead stays on it (its weight slides it down the vertical line
        # against the span springs)
        assert beads[5, 0] == pytest.approx(0.6, abs=1e-3) and 0.95 < beads[5, 2] < 1.0


def _hanging(spacing: float, dt: float = 1e-3, max_tension: float = 50.0):
    s = _hanging_over_edge()
    cable = dataclasses.replace(s.cables[0], contact=CableContact(spacing=spacing, radius=R),
                                motor=Motor(max_tension=max_tension))
    return dataclasses.replace(s, cables=(cable,)), WorldOptions(timestep=dt, terrain=EDGE_WALL)


def test_beads_that_would_outweigh_the_robot_are_refused_with_the_figures():
    # 0.23 m at 1 mm spacing: 229 beads that each need 4 * 2 T dt^2 / l = 0.4 kg at 1 ms
    # (92 kg in all) to drag a 1 kg mass: refused; at 2 cm (the edge case) they are not
    with pytest.raises(InputError, match=r"need 91\.\d+ kg of inertia .* robot's 1 kg"):
        compile_structure(*_hanging(0.001))
    compile_structure(*_hanging(0.02))


def test_beads_that_outweigh_the_robot_less_than_tenfold_are_built_with_a_warning(caplog):
    # the bound goes as 1 / spacing^2: 92 kg at 1 mm is about 92 / 16 = 5.7 kg at 4 mm (between
    # the 1 kg robot and ten times it: a warning), 0.23 kg at 2 cm (no warning)
    with caplog.at_level(logging.WARNING, logger="tensim.model._beads"):
        compile_structure(*_hanging(0.004))
    (record,) = [r for r in caplog.records if "kg of inertia" in r.getMessage()]
    assert re.search(r"need 5\.\d+ kg of inertia .* robot's 1 kg", record.getMessage())
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="tensim.model._beads"):
        compile_structure(*_hanging(0.02))
    assert not [r for r in caplog.records if "kg of inertia" in r.getMessage()]


@pytest.mark.parametrize("spacing", [1e-7, 1e-300, 5e-324])
def test_bead_counts_are_bounded_before_anything_is_built(spacing, monkeypatch):
    from tensim.model import _beads

    def never(*args, **kwargs):
        raise AssertionError("a bead was built before the count was checked")

    monkeypatch.setattr(_beads, "add_beads", never)
    with pytest.raises(InputError, match=r"beads: .* more than the limit of 1e\+04"):
        compile_structure(*_hanging(spacing))


@settings(max_examples=40, derandomize=True, database=None, deadline=None)
@given(st.floats(1e-300, 1.0), st.floats(1e-6, 1.0), st.floats(1.0, 1e5),
       st.sampled_from([1e-4, 1e-3, 5e-3]))
def test_any_bead_spacing_compiles_within_the_bounds_or_is_refused(spacing, mass, tension, dt):
    from tensim.limits import MAX_BEADS

    structure, world = _hanging(spacing, dt, tension)
    cable = dataclasses.replace(structure.cables[0], contact=CableContact(spacing, R, mass))
    structure = dataclasses.replace(structure, cables=(cable,))
    try:
        compiled = compile_structure(structure, world)
    except InputError:
        return  # refused before building: test_bead_counts_are_bounded_before_anything_is_built
    m = compiled.model
    beads = compiled.index.bead
    assert 1 <= beads.size <= MAX_BEADS
    # each bead's inertia (mass + armature of a slide joint), all together within ten times
    # the 1 kg load (past that: refused; between once and ten times: a warning)
    inertia = m.body_mass[beads] + m.dof_armature[m.body_dofadr[beads]]
    assert inertia.sum() <= _beads.MAX_INERTIA_SHARE * 1.0 + 1e-9
