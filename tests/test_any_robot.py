"""Any tensegrity robot: inspection, controller files that hold the build pose, loads,
experiments and gait families on structures tensim does not ship (written inline here)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tensim.control import default_impedance
from tensim.inspect import structure_info
from tensim.model import WorldOptions, compile_structure
from tensim.sim import simulate
from tensim.structure import structure_from_dict

MOTOR = {"max_speed": 0.1, "max_tension": 500.0}


def prism(n: int, motors: bool = True, fixed_bottom: bool = False) -> dict:
    """An n-strut tensegrity prism (3-bar, 4-bar, ...) as a structure file's mapping: bottom
    and top rings of radius 0.2 m, struts twisted by 90 + 180/n degrees, 3n cables."""
    twist = math.pi / 2 + math.pi / n
    nodes, rods, cables = [], [], []
    for i in range(n):
        a = 2 * math.pi * i / n
        nodes.append({"name": f"b{i}", "position": [0.2 * math.cos(a), 0.2 * math.sin(a), 0.02],
                      "tags": ["bottom"], "fixed": fixed_bottom})
    for i in range(n):
        a = 2 * math.pi * i / n + twist
        nodes.append({"name": f"t{i}", "position": [0.2 * math.cos(a), 0.2 * math.sin(a), 0.32],
                      "tags": ["top"]})
    for i in range(n):
        rods.append({"name": f"rod_{i}", "nodes": [f"b{i}", f"t{i}"]})
        for ring in "bt":
            cables.append({"name": f"{'bottom' if ring == 'b' else 'top'}_{i}",
                           "nodes": [f"{ring}{i}", f"{ring}{(i + 1) % n}"],
                           "pretension": 10.0, "tags": ["bottom" if ring == "b" else "top"]})
        cables.append({"name": f"vertical_{i}", "nodes": [f"b{i}", f"t{(i + 1) % n}"],
                       "pretension": 15.0, "tags": ["vertical"]})
    cable_default: dict = {"stiffness": 1000.0, "damping": 5.0}
    if motors:
        cable_default["motor"] = MOTOR
    return {"name": f"prism_{n}", "defaults": {
                "rod": {"radius": 0.01, "linear_density": 0.2},
                "cable": cable_default, "point_mass": {"radius": 0.015}},
            "nodes": nodes, "rods": rods, "cables": cables,
            "point_masses": [{"node": n_["name"], "mass": 0.05} for n_ in nodes]}


# -- inspection and the motor default -------------------------------------------------------------


def test_cable_without_motor_in_a_file_is_passive_and_info_says_where_motors_come_from():
    data = prism(3, motors=False)
    data["cables"][0]["motor"] = MOTOR
    structure = structure_from_dict(data)
    assert not structure.cables[0].motor.passive
    assert all(c.motor.passive for c in structure.cables[1:])
    from tensim.structure import motor_sources
    info = structure_info(structure, motor_sources=motor_sources(data))
    assert info["motorised_cables"] == ["bottom_0"]
    assert info["cables"][0]["motor_source"] == "cable"
    assert info["cables"][1]["motor"] is None and info["cables"][1]["motor_source"] == "none"
    assert motor_sources(prism(3))["top_2"] == "defaults"


def test_info_lengths_and_bodies_by_hand():
    structure = structure_from_dict(prism(4))
    info = structure_info(structure)
    bottom = info["cables"][0]
    # ring chord of a square of radius 0.2 m: 0.2 sqrt(2); rest = build - T/k
    assert bottom["build_length_m"] == pytest.approx(0.2 * math.sqrt(2), abs=1e-6)
    assert bottom["rest_length_m"] == pytest.approx(0.2 * math.sqrt(2) - 10.0 / 1000.0,
                                                    abs=1e-6)
    assert bottom["pretension_N"] == pytest.approx(10.0, abs=1e-5)
    assert len(info["rigid_bodies"]) == 4
    body = info["rigid_bodies"][0]
    rod_length = info["rods"][0]["length_m"]
    # one strut (0.2 kg/m) and its two 0.05 kg end masses
    assert body["mass_kg"] == pytest.approx(0.2 * rod_length + 0.1, abs=1e-6)  # rounded to µg
    assert body["com_m"][2] == pytest.approx(0.17, abs=1e-6)  # halfway up, by symmetry


# -- controller files that hold the build pose -------------------------------------------------


def test_default_impedance_holds_the_build_pose():
    """With the bottom ring fixed, the default laws keep every node within 3 mm over 5 s.

    Tolerance: gravity on the free top (0.33 kg) is taken by three verticals whose law adds
    K = k = 1000 N/m to the cable's own stiffness, a sag of ~1 mm; 3 mm leaves room for the
    cable damping's transient. A node moves at most |Δ body position| + angle x 0.35 m (no
    node is further than a strut length, 0.35 m, from its body's origin).
    """
    structure = structure_from_dict(prism(3, fixed_bottom=True))
    impedance = default_impedance(structure)
    compiled = compile_structure(structure, WorldOptions(timestep=1e-3))
    result = simulate(compiled, 5.0, controller=impedance, record_dt=0.05)
    series = result.trajectory
    for body in series.items("pos_x"):
        if body == "com":
            continue
        pos = np.stack([series[f"pos_{a}/{body}"] for a in "xyz"], axis=1)
        quat = np.stack([series[f"quat_{a}/{body}"] for a in "wxyz"], axis=1)
        angle = 2 * np.arccos(np.clip(np.abs(quat @ quat[0]), 0.0, 1.0))
        moved = np.linalg.norm(pos - pos[0], axis=1) + angle * 0.35
        assert moved.max() < 3e-3, body


# -- loads ----------------------------------------------------------------------------------------


def test_push_on_a_hanging_mass_stretches_its_cable_by_f_over_k():
    """A 1 kg node hangs from a fixed node on a passive cable of k = 1000 N/m; a 5 N downward
    push lowers it by F/k = 5 mm (static: the cable is taut before and during the push)."""
    data = {"name": "hanging", "nodes": [
                {"name": "top", "position": [0, 0, 1.0], "fixed": True},
                {"name": "mass", "position": [0, 0, 0.5]}],
            "point_masses": [{"node": "mass", "mass": 1.0, "radius": 0.01}],
            "cables": [{"name": "spring", "nodes": ["top", "mass"], "stiffness": 1000.0,
                        "damping": 40.0, "pretension": 9.81}]}
    from tensim.loads import parse_push

    structure = structure_from_dict(data)
    compiled = compile_structure(structure, WorldOptions(timestep=1e-3))
    result = simulate(compiled, 4.0, loads=[parse_push("mass:0,0,-5@2-4/0.2")], record_dt=0.01)
    series = result.trajectory
    z = series["pos_z/mass"]
    before = z[(series.time > 1.5) & (series.time < 2.0)].mean()
    during = z[(series.time > 3.3) & (series.time < 3.7)].mean()  # ramps end at 2.2, start 3.8
    # settled to 0.1 % of the 5 mm: ζ = 40 / (2 sqrt(1000)) = 0.63, e^-ζω t over 1.1 s < 1e-8
    assert before - during == pytest.approx(5.0 / 1000.0, rel=1e-3)


def test_load_strings_and_files_round_trip(tmp_path):
    from tensim.loads import LoadError, load_loads, parse_push, save_loads

    load = parse_push("t0:5,0,-1.5@1-3")
    assert load.node == "t0"
    assert load.times.tolist() == [1.0, 1.1, 2.9, 3.0]
    assert load.force_at(2.0).tolist() == [5.0, 0.0, -1.5]
    back = load_loads(save_loads([load], tmp_path / "loads.yaml"))[0]
    assert back.times.tolist() == load.times.tolist()
    assert back.forces.tolist() == load.forces.tolist()
    for bad in ("t0:5,0@1-3", "t0:5,0,0@3-1", "t0:5,0,0@1-1.1"):
        with pytest.raises(LoadError):
            parse_push(bad)
