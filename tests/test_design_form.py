"""Form finding (tensim.design.form_finding) against closed and published forms, the independent
statics of tests/statics.py and simulation."""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

import statics
import tensim
from tensim.cli import main
from tensim.design import DesignError, self_stress
from tensim.design.form_finding import form
from tensim.design.topology import load_topology, topology_from_dict
from tensim.hardware import node_positions
from tensim.model import WorldOptions
from tensim.models.prisms import prism
from tensim.models.six_bar import six_bar
from tensim.structure import StructureError

CABLE = {"stiffness": 4000.0, "damping": 10.0}
ROD = {"radius": 0.01, "linear_density": 0.3}


def _topology(name: str, nodes: list[str], rods: list[tuple[str, str, str]],
              cables: list[tuple[str, str, str]], groups: dict[str, Any],
              **extra: Any) -> dict[str, Any]:
    """A topology mapping: members as (tag, end, end), named by tag and index."""
    return {"name": name, "nodes": [{"name": n} for n in nodes],
            "rods": [{"name": f"{t}_{i}", "nodes": [a, b], "tags": [t], **ROD}
                     for i, (t, a, b) in enumerate(rods)],
            "cables": [{"name": f"{t}_{i}", "nodes": [a, b], "tags": [t], **CABLE}
                       for i, (t, a, b) in enumerate(cables)],
            "groups": groups, "min_tension": 10.0, **extra}


def _prism(n: int, groups: dict[str, Any]) -> dict[str, Any]:
    """The n-prism: rod b_i-t_i, polygons b_i-b_(i+1) and t_i-t_(i+1), vertical b_i-t_(i-1)."""
    nodes = [f"b{i}" for i in range(n)] + [f"t{i}" for i in range(n)]
    rods = [("rod", f"b{i}", f"t{i}") for i in range(n)]
    cables = [("bottom", f"b{i}", f"b{(i + 1) % n}") for i in range(n)]
    cables += [("top", f"t{i}", f"t{(i + 1) % n}") for i in range(n)]
    cables += [("vertical", f"b{i}", f"t{(i - 1) % n}") for i in range(n)]
    return _topology(f"prism{n}", nodes, rods, cables, groups)


def _twist(structure: tensim.Structure, n: int) -> float:
    """Angle about the prism's axis from b0 to the top node its vertical cable reaches [rad]."""
    bottom = np.array([structure.position(f"b{i}") for i in range(n)])
    top = np.array([structure.position(f"t{i}") for i in range(n)])
    axis = top.mean(axis=0) - bottom.mean(axis=0)
    axis /= np.linalg.norm(axis)

    def across(p: np.ndarray, centre: np.ndarray) -> np.ndarray:
        v = p - centre
        return v - axis * (v @ axis)

    u = across(structure.position("b0"), bottom.mean(axis=0))
    v = across(structure.position(f"t{n - 1}"), top.mean(axis=0))
    return math.atan2(np.cross(u, v) @ axis, u @ v)


@pytest.mark.parametrize("n", range(3, 9))
def test_prisms_come_out_at_their_twist(n: int) -> None:
    # Closed form (Tibert & Pellegrino 2003, after Kenner; Connelly & Terrell, "Globally
    # rigid symmetric tensegrities", 1995): the n-prism is in equilibrium with a top polygon
    # turned by pi/2 - pi/n against the bottom one, with force densities polygon : vertical :
    # rod = 1 : 2 sin(pi/n) : -2 sin(pi/n). Given those q, the form must have that twist; given
    # only lengths, the form finding must find both the twist and the q.
    ratio = 2 * math.sin(math.pi / n)
    given = {"rod": {"force_density": -ratio, "length": 0.44}, "top": {"force_density": 1.0},
             "bottom": {"force_density": 1.0}, "vertical": {"force_density": ratio}}
    free = {"rod": {"length": 0.44}, "top": {"length": 0.2}, "bottom": {"length": 0.2},
            "vertical": {}}
    for groups in (given, free):
        result = form(topology_from_dict(_prism(n, groups)))
        structure = result.structure
        # round-off of an eigen-decomposition / a least-squares solve at 1e-15 tolerances
        assert abs(_twist(structure, n)) == pytest.approx(math.pi / 2 - math.pi / n, abs=1e-9)
        q = result.force_densities
        assert q["vertical"] / q["top"] == pytest.approx(ratio, rel=1e-9)
        assert q["rod"] / q["top"] == pytest.approx(-ratio, rel=1e-9)
        assert q["bottom"] == pytest.approx(q["top"], rel=1e-9)
        assert result.lengths["rod"] == pytest.approx((0.44, 0.44), rel=1e-9)
        # Connelly's condition: D positive semi-definite of rank n_nodes - 4
        assert result.super_stable and result.rank == 2 * n - 4
        assert min(c.pretension for c in structure.cables) == pytest.approx(10.0)
    assert result.lengths["top"] == pytest.approx((0.2, 0.2), rel=1e-9)


