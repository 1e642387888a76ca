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
    """An n-strut tensegrity prism (3-bar, 4-bar, ...) as a structure file's mapping.

    Bottom and top rings of radius 0.2 m, 0.3 m apart; strut i runs from b_i to t_i, twisted by
    90 + 180/n degrees (the regular prism's equilibrium twist); vertical cable i from b_i to
    t_(i-1). Pretensions from the self-stress: ring force density 40 N/m, and node b_0's
    balance gives the verticals' (vertically q_v h = q_s h, so vertical and strut densities are
    equal; horizontally the rings' pull toward the centre is met by the vertical and strut).
    """
    twist = math.pi / 2 + math.pi / n
    bottom = [np.array([0.2 * math.cos(2 * math.pi * i / n), 0.2 * math.sin(2 * math.pi * i / n),
                        0.02]) for i in range(n)]
    top = [np.array([0.2 * math.cos(2 * math.pi * i / n + twist),
                     0.2 * math.sin(2 * math.pi * i / n + twist), 0.32]) for i in range(n)]
    ring = 40.0  # N/m
    pull = ring * (bottom[1] + bottom[-1] - 2 * bottom[0])[:2]
    across = (top[-1] - top[0])[:2]  # vertical minus strut direction, per unit density
    vertical = float(-(pull @ across) / (across @ across))
    nodes, rods, cables = [], [], []
    for ring_name, points, tag in (("b", bottom, "bottom"), ("t", top, "top")):
        for i, point in enumerate(points):
            nodes.append({"name": f"{ring_name}{i}", "position": [float(x) for x in point],
                          "tags": [tag], "fixed": fixed_bottom and ring_name == "b"})
    for i in range(n):
        rods.append({"name": f"rod_{i}", "nodes": [f"b{i}", f"t{i}"]})
        for ring_name, points, tag in (("b", bottom, "bottom"), ("t", top, "top")):
            length = float(np.linalg.norm(points[(i + 1) % n] - points[i]))
            cables.append({"name": f"{tag}_{i}", "nodes": [f"{ring_name}{i}",
                                                          f"{ring_name}{(i + 1) % n}"],
                           "pretension": ring * length, "tags": [tag]})
        length = float(np.linalg.norm(top[i - 1] - bottom[i]))
        cables.append({"name": f"vertical_{i}", "nodes": [f"b{i}", f"t{(i - 1) % n}"],
                       "pretension": vertical * length, "tags": ["vertical"]})
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
    # ring chord of a square of radius 0.2 m: L = 0.2 sqrt(2); T = 40 N/m x L; rest = L - T/k
    chord = 0.2 * math.sqrt(2)
    assert bottom["build_length_m"] == pytest.approx(chord, abs=1e-6)
    assert bottom["rest_length_m"] == pytest.approx(chord - 40 * chord / 1000.0, abs=1e-6)
    assert bottom["pretension_N"] == pytest.approx(40 * chord, abs=1e-5)
    assert len(info["rigid_bodies"]) == 4
    body = info["rigid_bodies"][0]
    rod_length = info["rods"][0]["length_m"]
    # one strut (0.2 kg/m) and its two 0.05 kg end masses
    assert body["mass_kg"] == pytest.approx(0.2 * rod_length + 0.1, abs=1e-6)  # rounded to µg
    assert body["com_m"][2] == pytest.approx(0.17, abs=1e-6)  # halfway up, by symmetry


# -- controller files that hold the build pose -------------------------------------------------


def _node_paths(compiled, series) -> dict[str, np.ndarray]:
    """(n_samples, 3) world position of every node on a recorded body [m]."""
    import mujoco
    from scipy.spatial.transform import Rotation

    paths = {}
    for node, body in compiled.index.node_body.items():
        name = mujoco.mj_id2name(compiled.model, mujoco.mjtObj.mjOBJ_BODY, body)
        if f"pos_x/{name}" not in series.channels:
            continue  # a node fixed to the world
        pos = np.stack([series[f"pos_{a}/{name}"] for a in "xyz"], axis=1)
        quat = np.stack([series[f"quat_{a}/{name}"] for a in "xyzw"], axis=1)
        paths[node] = pos + Rotation.from_quat(quat).apply(compiled.index.node_local[node])
    return paths


