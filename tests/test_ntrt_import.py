"""Import of the original toolkit's (NTRTsim's) YAML structure files.

The example files are written here, in the toolkit's format; the expected nodes, rods and
cables follow by hand from its rules: Y up, lengths in file units, a substructure turned about
its centroid (or a given point), then scaled about its centroid, offset by index, translated.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
import pytest

from tensim.cli import main
from tensim.io import import_ntrt
from tensim.model import compile_structure
from tensim.sim import simulate
from tensim.structure import StructureError, load_structure

TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # (x, y, z) -> (x, -z, y)


def _write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text))
    return path


def _si(ntrt_cm) -> np.ndarray:
    """A toolkit position in centimetres, Y up, as tensim's metres, Z up."""
    return TO_Z_UP @ (np.asarray(ntrt_cm, dtype=float) / 100.0)


SIMPLE = """\
    nodes:
      a: [0, 0, 0]
      b: [0, 30, 0]
      c: [20, 0, 0]
      d: [20, 30, 10]
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
        parameters: {density: 0.002, radius: 0.5, friction: 0.8, restitution: 0.1}
      string:
        class: tgBasicActuatorInfo
        parameters: {stiffness: 500, damping: 5, pretension: 200, max_tension: 5000,
                     target_velocity: 20}
    """


def test_nodes_rods_and_cables_of_a_plain_file(tmp_path):
    path = _write(tmp_path, "simple.yaml", SIMPLE)
    s = import_ntrt(path, "cm").structure
    positions = {"a": (0, 0, 0), "b": (0, 30, 0), "c": (20, 0, 0), "d": (20, 30, 10)}
    assert [n.name for n in s.nodes] == list(positions)
    for name, p in positions.items():
        np.testing.assert_allclose(s.position(name), _si(p), atol=1e-15)  # rounding of /100
    np.testing.assert_allclose(s.position("d"), [0.2, -0.1, 0.3], atol=1e-15)  # Z up, by hand
    assert [(r.name, r.nodes) for r in s.rods] == [("rod_0", ("a", "b")), ("rod_1", ("c", "d"))]
    rod = s.rods[0]
    assert rod.radius == pytest.approx(0.005)  # 0.5 cm
    assert rod.density == pytest.approx(2000.0)  # 0.002 kg/cm^3 = 2000 kg/m^3
    assert (rod.friction, rod.restitution) == (0.8, 0.1)
    assert [(c.name, c.nodes) for c in s.cables] == [
        ("string_0", ("a", "c")), ("string_1", ("b", "d")), ("string_2", ("a", "d"))]
    cable = s.cables[0]
    assert (cable.stiffness, cable.damping) == (500.0, 5.0)  # kg/s^2 and kg/s: unit-free
    assert cable.pretension == pytest.approx(2.0)  # 200 kg cm/s^2 = 2 N
    assert cable.motor.max_tension == pytest.approx(50.0)  # 5000 kg cm/s^2
    assert cable.motor.max_speed == pytest.approx(0.2)  # 20 cm/s
    assert cable.motor.min_rest_length == pytest.approx(0.001)  # the toolkit's default 0.1 cm
    assert cable.anchor_offset == pytest.approx(0.005)  # moved onto the rod surface
    # mass: density x pi r^2 x (30 cm + |cd| = sqrt(30^2 + 10^2) cm)
    length = 0.3 + math.hypot(0.3, 0.1)
    assert s.total_mass() == pytest.approx(2000.0 * math.pi * 0.005**2 * length, rel=1e-12)
    assert len(s.rigid_groups()) == 2


def test_units_scale_lengths_and_forces_but_not_mass_or_stiffness(tmp_path):
    path = _write(tmp_path, "simple.yaml", SIMPLE)
    cm, m = import_ntrt(path, "cm").structure, import_ntrt(path, "m").structure
    np.testing.assert_allclose(m.position("d"), 100.0 * cm.position("d"), rtol=1e-14)
    # mass = rho/s^3 x pi (r s)^2 x (L s): the same kilograms whatever the unit
    assert m.total_mass() == pytest.approx(cm.total_mass(), rel=1e-12)
    assert m.cables[0].stiffness == cm.cables[0].stiffness
    assert m.cables[0].pretension == pytest.approx(100.0 * cm.cables[0].pretension)
    dm = import_ntrt(path, "dm", up="z").structure
    np.testing.assert_allclose(dm.position("d"), [2.0, 3.0, 1.0], rtol=1e-14)  # no turn


PART = """\
    nodes:
      hub: [0, 0, 0]
      tip: [10, 0, 0]
      side: [0, 10, 0]
    pair_groups:
      rod:
        - [hub, tip]
        - [hub, side]
    """