def test_expanded_octahedron_is_the_published_form() -> None:
    # Published form (Tibert & Pellegrino 2003, Fig. 6; the six_bar preset's docstring): three
    # pairs of parallel rods along x, y, z, each pair half a rod length apart, all 24 cables
    # rod * sqrt(6) / 4 long, at cable : rod force density 1 : -3/2. Given the q, the form; given
    # only the rod length, the q.
    reference = six_bar(standing=False)  # the form, not its pose standing on the ground
    nodes = [n.name for n in reference.nodes]
    rods = [("rod", *r.nodes) for r in reference.rods]
    cables = [("cable", *c.nodes) for c in reference.cables]
    for groups in ({"rod": {"force_density": -1.5, "length": 1.0},
                    "cable": {"force_density": 1.0}},
                   {"rod": {"length": 1.0}, "cable": {}}):
        result = form(topology_from_dict(_topology("octahedron", nodes, rods, cables, groups)))
        structure = result.structure
        assert result.force_densities["rod"] / result.force_densities["cable"] == \
            pytest.approx(-1.5, rel=1e-9)
        assert result.lengths["cable"] == pytest.approx((math.sqrt(6) / 4,) * 2, rel=1e-9)
        assert result.super_stable and result.rank == 12 - 4
        ends = {r.name: [structure.position(n) for n in r.nodes] for r in structure.rods}
        for axis in "xyz":  # the pair of rods along each axis (tensim's six_bar names)
            (a0, a1), (b0, b1) = (ends[f"rod_{i}"] for i, r in enumerate(reference.rods)
                                  if r.name.startswith(f"rod_{axis}"))
            direction = (a1 - a0) / np.linalg.norm(a1 - a0)
            assert abs(direction @ (b1 - b0)) == pytest.approx(1.0, rel=1e-9)  # parallel
            gap = (a0 + a1) / 2 - (b0 + b1) / 2
            assert np.linalg.norm(gap) == pytest.approx(0.5, rel=1e-9)
            assert gap @ direction == pytest.approx(0.0, abs=1e-9)  # side by side


def _tower(groups: dict[str, Any]) -> dict[str, Any]:
    """A two-stage, three-rod tower (Sultan, Corless & Skelton's SVD tower: saddle, vertical
    and diagonal cables): stage 1 rods b_i-u_i, stage 2 rods v_i-t_i, the upper stage's feet
    v below the lower stage's heads u."""
    nodes = [f"{s}{i}" for s in "buvt" for i in range(3)]
    rods = [("rod", f"{a}{i}", f"{b}{i}") for a, b in ("bu", "vt") for i in range(3)]
    cables = []
    for i in range(3):
        j = (i + 1) % 3
        cables += [("bottom", f"b{i}", f"b{j}"), ("top", f"t{i}", f"t{j}"),
                   ("saddle", f"u{i}", f"v{i}"), ("saddle", f"u{i}", f"v{j}"),
                   ("vertical", f"b{i}", f"v{j}"), ("vertical", f"u{i}", f"t{i}"),
                   ("diagonal", f"b{i}", f"u{j}"), ("diagonal", f"v{i}", f"t{(i + 2) % 3}")]
    return _topology("tower", nodes, rods, cables, groups)


TOWER = {"rod": {"length": 0.5}, "bottom": {"length": 0.3}, "top": {"length": 0.3},
         "saddle": {}, "vertical": {}, "diagonal": {}}


