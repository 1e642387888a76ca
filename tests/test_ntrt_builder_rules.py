"""The original toolkit's YAML builder rules that its composite robots rely on.

Every file is written here in the toolkit's format; each expected position, count and length
follows by hand from the builder's rules (``TensegrityModel.cpp``, ``tgStructure``,
``tgRodInfo``/``tgSphereInfo::getConnectionPoint``). Files are read with ``up="z"`` and
``units="m"`` where positions are compared, so a file's numbers are tensim's.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tensim.io import import_ntrt
from tensim.model import compile_structure
from tensim.sim import simulate
from tensim.structure import CableContact, StructureError

UNIT = """\
    nodes:
      hub: [0, 0, 0]
      tip: [10, 0, 0]
      side: [0, 10, 0]
    pair_groups:
      rod:
        - [hub, tip]
        - [hub, side]
    """
HUB, TIP, SIDE = np.array([0.0, 0, 0]), np.array([10.0, 0, 0]), np.array([0.0, 10, 0])


def _write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text))
    return path


def _positions(path: Path) -> dict[str, np.ndarray]:
    s = import_ntrt(path, "m", up="z").structure
    return {n.name: s.position(n.name) for n in s.nodes}


def test_entries_without_path_transform_after_every_child_is_read(tmp_path):
    _write(tmp_path, "parts/unit.yaml", UNIT)
    path = _write(tmp_path, "top.yaml", """\
        substructures:
          b:
            translation: [0, 0, 7]
          a/b:
            path: parts/unit.yaml
            offset: [0, 20, 0]
            translation: [10, 0, 0]
          a:
            rotation: {axis: [0, 0, 1], angle: 90, reference: [0, 0, 0]}
        """)
    got = _positions(path)
    # every rotation first (a: +90 deg about z through the origin), then each entry's scale,
    # offset x index and translation in file order: b += (0, 0, 7); a, b += (10, 0, 0) and
    # b += 1 x (0, 20, 0)
    turned = {"hub": HUB, "tip": np.array([0.0, 10, 0]), "side": np.array([-10.0, 0, 0])}
    expected = {f"a/{n}": p + np.array([10, 0, 0]) for n, p in turned.items()}
    expected |= {f"b/{n}": p + np.array([0, 0, 7]) + np.array([10, 0, 0]) + np.array([0, 20, 0])
                 for n, p in (("hub", HUB), ("tip", TIP), ("side", SIDE))}
    assert got.keys() == expected.keys()
    for name, p in expected.items():
        np.testing.assert_allclose(got[name], p, atol=1e-14)  # rounding of the quarter turn


def test_an_entry_without_path_reaches_a_grandchild(tmp_path):
    _write(tmp_path, "parts/unit.yaml", UNIT)
    _write(tmp_path, "spine.yaml", """\
        substructures:
          v1/v2:
            path: parts/unit.yaml
            offset: [20, 0, 0]
        """)
    path = _write(tmp_path, "top.yaml", """\
        substructures:
          spine:
            path: spine.yaml
          v2:
            translation: [0, 5, 0]
        """)
    got = _positions(path)
    for name, p in (("hub", HUB), ("tip", TIP), ("side", SIDE)):
        np.testing.assert_array_equal(got[f"spine/v1/{name}"], p)
        np.testing.assert_array_equal(got[f"spine/v2/{name}"], p + np.array([20, 5, 0]))


def test_an_entry_without_path_must_name_a_substructure(tmp_path):
    _write(tmp_path, "parts/unit.yaml", UNIT)
    path = _write(tmp_path, "top.yaml", """\
        substructures:
          a:
            path: parts/unit.yaml
          ghost:
            translation: [1, 0, 0]
        """)
    with pytest.raises(StructureError, match=r"top\.yaml: substructures 'ghost': no "
                                             r"substructure 'ghost'"):
        import_ntrt(path, "m")


SQUARE = """\
    nodes:
      a: [0, 0, 0]
      b: [0, 10, 0]
      c: [10, 0, 0]
      d: [10, 10, 0]
    pair_groups:
      rod:
        - [a, b]
        - [c, d]
      string:
        - [a, c]
        - [c, a]
        - [b, d]
    """


def test_a_pair_declared_both_ways_is_built_twice(tmp_path):
    s = import_ntrt(_write(tmp_path, "square.yaml", SQUARE), "cm").structure
    assert [(c.name, c.nodes) for c in s.cables] == [
        ("string_0", ("a", "c")), ("string_1", ("c", "a")), ("string_2", ("b", "d"))]


def test_contact_cable_builders_make_contact_cables(tmp_path):
    contact = SQUARE.rstrip(" ") + """\
    builders:
      string:
        class: tgBasicContactCableInfo
        parameters: {stiffness: 500, pretension: 10}
    """
    result = import_ntrt(_write(tmp_path, "square.yaml", contact), "cm")
    assert all(c.contact == CableContact() for c in result.structure.cables)
    assert any("contact: true" in note and "cable-rod contact is not modelled" in note
               for note in result.notes)
    plain = import_ntrt(_write(tmp_path, "plain.yaml", SQUARE), "cm").structure
    assert all(c.contact is None for c in plain.cables)


def test_a_pair_declared_twice_the_same_way_is_refused(tmp_path):
    twice = SQUARE.replace("- [b, d]\n", "- [b, d]\n        - [b, d]\n")
    path = _write(tmp_path, "square.yaml", twice)
    with pytest.raises(StructureError, match=r"square\.yaml: pair_groups 'string' \[b, d\]: "
                                             r"this pair is already declared"):
        import_ntrt(path, "cm")


# node_edge: a hub whose three tips take the midpoints of a dock's three edges
HUB_PART = """\
    nodes:
      h: {h}
      n1: {n1}
      n2: {n2}
      n3: {n3}
    pair_groups:
      rod:
        - [h, n1]
        - [h, n2]
        - [h, n3]
        - [n3, n1]
      string:
        - [n1, n2]
        - [n2, n3]
    """
MIDPOINTS = np.array([[0.0, 0, 0], [6, 0, 0], [0, 0, 8]])  # the dock's edge midpoints
HALF_EDGE = np.array([0.0, 3, 0])  # each edge runs from midpoint + this to midpoint - this
DOCK = """\
    nodes:
      a1: [0, 3, 0]
      b1: [0, -3, 0]
      a2: [6, 3, 0]
      b2: [6, -3, 0]
      a3: [0, 3, 8]
      b3: [0, -3, 8]
    pair_groups:
      rod:
        - [a1, a2]
        - [a2, a3]
        - [a3, a1]
        - [b1, b2]
        - [b2, b3]
        - [b3, b1]
      string:
        - [a1, b1]
        - [a2, b2]
        - [a3, b3]
    """
BOND = """\
    substructures:
      hub:
        path: hub.yaml
      dock:
        path: dock.yaml
    bond_groups:
      link:
        hub/dock/node_edge:
          - [n1, a1/b1]
          - [n2, a2/b2]
          - [n3, a3/b3]
    builders:
      link:
        class: tgBasicActuatorInfo
    """


@pytest.mark.parametrize("turn", [
    Rotation.from_euler("zy", [90, 40], degrees=True),  # normals at right angles, then a twist
    Rotation.from_euler("xy", [180, 25], degrees=True),  # opposite normals (the fallback turn)
], ids=["tilted", "flipped"])
def test_node_edge_bond_puts_each_edge_midpoint_on_its_node(tmp_path, turn):
    # the hub's tips are the dock's midpoints moved rigidly (turn, then shift): the bond's
    # aligning of normals, centroids and first points can only undo that same motion
    shift = np.array([20.0, 5, -3])
    tips = turn.apply(MIDPOINTS) + shift
    fields = {"h": [float(v) for v in tips.mean(axis=0) + np.array([0, 0, 0.5])]}
    fields |= {f"n{k + 1}": [float(v) for v in tip] for k, tip in enumerate(tips)}
    _write(tmp_path, "hub.yaml", HUB_PART.format(**fields))
    _write(tmp_path, "dock.yaml", DOCK)
    result = import_ntrt(_write(tmp_path, "bond.yaml", BOND), "m", up="z")
    s = result.structure
    got = {n.name: s.position(n.name) for n in s.nodes}
    for k, mid in enumerate(MIDPOINTS, start=1):
        for end, sign in (("a", 1), ("b", -1)):
            expected = turn.apply(mid + sign * HALF_EDGE) + shift
            np.testing.assert_allclose(got[f"dock/{end}{k}"], expected, atol=1e-12)  # 3 turns
        np.testing.assert_allclose(got[f"hub/n{k}"], tips[k - 1], atol=0)  # the hub stays
    # rods all stay (4 + 6); the hub's tip-to-tip strings and the dock's edges are replaced by
    # edge start -> tip -> edge end, with the bond's tag
    assert len(s.rods) == 10
    assert [(c.name, c.nodes) for c in s.cables] == [
        (f"link_{2 * k}", (f"dock/a{k + 1}", f"hub/n{k + 1}")) if half == 0 else
        (f"link_{2 * k + 1}", (f"hub/n{k + 1}", f"dock/b{k + 1}"))
        for k in range(3) for half in (0, 1)]


def test_node_edge_bond_refuses_rod_edges_and_fewer_than_three_entries(tmp_path):
    _write(tmp_path, "hub.yaml", HUB_PART.format(h=[0, 1, 9], n1=[0, 0, 9], n2=[6, 0, 9],
                                                 n3=[0, 0, 17]))
    _write(tmp_path, "dock.yaml", DOCK)
    rod_edge = BOND.replace("[n3, a3/b3]", "[n3, a3/a1]")
    with pytest.raises(StructureError, match=r"rodedge\.yaml: bond_groups 'hub/dock/node_edge' "
                                             r"'link'.*built as a rigid body"):
        import_ntrt(_write(tmp_path, "rodedge.yaml", rod_edge), "m")
    two = BOND.replace("          - [n3, a3/b3]\n", "")
    with pytest.raises(StructureError, match=r"two\.yaml: .*needs at least 3"):
        import_ntrt(_write(tmp_path, "two.yaml", two), "m")
    both = BOND.replace("[n3, a3/b3]", "[n3, a3]")
    with pytest.raises(StructureError, match=r"both\.yaml: .*\[n3, a3\]: expected one node and "
                                             r"one edge"):
        import_ntrt(_write(tmp_path, "both.yaml", both), "m")


SPHERES = """\
    nodes:
      a: [0, 0, 0]
      b: [0, 10, 0]
      ball: [0, 10, 0]
      sphere: [10, 0, 0]
    pair_groups:
      rod:
        - [a, b]
      string:
        - [a, sphere]
    builders:
      ball:
        class: tgSphereInfo
        parameters: {radius: 2, density: 0.5}
      rod:
        class: tgRodInfo
        parameters: {radius: 1, density: 0.01}
    """


def test_spheres_are_built_at_nodes_whose_names_carry_a_sphere_builder_tag(tmp_path):
    result = import_ntrt(_write(tmp_path, "balls.yaml", SPHERES), "cm", clearance=0.01)
    s = result.structure
    masses = {m.node: m for m in s.point_masses}
    # 'ball' coincides with 'b' (merged into b); 'sphere' takes the default sphere builder
    assert sorted(masses) == ["b", "sphere"]
    assert masses["b"].mass == pytest.approx(0.5 * 4 / 3 * math.pi * 2**3, rel=1e-15)  # kg
    assert masses["b"].radius == pytest.approx(0.02)  # 2 cm
    assert masses["sphere"].mass == pytest.approx(4 / 3 * math.pi * 0.5**3, rel=1e-15)
    assert masses["sphere"].radius == pytest.approx(0.005)  # the default 0.5 cm
    rod_mass = 0.01 * math.pi * 1**2 * 10  # kg/cm^3 x cm^2 x cm
    assert s.total_mass() == pytest.approx(rod_mass + masses["b"].mass + masses["sphere"].mass,
                                           rel=1e-12)
    assert sorted(len(g.nodes) for g in s.rigid_groups()) == [1, 2]  # the rod + b; the ball
    # the toolkit anchors at the rod's surface (1 cm across, toward the sphere) and the
    # sphere's (0.5 cm toward a): 8.5 of the 10 cm remain, so 0.75 cm in from each node
    assert s.cables[0].anchor_offset == pytest.approx(0.0075, rel=1e-12)
    # lowest surfaces (Y up: a and 'sphere' at height 0, b 10 cm up): the rod's 1 cm below a,
    # the small sphere's 0.5 cm below, the ball's 8 cm above -> the rod's goes to 1 cm
    assert s.position("a")[2] == pytest.approx(0.02, abs=1e-15)
    assert any("spheres are point masses" in note for note in result.notes)
    run = simulate(compile_structure(s), 0.2, record_dt=0.05)
    assert np.all(np.isfinite(run.trajectory.matrix("tension")))


def test_cable_length_follows_the_toolkits_anchors_on_rod_surfaces(tmp_path):
    text = """\
        nodes:
          a: [0, 0, 0]
          a_top: [0, 10, 0]
          b: [3, -4, 0]
          b_top: [3, -4, 10]
        pair_groups:
          rod:
            - [a, a_top]
            - [b, b_top]
          string:
            - [a, b]
        builders:
          rod:
            class: tgRodInfo
            parameters: {radius: 1}
          string:
            class: tgBasicActuatorInfo
            parameters: {moveCablePointBToEdge: {move_b}}
        """
    # a's rod runs along y: its anchor moves 1 along x (b - a without its y part), to (1, 0, 0)
    # b's rod runs along z: its anchor moves 1 toward a, to (2.4, -3.2, 0); 5 cm between nodes
    for move_b, anchors in (("true", math.sqrt(1.4**2 + 3.2**2)), ("false", math.sqrt(20.0))):
        path = _write(tmp_path, f"oblique_{move_b}.yaml", text.replace("{move_b}", move_b))
        cable = import_ntrt(path, "cm").structure.cables[0]
        assert cable.anchor_offset == pytest.approx((5 - anchors) / 2 / 100, rel=1e-12)


def test_massless_rods_make_a_body_fixed_to_the_world(tmp_path):
    path = _write(tmp_path, "base.yaml", """\
        nodes:
          a: [0, 0, 0]
          b: [0, 10, 0]
          c: [10, 10, 0]
          d: [10, 20, 0]
          e: [20, 20, 0]
        pair_groups:
          base:
            - [a, b]
          rod:
            - [c, d]
          light:
            - [d, e]
          string:
            - [b, c]
        builders:
          base:
            class: tgRodInfo
            parameters: {density: 0}
          light:
            class: tgRodInfo
            parameters: {density: 0}
        """)
    result = import_ntrt(path, "cm")
    s = result.structure
    # a body of massless rods only is static; a massless rod joined to a massive one is not
    assert {n.name for n in s.nodes if n.fixed} == {"a", "b"}
    assert [g.fixed for g in s.rigid_groups()] == [True, False]
    assert any("density 0" in note for note in result.notes)
    run = simulate(compile_structure(s), 0.3, record_dt=0.1)
    fixed, free = (g.name for g in s.rigid_groups())
    for body, moves in ((fixed, False), (free, True)):
        drop = run.trajectory[f"pos_z/{body}"][0] - run.trajectory[f"pos_z/{body}"][-1]
        assert (drop > 1e-3) == moves  # the free body falls under gravity; the fixed one never


def test_the_reader_takes_tabs_and_percent_lines_as_the_toolkits_does(tmp_path):
    text = ("nodes:\n  a:\t[0, 0, 0]\n  b: [0,\t10, 0]\npair_groups:\n  rod:\n    - [a, b]\n"
            "% radius was 3\nbuilders:\n  rod:\n    class: tgRodInfo\n"
            "    parameters: {radius: 3}\n")
    result = import_ntrt(_write(tmp_path, "lenient.yaml", text), "cm")
    s = result.structure
    np.testing.assert_allclose(s.position("b") - s.position("a"), [0, 0, 0.1])  # 10 cm up
    # yaml-cpp ends the document at the '%' line: the builder after it is never read, so the
    # default rod builder (radius 0.5 cm) builds the rod
    assert s.rods[0].radius == pytest.approx(0.005)
    assert any("lenient.yaml line 7 starts with '%'" in note for note in result.notes)
    with pytest.raises(StructureError, match=r"indented\.yaml: not valid YAML"):
        import_ntrt(_write(tmp_path, "indented.yaml", text.replace("  a:", "\ta:")), "cm")
    directive = "%YAML 1.1\n---\n" + text.split("%")[0]
    assert len(import_ntrt(_write(tmp_path, "directive.yaml", directive), "cm").notes) == 0


def test_light_bodies_on_strong_dampers_get_a_step_note(tmp_path):
    text = """\
        nodes:
          a: [0, 0, 0]
          b: [0, 10, 0]
          c: [10, 0, 0]
          d: [10, 20, 0]
        pair_groups:
          rod:
            - [a, b]
            - [c, d]
          string:
            - [a, c]
            - [b, d]
            - [a, d]
        builders:
          rod:
            class: tgRodInfo
            parameters: {radius: 0.5, density: 0.005}
          string:
            class: tgBasicActuatorInfo
            parameters: {damping: {b}}
        """
    # the lighter rod: 0.005 kg/cm^3 x pi 0.25 cm^2 x 10 cm; all three cables touch each rod
    light = 0.005 * math.pi * 0.25 * 10
    for damping, noted in ((50, True), (1, False)):
        path = _write(tmp_path, f"damped_{damping}.yaml", text.replace("{b}", str(damping)))
        result = import_ntrt(path, "cm")
        assert result.max_step == pytest.approx(2 * light / (3 * damping), rel=1e-12)
        # 2 m / b = 0.52 ms at 50 N s/m: below tensim's 1 ms step; 26 ms at 1 N s/m
        assert any("--dt 0.0005 or less" in n for n in result.notes) == noted