ASSEMBLY = """\
    substructures:
      first/second:
        path: parts/unit.yaml
        rotation: {axis: [0, 0, 1], angle: 90}
        offset: [0, 0, 30]
        translation: [5, 0, 0]
      third:
        path: parts/unit.yaml
        rotation: {axis: [1, 0, 0], angle: 180, reference: [0, 0, 0]}
        scale: 2
    bond_groups:
      string:
        first/second/node_node:
          - [tip, tip]
          - [side, hub]
      second/third/node_node:
        link:
          - [tip, side]
    builders:
      string:
        class: tgBasicActuatorInfo
        parameters: {stiffness: 100, pretension: 10}
      link:
        class: tgBasicActuatorInfo
        parameters: {stiffness: 200}
    """


def _expected_assembly() -> dict[str, np.ndarray]:
    """The assembly's nodes in the file's frame [cm], by the toolkit's rules, by hand."""
    part = {"hub": np.array([0.0, 0, 0]), "tip": np.array([10.0, 0, 0]),
            "side": np.array([0.0, 10, 0])}
    quarter_z = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])  # +90 deg about z
    half_x = np.diag([1.0, -1, -1])  # 180 deg about x
    centroid = sum(part.values()) / 3
    out = {}
    for index, name in enumerate(("first", "second")):
        for node, p in part.items():  # about the centroid, then offset x index, translation
            out[f"{name}/{node}"] = (centroid + quarter_z @ (p - centroid)
                                     + index * np.array([0, 0, 30.0]) + [5.0, 0, 0])
    turned = {node: half_x @ p for node, p in part.items()}  # about the given origin
    centre = sum(turned.values()) / 3
    for node, p in turned.items():  # then doubled about its (new) centroid
        out[f"third/{node}"] = centre + 2.0 * (p - centre)
    return out


def test_substructures_transforms_and_bonds(tmp_path):
    _write(tmp_path, "parts/unit.yaml", PART)
    path = _write(tmp_path, "assembly.yaml", ASSEMBLY)
    result = import_ntrt(path, "cm")
    s = result.structure
    assert [Path(f).name for f in result.files] == ["assembly.yaml", "unit.yaml", "unit.yaml",
                                                    "unit.yaml"]
    expected = _expected_assembly()
    assert sorted(n.name for n in s.nodes) == sorted(expected)
    for name, p in expected.items():
        np.testing.assert_allclose(s.position(name), _si(p), atol=1e-14)  # rounding of turns
    # each substructure's two rods (the default rod builder) are one rigid body named after it
    assert sorted(r.name for r in s.rods) == sorted(
        f"{part}/rod_{k}" for part in ("first", "second", "third") for k in (0, 1))
    assert sorted(g.name for g in s.rigid_groups()) == ["first", "second", "third"]
    assert s.rods[0].radius == pytest.approx(0.005)  # the toolkit's default 0.5 cm
    # bonds: the pairs between substructures, with their names as extra tags
    cables = {c.name: c for c in s.cables}
    assert set(cables) == {"string_0", "string_1", "link_0"}
    assert cables["string_0"].nodes == ("first/tip", "second/tip")
    assert cables["string_1"].nodes == ("first/side", "second/hub")
    assert cables["link_0"].nodes == ("second/tip", "third/side")
    assert set(cables["string_0"].tags) >= {"string", "first", "second", "first/second"}
    assert cables["string_0"].stiffness == 100.0 and cables["link_0"].stiffness == 200.0
    assert cables["string_0"].pretension == pytest.approx(0.1)  # 10 kg cm/s^2
    assert cables["link_0"].pretension == 0.0  # the toolkit's default


def test_builder_choice_follows_the_toolkit(tmp_path):
    _write(tmp_path, "parts/unit.yaml", PART)
    path = _write(tmp_path, "choice.yaml", """\
        substructures:
          thin/thick:
            path: parts/unit.yaml
            offset: [0, 0, 40]
        nodes:
          x: [0, 50, 0]
        pair_groups:
          rod special:
            - [x, thin.tip]
          cable:
            - [x, thick.side]
        builders:
          special:
            class: tgBasicActuatorInfo
          rod thick:
            class: tgRodInfo
            parameters: {radius: 2}
          cable:
            class: tgKinematicActuatorInfo
            parameters: {target_velocity: 5}
        """)
    result = import_ntrt(path, "cm")
    s = result.structure
    radius = {r.name: r.radius for r in s.rods}
    # a rod builder beats a cable builder; a substructure's name is a tag of its own pairs
    assert radius == {"thin/rod_0": 0.005, "thin/rod_1": 0.005, "thick/rod_0": 0.02,
                      "thick/rod_1": 0.02, "rod_0": 0.005}
    assert [c.name for c in s.cables] == ["cable_0"]
    assert s.cables[0].motor.max_speed == pytest.approx(0.05)
    assert any("kinematic" in note for note in result.notes)