def test_two_stage_tower_has_the_self_stress_of_independent_statics() -> None:
    result = form(topology_from_dict(_tower(TOWER)))
    structure = result.structure
    # the pin-jointed self-stress of the formed geometry, by an independent SVD, is the
    # found force densities (one state of self-stress: s = 1)
    _, q = statics.self_stress(structure)
    found = [result.force_densities[g] for g in ["rod"] * 6] + \
        [c.pretension / structure.cable_length(c) for c in structure.cables]
    np.testing.assert_allclose(q / q[0], np.array(found) / found[0], rtol=1e-7)
    assert result.super_stable and result.rank == 12 - 4
    for group in ("rod", "bottom", "top"):  # the chosen lengths
        assert result.lengths[group] == pytest.approx((TOWER[group]["length"],) * 2, rel=1e-9)
    z = {s: np.mean([structure.position(f"{s}{i}")[2] for i in range(3)]) for s in "buvt"}
    assert z["b"] < z["v"] < z["u"] < z["t"]  # the stages overlap


def _still(structure: tensim.Structure) -> float:
    """Largest node displacement [m] over 5 s without gravity from the build pose."""
    compiled = tensim.compile_structure(structure, WorldOptions(gravity=(0.0, 0.0, 0.0),
                                                                ground=False))
    run = tensim.simulate(compiled, 5.0, record_dt=0.05)
    nodes = [n.name for n in structure.nodes]
    positions = node_positions(run.trajectory, compiled, nodes)
    return max(float(np.linalg.norm(positions[n] - structure.position(n), axis=1).max())
               for n in nodes)


@pytest.mark.parametrize("case", ["prism3", "prism6", "octahedron", "tower"])
def test_formed_structures_pass_prestress_and_stand_still(case: str) -> None:
    if case.startswith("prism"):
        n = int(case[-1])
        topology = _prism(n, {"rod": {"length": 0.44}, "top": {"length": 0.2},
                              "bottom": {"length": 0.2}, "vertical": {}})
    elif case == "octahedron":
        reference = six_bar(standing=False)  # the form, not its pose standing on the ground
        topology = _topology("octahedron", [n.name for n in reference.nodes],
                             [("rod", *r.nodes) for r in reference.rods],
                             [("cable", *c.nodes) for c in reference.cables],
                             {"rod": {"length": 1.0}, "cable": {}})
    else:
        topology = _tower(TOWER)
    topology["point_masses"] = [{"node": n["name"], "mass": 0.05} for n in topology["nodes"]]
    structure = form(topology_from_dict(topology)).structure
    # design prestress finds the written pretensions: one self-stress, at the same level
    stress = self_stress(structure, min_tension=10.0)
    np.testing.assert_allclose(stress.tensions, [c.pretension for c in structure.cables],
                               rtol=1e-6)  # the form balances to 1e-9 of the largest force
    # stands still: under 1 mm in 5 s at zero g
    assert _still(structure) < 1e-3


def test_force_densities_without_a_form_are_refused() -> None:
    # the 3-prism with vertical : polygon = 1 : 1 instead of sqrt(3): D has rank 5 - 0 = more
    # than n - 4, so the only equilibria are flat or a point
    groups = {"rod": {"force_density": -1.0, "length": 0.44}, "top": {"force_density": 1.0},
              "bottom": {"force_density": 1.0}, "vertical": {"force_density": 1.0}}
    with pytest.raises(DesignError, match=r"no three-dimensional form has these force "
                       r"densities: their force density matrix D has rank \d for 6 nodes, and "
                       r"a form in 3D needs rank <= 2"):
        form(topology_from_dict(_prism(3, groups)))
    with pytest.raises(DesignError, match="nothing sets the form's size"):
        form(topology_from_dict(_prism(3, {"rod": {}, "top": {}, "bottom": {},
                                           "vertical": {}})))


def test_topology_file_errors_name_the_file_and_field(tmp_path: Path) -> None:
    path = tmp_path / "t.yaml"
    cases = [
        ({"groups": {"rod": {"force_density": 1.0}}}, r"rods\[0\] 'rod_0': group 'rod' has "
         r"force_density 1 N/m; a rod pushes: expected < 0"),
        ({"groups": {"rod": {"lenght": 1.0}}}, r"groups 'rod': unknown field 'lenght'"),
        ({"groups": {"rod": {"length": -1}}}, r"groups 'rod': length must be > 0 m"),
        ({"groups": {"top": {}}}, r"rods\[0\] 'rod_0': belongs to no group"),
        ({"extra": 1}, "unknown top-level field 'extra'"),
    ]
    base = _prism(3, {"rod": {"length": 0.44}, "top": {}, "bottom": {}, "vertical": {}})
    for change, message in cases:
        data = {**base, **change}
        if "groups" in change and "top" not in change["groups"]:
            data["groups"] = {**base["groups"], **change["groups"]}
        if change.get("groups") == {"top": {}}:
            data["groups"] = {"top": {}, "bottom": {}, "vertical": {}}
        path.write_text(yaml.safe_dump(data))
        with pytest.raises(StructureError, match=f"^{path}: {message}"):
            load_topology(path)
    data = {**base}
    data["cables"] = [{**data["cables"][0], "pretension": 5.0}, *data["cables"][1:]]
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(StructureError, match="pretension is set by the form finding"):
        load_topology(path)