@pytest.mark.parametrize("n", [3, 4])
def test_controller_init_file_holds_the_build_pose(n, tmp_path):
    """The file ``tensim controller init`` writes keeps a self-stressed prism in its build
    pose: strut 0 fixed, no gravity, 5 s; every node stays within 0.1 mm (the law's T_set
    equals each cable's build tension there, so only the file's rounding to µm moves it:
    ~10 µm). Off by 1 cm in L*, or with T0 = 0, the nodes move 3-17 mm."""
    import yaml as pyyaml

    from tensim.cli import main
    from tensim.control import load_controller

    data = prism(n)
    data["nodes"][0]["fixed"] = True
    for node in data["nodes"]:  # lifted clear of the ground
        node["position"][2] += 0.5
    path = tmp_path / "prism.yaml"
    path.write_text(pyyaml.safe_dump(data))
    assert main(["controller", "init", str(path), "--out", str(tmp_path / "hold.yaml")]) == 0
    structure = structure_from_dict(data)
    config = load_controller(tmp_path / "hold.yaml", structure)
    assert config.impedance == default_impedance(structure)
    compiled = compile_structure(structure, WorldOptions(timestep=1e-3, gravity=(0, 0, 0)))
    result = simulate(compiled, 5.0, controller=config.build(1e-3), record_dt=0.05)
    paths = _node_paths(compiled, result.trajectory)
    assert len(paths) == 2 * n
    for node, path in paths.items():
        assert np.linalg.norm(path - path[0], axis=1).max() < 1e-4, node


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


def spine(segments: int) -> dict:
    """A spine of tetrahedral segments 0.25 m apart (segment 0 in front, toward +x): each has
    left, right and top corners and a tip toward the segment in front; joint j joins segment
    j - 1 and j with three outer cables (corner to corner) and three inner ones (corner of j - 1
    to the tip of j), tagged ``joint_<j>`` and named ``<kind>_<j>``."""
    nodes, rods, cables = [], [], []
    corners = {"left": (0.0, 0.15, 0.02), "right": (0.0, -0.15, 0.02), "top": (0.0, 0.0, 0.28)}
    for s in range(segments):
        x = -0.25 * s
        for name, (cx, cy, cz) in corners.items():
            nodes.append({"name": f"s{s}_{name}", "position": [x + cx, cy, cz]})
        nodes.append({"name": f"s{s}_tip", "position": [x + 0.2, 0.0, 0.1]})
        for a, b in (("left", "right"), ("right", "top"), ("top", "left"), ("left", "tip"),
                     ("right", "tip"), ("top", "tip")):
            rods.append({"name": f"s{s}_{a}_{b}", "nodes": [f"s{s}_{a}", f"s{s}_{b}"]})
    for j in range(1, segments):
        for side in corners:
            cables.append({"name": f"outer_{side}_{j}", "nodes": [f"s{j - 1}_{side}",
                                                                 f"s{j}_{side}"],
                           "pretension": 5.0, "tags": [f"joint_{j}", "outer", side]})
            cables.append({"name": f"inner_{side}_{j}", "nodes": [f"s{j - 1}_{side}",
                                                                 f"s{j}_tip"],
                           "pretension": 5.0, "tags": [f"joint_{j}", "inner", side]})
    return {"name": f"spine_{segments}", "defaults": {
                "rod": {"radius": 0.005, "linear_density": 0.3},
                "cable": {"stiffness": 300.0, "damping": 10.0, "motor": MOTOR}},
            "nodes": nodes, "rods": rods, "cables": cables}


# -- the CPG coupling rule ------------------------------------------------------------------------


def test_tetraspine3_couplings_and_its_57_classes_by_hand():
    """Tetraspine3: 6 cables per joint, 2 joints. Cables of one joint share both its segments
    (6 x 5 directed couplings per joint); cables of joints 1 and 2 share segment 1 (6 x 6 each
    way): 30 + 30 + 72 = 132 couplings. Classes: 6 kinds, so C(6, 2) = 15 at offset 0 and
    6 x 7 / 2 = 21 at each of offsets +1 and -1: 57, i.e. 2 x 57 + 2 = 116 parameters."""
    from tensim.control import spine_parameters
    from tensim.models import preset

    layout = spine_parameters(preset("tetraspine3").build())
    assert len(layout.edges) == 132
    assert len(layout.classes) == 57
    assert sum(c.startswith("0/") for c in layout.classes) == 15
    assert sum(c.startswith("+1/") for c in layout.classes) == 21
    assert layout.size == 116


def test_four_segment_spine_couplings_by_hand():
    """Three joints of 6 cables: 3 x 30 within joints + 2 neighbour pairs x 72 = 234 couplings
    (joints 1 and 3 share no segment); the classes are those of any spine of 3+ segments: 57."""
    from tensim.control import spine_parameters

    layout = spine_parameters(structure_from_dict(spine(4)))
    assert len(layout.edges) == 234
    assert len(layout.classes) == 57


