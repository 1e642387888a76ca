"""Routed cables (through via nodes): length, tension at every via point, statics, validation.

Every expected number follows from node positions: a span is a straight segment, a frictionless
eyelet carries the same tension on both sides, and a pulley hanging on an elastic cable sits
where both spans make the same angle with the vertical.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from scipy.optimize import brentq

from tensim.model import WorldOptions, compile_structure
from tensim.models import preset
from tensim.sim import Simulation, simulate
from tensim.structure import (
    Cable,
    Motor,
    Node,
    PointMass,
    Structure,
    StructureError,
    load_structure,
    save_structure,
)

G = 9.81


def _eyelet(via_positions, stiffness=200.0, rest=None, pretension=None, offset=0.0, mass=0.5,
            anchors=((-0.4, 0.0, 1.0), (0.4, 0.0, 1.0))):
    """A cable between two fixed anchors, routed through free point-mass nodes."""
    nodes = [Node("a", anchors[0], fixed=True), Node("b", anchors[1], fixed=True)]
    nodes += [Node(f"v{k}", p) for k, p in enumerate(via_positions)]
    via = tuple(f"v{k}" for k in range(len(via_positions)))
    cable = Cable("c", ("a", "b"), stiffness, damping=0.0, rest_length=rest, pretension=pretension,
                  anchor_offset=offset, via=via, motor=Motor(max_tension=1e4))
    masses = tuple(PointMass(v, mass, 0.01) for v in via)
    return Structure("eyelet", tuple(nodes), cables=(cable,), point_masses=masses)


def _spans(points) -> float:
    points = np.asarray(points, dtype=float)
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


@pytest.mark.parametrize("via", [
    [(0.0, 0.0, 0.7)],
    [(-0.1, 0.2, 0.6), (0.25, -0.1, 0.8)],
    [(-0.3, 0.1, 0.5), (0.0, 0.0, 1.4), (0.3, -0.2, 0.5)],
])
@pytest.mark.parametrize("offset", [0.0, 0.02])
def test_length_is_the_sum_of_the_spans(via, offset):
    s = _eyelet(via, pretension=5.0, offset=offset)
    a, b = np.array([-0.4, 0.0, 1.0]), np.array([0.4, 0.0, 1.0])
    first, last = np.asarray(via[0]), np.asarray(via[-1])
    # each anchor sits `offset` from its end node toward the next point of the path
    start = a + offset * (first - a) / np.linalg.norm(first - a)
    end = b + offset * (last - b) / np.linalg.norm(last - b)
    expected = _spans([start, *via, end])
    assert s.cable_length(s.cables[0]) == pytest.approx(expected, rel=1e-14)  # rounding
    assert s.rest_length(s.cables[0]) == pytest.approx(expected - 5.0 / 200.0, rel=1e-14)
    compiled = compile_structure(s, WorldOptions(ground=False))
    data = mujoco.MjData(compiled.model)
    mujoco.mj_forward(compiled.model, data)
    # MuJoCo's tendon through the via sites measures the same path (rounding of the site poses)
    assert data.ten_length[0] == pytest.approx(expected, abs=1e-12)
    assert compiled.model.tendon_num[0] == len(via) + 2  # anchor, a site per via node, anchor


def test_tension_acts_at_each_via_point():
    via = [(-0.15, 0.05, 0.75), (0.2, -0.05, 0.85)]
    k, rest = 300.0, 0.9
    s = _eyelet(via, stiffness=k, rest=rest)
    compiled = compile_structure(s, WorldOptions(ground=False, gravity=(0.0, 0.0, 0.0)))
    path = np.array([(-0.4, 0.0, 1.0), *via, (0.4, 0.0, 1.0)])
    tension = k * (_spans(path) - rest)  # Hooke's law on the whole path; no damping at rest
    with Simulation(compiled, backend="python") as sim:
        assert sim.drive.tension[0] == pytest.approx(tension, rel=1e-12)  # rounding
        for k_via in range(len(via)):
            point = path[k_via + 1]
            back, ahead = path[k_via] - point, path[k_via + 2] - point
            unit_back, unit_ahead = back / np.linalg.norm(back), ahead / np.linalg.norm(ahead)
            expected = tension * (unit_back + unit_ahead)  # both spans pull with the same T
            # magnitude 2 T sin(phi / 2), phi the angle the cable turns by at the via point
            phi = np.pi - np.arccos(unit_back @ unit_ahead)
            assert np.linalg.norm(expected) == pytest.approx(2 * tension * np.sin(phi / 2))
            body = compiled.index.node_body[f"v{k_via}"]
            dof = compiled.model.body_dofadr[body]
            # free joint: the first three dofs are world-frame translations, and the point mass
            # sits at its body's centre, so the tendon's pull there is the force itself
            force = sim.data.qfrc_actuator[dof:dof + 3]
            np.testing.assert_allclose(force, expected, rtol=0, atol=1e-10 * tension)
            np.testing.assert_allclose(sim.data.qfrc_actuator[dof + 3:dof + 6], 0.0, atol=1e-12)


def _pulley_equilibrium(a, b, rest, k, weight):
    """Closed form of an elastic clothesline: the pulley where both spans share an angle."""
    d, rise = b[0] - a[0], a[2] - b[2]

    def excess(length: float) -> float:
        # sin(theta) = d / L; T = W / (2 cos(theta)); L = rest + T / k
        cos_theta = np.sqrt(1.0 - (d / length) ** 2)
        return length - rest - weight / (2.0 * cos_theta * k)

    length = brentq(excess, d * (1 + 1e-12), 10.0, xtol=1e-15)
    sin_t, cos_t = d / length, np.sqrt(1 - (d / length) ** 2)
    first = 0.5 * (length + rise / cos_t)  # L1 + L2 = L, (L1 - L2) cos(theta) = z_a - z_b
    return a + first * np.array([sin_t, 0.0, -cos_t]), k * (length - rest)


def test_pulley_on_an_elastic_cable_settles_at_the_closed_form():
    a, b = np.array([-0.4, 0.0, 1.0]), np.array([0.4, 0.0, 1.2])
    k, rest, mass = 400.0, 1.0, 0.5
    s = _eyelet([(0.1, 0.0, 0.5)], stiffness=k, rest=rest, mass=mass, anchors=(a, b))
    s = dataclasses.replace(s, cables=(dataclasses.replace(s.cables[0], damping=5.0),))
    compiled = compile_structure(s, WorldOptions(ground=False))
    # the eyelet slides freely along the cable (no cable damping acts on that motion): damp the
    # mass's own motion so it settles; damping does not move an equilibrium
    compiled.model.dof_damping[:] = 2.0
    ts = simulate(compiled, 10.0, record_dt=0.1).trajectory
    expected, tension = _pulley_equilibrium(a, b, rest, k, mass * G)
    final = np.array([ts[f"pos_{axis}/v0"][-1] for axis in "xyz"])
    # 10 s is 40 decay times of the 0.25 s damped motion: the transient is far below 1e-9 m
    np.testing.assert_allclose(final, expected, rtol=0, atol=1e-9)
    assert ts["tension/c"][-1] == pytest.approx(tension, abs=1e-6)  # k x 1e-9 m, rounding


def test_cable_spanning_several_segments_runs_stably():
    robot = preset("tetraspine3")
    base = robot.build()
    routed = Cable("spanning", ("s0_tip", "s2_top"), 229.16, damping=20.0, pretension=5.0,
                   via=("s1_top",), motor=Motor(max_speed=0.07, max_tension=50.0),
                   tags=("routed",))
    s = dataclasses.replace(base, cables=(*base.cables, routed))
    compiled = compile_structure(s)
    result = simulate(compiled, 3.0, controller=robot.controller(), record_dt=0.05)
    ts = result.trajectory
    for channel, values in ts.channels.items():
        if not channel.startswith("setpoint/"):
            assert np.all(np.isfinite(values)), channel
    assert np.all(result.peak_tension < compiled.law().max_tension)
    # along the run, the recorded length is the sum of the spans between the node positions
    # rebuilt from the recorded body poses (same geometry, independent path; rounding only)
    body_name = dict(zip(compiled.index.body.tolist(), compiled.index.bodies, strict=True))
    for k in range(0, len(ts.time), 10):
        points = []
        for node in routed.path:
            body = body_name[compiled.index.node_body[node]]
            pos = np.array([ts[f"pos_{a}/{body}"][k] for a in "xyz"])
            rot = np.zeros(9)
            mujoco.mju_quat2Mat(rot, np.array([ts[f"quat_{a}/{body}"][k] for a in "wxyz"]))
            points.append(pos + rot.reshape(3, 3) @ compiled.index.node_local[node])
        assert ts["length/spanning"][k] == pytest.approx(_spans(points), abs=1e-12)


# -- validation and files ---------------------------------------------------------------------


def test_bad_routes_are_refused():
    with pytest.raises(StructureError, match=r"cable 'c'.*unknown node 'nowhere'"):
        Structure(
            "t", (Node("a", (0, 0, 1), fixed=True), Node("b", (1, 0, 1), fixed=True)),
            cables=(Cable("c", ("a", "b"), 10.0, rest_length=1.0, via=("nowhere",)),))
    with pytest.raises(StructureError, match=r"cable 'c'.*'a' follows itself"):
        Cable("c", ("a", "b"), 10.0, rest_length=1.0, via=("a", "v"))
    with pytest.raises(StructureError, match=r"cable 'c'.*single string"):
        Cable("c", ("a", "b"), 10.0, rest_length=1.0, via="v")  # type: ignore[arg-type]
    with pytest.raises(StructureError, match=r"cable 'c'.*zero-length cable span.*'v0' and 'b'"):
        _eyelet([(0.4, 0.0, 1.0)], rest=0.5)  # the via node sits on the anchor
    with pytest.raises(StructureError, match=r"cable 'c'.*anchor_offset"):
        _eyelet([(-0.39, 0.0, 1.0)], rest=0.5, offset=0.05)  # passes the via node


def test_routed_cable_round_trips_through_yaml(tmp_path):
    s = _eyelet([(-0.1, 0.2, 0.6), (0.25, -0.1, 0.8)], pretension=5.0)
    save_structure(s, tmp_path / "routed.yaml")
    back = load_structure(tmp_path / "routed.yaml")
    assert back.cables[0].via == ("v0", "v1")
    assert back == s
    text = (tmp_path / "routed.yaml").read_text().replace("- v1", "- v9")
    (tmp_path / "bad.yaml").write_text(text)
    with pytest.raises(StructureError, match=r"bad\.yaml.*cable 'c'.*unknown node 'v9'"):
        load_structure(tmp_path / "bad.yaml")