@pytest.mark.parametrize(("text", "match"), [
    ("nodes:\n  a: [0, 0, 0]\nrods: []\n", r"bad\.yaml: top level: unknown key 'rods'"),
    ("nodes:\n  a: [0, 0]\n", r"bad\.yaml: nodes 'a': expected three"),
    ("nodes:\n  a: [0, 0, 0]\n  a: [1, 0, 0]\n", r"bad\.yaml.*duplicate key 'a'"),
    ("nodes:\n  a: [0, 0, 0]\npair_groups:\n  rod:\n    - [a, z]\n",
     r"bad\.yaml: pair_groups 'rod' \[a, z\]: unknown node 'z'"),
    ("builders:\n  rod:\n    class: tgCapsuleInfo\n",
     r"bad\.yaml: builders 'rod': unsupported builder class 'tgCapsuleInfo'"),
    ("builders:\n  rod:\n    class: tgRodInfo\n    parameters: {mass: 1}\n",
     r"bad\.yaml: builders 'rod': unsupported tgRodInfo parameter 'mass'"),
    ("substructures:\n  s:\n    path: missing.yaml\n",
     r"bad\.yaml: cannot read structure file .*missing\.yaml"),
    ("substructures:\n  s:\n    path: bad.yaml\n", r"bad\.yaml: substructure files include"),
    ("nodes:\n  a: [0, 0, 0]\n  b: [0, 9, 0]\n  c: [9, 0, 0]\n"
     "pair_groups:\n  rod:\n    - [a, b]\n  string:\n    - [b, c]\n",
     r"bad\.yaml: cable 'string_0': node 'c' ends a cable but no rod"),
])
def test_bad_files_name_the_file_and_entry(tmp_path, text, match):
    path = _write(tmp_path, "bad.yaml", text)
    with pytest.raises(StructureError, match=match):
        import_ntrt(path, "cm")


SPINE = """\
    substructures:
      t1/t2/t3:
        path: parts/vertebra.yaml
        offset: [0, 0, -12]
    bond_groups:
      string:
        t1/t2/t3/node_node:
          - [front, front]
          - [right, right]
          - [left, left]
          - [top, top]
          - [right, front]
          - [left, front]
    builders:
      string:
        class: tgBasicActuatorInfo
        parameters: {stiffness: 1000, damping: 10, pretension: 300, max_tension: 7000,
                     target_velocity: 12}
    """

VERTEBRA = """\
    nodes:
      centre: [0, 10, 0]
      front: [0, 10, 8]
      right: [8, 4, -3]
      left: [-8, 4, -3]
      top: [0, 18, -3]
    pair_groups:
      rod:
        - [centre, front]
        - [centre, right]
        - [centre, left]
        - [centre, top]
    builders:
      rod:
        class: tgRodInfo
        parameters: {density: 0.0014, radius: 0.5}
    """


def test_cli_imports_a_spine_that_simulates(tmp_path, capsys):
    _write(tmp_path, "parts/vertebra.yaml", VERTEBRA)
    path = _write(tmp_path, "spine.yaml", SPINE)
    out = tmp_path / "spine_tensim.yaml"
    assert main(["import-ntrt", str(path), "--units", "cm", "--out", str(out)]) == 0
    assert "15 nodes, 12 rods in 3 rigid bodies, 12 cables" in capsys.readouterr().out
    s = load_structure(out)
    # --clearance 0.01 (default): the lowest rod surface (node z - radius) sits 1 cm up
    assert min(s.position(n)[2] for r in s.rods for n in r.nodes) - 0.005 == \
        pytest.approx(0.01, abs=1e-15)
    result = simulate(compile_structure(s), 1.0, record_dt=0.05)
    assert np.all(np.isfinite(result.trajectory.matrix("tension")))
    assert result.peak_tension.max() < 10.0  # 3 N pretension; the spine just settles


EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "ntrt" / "prism_tower.yaml"


def test_the_shipped_example_imports_and_stands_5_s(tmp_path, capsys):
    out = tmp_path / "tower.yaml"
    assert main(["import-ntrt", str(EXAMPLE), "--units", "dm", "--out", str(out)]) == 0
    # three prisms of 6 nodes, 3 bars and 9 strings; 6 saddle strings; the node_edge bond
    # takes the top prism's 3 bottom edges and the middle's 3 top strings, adds 2 x 3
    assert "18 nodes, 9 rods in 9 rigid bodies, 33 cables" in capsys.readouterr().out
    s = load_structure(out)
    bar = math.dist((0, 0, 3), (-1.5, 6, -2.598076))  # bottom1 -> top1 [dm]
    area, density = math.pi * 0.01**2, 1.3 / 0.1**3  # 0.1 dm radius [m^2]; kg/dm^3 -> kg/m^3
    # the file rounds its coordinates to 1e-6 dm: its three bars' lengths differ by ~1e-9
    assert s.total_mass() == pytest.approx(density * area * 0.1 * bar * (6 + 3 * 0.7), rel=1e-8)
    assert sum(c.name.startswith("cap_") for c in s.cables) == 6
    assert sum(c.name.startswith("saddle_") for c in s.cables) == 6
    result = simulate(compile_structure(s), 5.0, record_dt=0.1)
    assert np.all(np.isfinite(result.trajectory.matrix("tension")))
    assert result.peak_tension.max() < 100.0  # 40 N pretension; it settles, nothing flies off