def test_prism_couplings_by_hand_and_symmetry_groups_from_tags():
    """3-bar: every cable touches 2 of the 3 struts, so any two cables share one: 9 x 8 = 72
    couplings; untagged, each unordered pair is a class: 36 (74 parameters). 4-bar: cable sets
    {i, i+1} of struts, three cables per i; a cable shares a strut with the other 2 of its i
    and the 6 of i +- 1, not the 3 of i + 2: 12 x 8 = 96 couplings, 48 pairs. With kind tags
    (bottom, top, vertical) the 3-bar's classes are the 6 unordered kind pairs."""
    from tensim.control import spine_parameters

    layout = spine_parameters(structure_from_dict(prism(3)))
    assert (len(layout.edges), len(layout.classes), layout.size) == (72, 36, 74)
    layout = spine_parameters(structure_from_dict(prism(4)))
    assert (len(layout.edges), len(layout.classes)) == (96, 48)
    tagged = prism(3)
    for cable in tagged["cables"]:
        cable["tags"] = [*cable["tags"], f"kind_{cable['name'].split('_')[0]}"]
    layout = spine_parameters(structure_from_dict(tagged))
    assert sorted(layout.classes) == sorted(
        f"0/{a}|{b}" for a, b in (("bottom", "bottom"), ("top", "top"), ("vertical", "vertical"),
                                  ("bottom", "top"), ("bottom", "vertical"),
                                  ("top", "vertical")))
    network = layout.network()
    assert len(network.couplings) == 72


# -- travelling waves -----------------------------------------------------------------------------


def test_travelling_wave_follows_the_tagged_order():
    """wave_<k> tags set the order: the cable of tag k runs k lags behind the first."""
    from tensim.control.wave import travelling_wave_parameters

    data = prism(3)
    order = ["vertical_2", "top_0", "bottom_1"]
    for k, name in enumerate(order):
        next(c for c in data["cables"] if c["name"] == name)["tags"].append(f"wave_{k}")
    structure = structure_from_dict(data)
    layout = travelling_wave_parameters(structure, ["bottom_1", "top_0", "vertical_2"],
                                        order="tags")
    assert layout.order == tuple(order)
    gait = layout.gait([0.01, 0.5, 0.3])
    assert gait.phase == pytest.approx((0.0, -0.3, -0.6))
    assert gait.amplitude == (0.01, 0.01, 0.01)


def test_travelling_wave_order_along_a_spine_runs_front_to_back():
    from tensim.control.wave import wave_order

    structure = structure_from_dict(spine(4))
    outer_top = [f"outer_top_{j}" for j in (3, 1, 2)]
    assert wave_order(structure, outer_top) == ("outer_top_1", "outer_top_2", "outer_top_3")


# -- passive cables and controllers ---------------------------------------------------------------


def test_passive_cables_get_no_laws_and_a_file_may_not_drive_them():
    from tensim.control import ControllerFileError
    from tensim.control.files import controller_from_dict

    data = prism(3, motors=False)
    data["cables"][0]["motor"] = MOTOR
    structure = structure_from_dict(data)
    assert list(default_impedance(structure).gains) == ["bottom_0"]
    gains = {"offset_tension": 1, "stiffness_gain": 1, "damping_gain": 1, "target_length": 0.3}
    with pytest.raises(ControllerFileError, match="no motor"):
        controller_from_dict({"format": "tensim-controller", "version": 1,
                              "impedance": {"cables": {"top_0": gains}}}, structure)
    with pytest.raises(ValueError, match="no motorised cable"):
        default_impedance(structure_from_dict(prism(3, motors=False)))


# -- the command line on a robot tensim does not ship ---------------------------------------------