def test_form_command_writes_a_structure_that_reads_back(tmp_path: Path, capsys) -> None:
    source = Path(__file__).parent.parent / "examples/design/hopper_topology.yaml"
    out = tmp_path / "hopper.yaml"
    assert main(["design", "form", str(source), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "force density matrix of rank 2 (a 3D form needs <= 2), super-stable" in text
    structure = tensim.load_structure(out)
    assert min(c.pretension for c in structure.cables) == pytest.approx(20.0)
    assert min(structure.position(n.name)[2] for n in structure.nodes) == pytest.approx(0.02)
    assert {n.name for n in structure.nodes if structure.position(n.name)[2] < 0.03} == \
        {"b0", "b1", "b2"}  # the first node's side down
    for rod in structure.rods:
        assert structure.distance(*rod.nodes) == pytest.approx(0.44, rel=1e-9)
    assert main(["design", "form", str(out), "--out", str(out)]) != 0
    assert "is the topology file this command reads" in capsys.readouterr().err
    assert list(itertools.chain(tmp_path.iterdir())) == [out]


def test_a_topology_whose_groups_cannot_all_carry_force_is_refused() -> None:
    # the tower with its vertical cables joining b_i to v_i and u_i to t_i, and diagonals
    # b_i-u_(i+1), v_i-t_(i+1): no form holds every group in tension (the nearest
    # equilibria leave the vertical cables idle, q -> 0)
    data = _tower(TOWER)
    for cable in data["cables"]:
        a, b = cable["nodes"]
        if cable["tags"] == ["vertical"]:
            cable["nodes"] = [a, b[0] + a[1]]
        if cable["tags"] == ["diagonal"] and a.startswith("v"):
            cable["nodes"] = [a, f"t{(int(a[1]) + 1) % 3}"]
    with pytest.raises(DesignError, match="no form in equilibrium found with these groups"):
        form(topology_from_dict(data))


def test_form_command_names_the_file_of_a_bad_member(tmp_path: Path, capsys) -> None:
    data = _prism(3, {"rod": {"length": 0.44}, "top": {"length": 0.2},
                      "bottom": {"length": 0.2}, "vertical": {}})
    data["rods"][1]["radius"] = -0.01
    path = tmp_path / "t.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["design", "form", str(path), "--out", str(tmp_path / "out.yaml")]) != 0
    assert f"{path}: rod 'rod_1': radius must be > 0 m, got -0.01" in capsys.readouterr().err
    assert not (tmp_path / "out.yaml").exists()


@pytest.mark.parametrize("n", [3, 5])
def test_rough_positions_place_the_form(n: int) -> None:
    # the prism preset's exact form, each coordinate moved by up to 2 mm: given q or given
    # lengths, the form comes back to the exact one (placed by the best rigid fit to the rough
    # positions) within 2 mm (measured 0.8 / 0.6 mm: the fit spreads the noise)
    exact = prism(n)
    rod, side = exact.distance("b0", "t0"), exact.distance("t0", "t1")
    ratio = 2 * math.sin(math.pi / n)
    for groups in ({"rod": {"force_density": -ratio, "length": rod},
                    "top": {"force_density": 1.0, "length": side},
                    "bottom": {"force_density": 1.0}, "vertical": {"force_density": ratio}},
                   {"rod": {"length": rod}, "top": {"length": side}, "bottom": {"length": side},
                    "vertical": {}}):
        data = _prism(n, groups)
        rng = np.random.default_rng(1)
        for node in data["nodes"]:
            node["position"] = (exact.position(node["name"])
                                + rng.uniform(-2e-3, 2e-3, 3)).tolist()
        formed = form(topology_from_dict(data)).structure
        assert max(np.linalg.norm(formed.position(x.name) - exact.position(x.name))
                   for x in exact.nodes) < 2e-3