def test_cli_end_to_end_on_a_new_robot(tmp_path, capsys):
    """info, controller init, a pushed simulation, the disturbance and drag experiments and
    learning with each gait family, from the command line alone (tiny budgets)."""
    import json

    import yaml as pyyaml

    from tensim.cli import main

    robot = tmp_path / "prism4.yaml"
    robot.write_text(pyyaml.safe_dump(prism(4)))
    assert main(["info", str(robot), "--json", str(tmp_path / "info.json")]) == 0
    info = json.loads((tmp_path / "info.json").read_text())
    assert len(info["motorised_cables"]) == 12 and info["cables"][0]["motor_source"] == "defaults"
    assert "vertical_3" in capsys.readouterr().out

    controller = tmp_path / "hold.yaml"
    assert main(["controller", "init", str(robot), "--out", str(controller)]) == 0
    run = tmp_path / "push"
    assert main(["--quiet", "simulate", str(robot), "--controller", str(controller),
                 "--duration", "1", "--load", "t0:2,0,0@0.2-0.8", "--out", str(run)]) == 0
    summary = json.loads((run / "summary.json").read_text())
    assert summary["loads"][0]["node"] == "t0" and (run / "loads.yaml").is_file()
    assert summary["motors"]["top_0"] == "kinematic 0.1 m/s, 500 N"
    assert summary["gains"]["top_0"]["target_length_m"] == pytest.approx(0.2 * math.sqrt(2),
                                                                         abs=1e-6)
    again = tmp_path / "again"  # the run folder's loads.yaml replays the push
    assert main(["--quiet", "simulate", str(robot), "--controller", str(controller),
                 "--duration", "1", "--loads", str(run / "loads.yaml"), "--out", str(again)]) == 0
    assert json.loads((again / "summary.json").read_text())["max_tension_N"] == \
        summary["max_tension_N"]
    assert main(["render", str(run), "--out", str(tmp_path / "v.mp4"), "--load",
                 "t0:1,0,0@0-1"]) == 2
    capsys.readouterr()

    out = tmp_path / "dist"
    assert main(["--quiet", "experiment", "disturbance", "--robot", str(robot), "--push", "t0",
                 "--hold", "b0,b1", "--duration", "1", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["model"] == str(robot)
    assert summary["push"]["holds"] == {"b0": 0.5, "b1": 0.5}
    assert "before the push starts at 30 s" in capsys.readouterr().err
    assert main(["--quiet", "experiment", "disturbance", "--robot", str(robot), "--duration",
                 "1", "--out", str(tmp_path / "bad")]) == 2
    assert "s0_tip" in capsys.readouterr().err and not (tmp_path / "bad").exists()
    out = tmp_path / "drag"
    assert main(["--quiet", "experiment", "drag", "--robot", str(robot), "--tow", "t0",
                 "--duration", "6.2", "--out", str(out)]) == 0
    assert json.loads((out / "summary.json").read_text())["model"] == str(robot)

    for family in ("cpg", "sine", "wave"):
        out = tmp_path / f"learn_{family}"
        assert main(["--quiet", "learn", "--model", str(robot), "--controller", family,
                     "--evaluations", "2", "--monte-carlo", "1", "--workers", "1",
                     "--trial-duration", "0.3", "--out", str(out)]) == 0, family
        assert (out / "best_controller.yaml").is_file()


def test_cli_learn_on_a_robot_without_motors_says_what_it_needs(tmp_path, capsys):
    import yaml as pyyaml

    from tensim.cli import main

    robot = tmp_path / "passive.yaml"
    robot.write_text(pyyaml.safe_dump(prism(3, motors=False)))
    assert main(["--quiet", "learn", "--model", str(robot), "--controller", "cpg",
                 "--evaluations", "2", "--out", str(tmp_path / "l")]) == 2
    assert "no motorised cable" in capsys.readouterr().err


@pytest.mark.parametrize("robot", ["prism3", "spine4"])
def test_cli_inspects_controls_and_learns_on_other_robots(robot, tmp_path, capsys):
    """The 3-bar and a 4-segment spine: info, controller init and a gait of each family."""
    import json

    import yaml as pyyaml

    from tensim.cli import main

    data = prism(3) if robot == "prism3" else spine(4)
    path = tmp_path / f"{robot}.yaml"
    path.write_text(pyyaml.safe_dump(data))
    assert main(["info", str(path), "--json", str(tmp_path / "info.json")]) == 0
    info = json.loads((tmp_path / "info.json").read_text())
    assert len(info["cables"]) == len(data["cables"])
    assert main(["controller", "init", str(path), "--out", str(tmp_path / "c.yaml")]) == 0
    capsys.readouterr()
    for family in ("cpg", "sine", "wave"):
        out = tmp_path / family
        assert main(["--quiet", "learn", "--model", str(path), "--controller", family,
                     "--evaluations", "1", "--monte-carlo", "1", "--workers", "1",
                     "--trial-duration", "0.2", "--base-controller", str(tmp_path / "c.yaml"),
                     "--out", str(out)]) == 0, family
        summary = json.loads((out / "summary.json").read_text())
        assert summary["evaluations"] == 1
