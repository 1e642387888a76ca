"""Structure records: validation of malformed input, YAML files, rigid groups, mass properties."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
import yaml

from tensim.models import prism3, tetraspine3
from tensim.structure import (
    Cable,
    Motor,
    Node,
    PointMass,
    Rod,
    Structure,
    StructureError,
    load_structure,
    mass_properties,
    save_structure,
)


def _nodes() -> tuple[Node, ...]:
    return (Node("a", (0.0, 0.0, 0.0)), Node("b", (1.0, 0.0, 0.0)), Node("c", (0.0, 1.0, 0.0)))


def _rods() -> tuple[Rod, ...]:
    return (Rod("r", ("a", "b"), 0.01, linear_density=0.1),
            Rod("s", ("a", "c"), 0.01, linear_density=0.1))


# -- malformed input built in Python -----------------------------------------------------------


def test_unknown_node_is_refused():
    with pytest.raises(StructureError, match=r"cable 'k'.*unknown node 'z'"):
        Structure("t", _nodes(), _rods(), (Cable("k", ("b", "z"), 100.0, pretension=1.0),))
    with pytest.raises(StructureError, match=r"rod 'q'.*unknown node 'z'"):
        Structure("t", _nodes(), (*_rods(), Rod("q", ("a", "z"), 0.01, linear_density=0.1)))


def test_zero_length_rod_is_refused():
    nodes = (*_nodes(), Node("d", (1.0, 0.0, 0.0)))  # on top of b
    with pytest.raises(StructureError, match=r"rod 'q'.*zero-length"):
        Structure("t", nodes, (*_rods(), Rod("q", ("b", "d"), 0.01, linear_density=0.1)))


def test_cable_from_a_node_to_itself_is_refused():
    with pytest.raises(StructureError, match=r"cable 'k'.*two different nodes"):
        Cable("k", ("a", "a"), 100.0, pretension=1.0)


@pytest.mark.parametrize("stiffness", [-100.0, 0.0])
def test_non_positive_stiffness_is_refused(stiffness):
    with pytest.raises(StructureError, match=r"cable 'k'.*stiffness must be > 0"):
        Cable("k", ("a", "b"), stiffness, pretension=1.0)


def test_pretension_leaving_no_rest_length_is_refused():
    # b to c is sqrt(2) m; at 100 N/m a pretension of 100 sqrt(2) N or more leaves rest <= 0
    cable = Cable("k", ("b", "c"), 100.0, pretension=150.0)
    with pytest.raises(StructureError, match=r"cable 'k'.*non-positive rest length"):
        Structure("t", _nodes(), _rods(), (cable,))
    # just below the limit is fine and leaves rest = L - T/k
    ok = Structure("t", _nodes(), _rods(), (Cable("k", ("b", "c"), 100.0, pretension=140.0),))
    # closed form sqrt(2) - 1.4; rounding of a norm and a division
    assert ok.rest_length(ok.cables[0]) == pytest.approx(math.sqrt(2) - 1.4, abs=1e-14)


def test_other_bad_values_are_refused():
    with pytest.raises(StructureError, match=r"damping must be >= 0"):
        Cable("k", ("a", "b"), 100.0, damping=-1.0, pretension=1.0)
    with pytest.raises(StructureError, match="exactly one of pretension"):
        Cable("k", ("a", "b"), 100.0)
    with pytest.raises(StructureError, match="exactly one of linear_density"):
        Rod("r", ("a", "b"), 0.01)
    with pytest.raises(StructureError, match="mass must be > 0"):
        PointMass("a", 0.0)
    with pytest.raises(StructureError, match="max_speed must be > 0"):
        Motor(max_speed=0.0)
    with pytest.raises(StructureError, match=r"node 'c'.*no rod.*no point mass"):
        Structure("t", _nodes(), _rods()[:1])
    with pytest.raises(StructureError, match="duplicate node name 'a'"):
        Structure("t", (*_nodes(), Node("a", (5.0, 0.0, 0.0))), _rods())


# -- YAML files ----------------------------------------------------------------------------------


def _good() -> dict[str, Any]:
    return {
        "name": "tri",
        "nodes": [{"name": "a", "position": [0.0, 0.0, 0.0]},
                  {"name": "b", "position": [1.0, 0.0, 0.0]},
                  {"name": "c", "position": [0.0, 1.0, 0.0]}],
        "rods": [{"name": "r", "nodes": ["a", "b"], "radius": 0.01, "linear_density": 0.1},
                 {"name": "s", "nodes": ["a", "c"], "radius": 0.01, "linear_density": 0.1}],
        "cables": [{"name": "k", "nodes": ["b", "c"], "stiffness": 100.0, "pretension": 5.0}],
    }


def _write(tmp_path, data: dict[str, Any]):
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def test_good_yaml_loads(tmp_path):
    s = load_structure(_write(tmp_path, _good()))
    assert [c.name for c in s.cables] == ["k"]
    # rest = sqrt(2) - 5/100 from the file's geometry; rounding only
    assert s.rest_length(s.cables[0]) == pytest.approx(math.sqrt(2) - 0.05, abs=1e-14)


def _mutate(data: dict[str, Any], section: str, i: int, **changes: Any) -> dict[str, Any]:
    data[section][i].update(changes)
    return data


BAD_YAML = [
    # (description, mutation, fragments the message must contain: item and what was expected)
    ("unknown field", lambda d: _mutate(d, "cables", 0, colour="red"),
     ["cables[0] 'k'", "unknown field 'colour'", "expected one of", "stiffness"]),
    ("unknown node", lambda d: _mutate(d, "cables", 0, nodes=["b", "zz"]),
     ["cable 'k'", "unknown node 'zz'", "known nodes"]),
    ("zero-length rod", lambda d: _mutate(d, "rods", 1, nodes=["a", "a"]),
     ["rod 's'", "two different nodes"]),
    ("coincident rod nodes", lambda d: _mutate(d, "nodes", 2, position=[0.0, 0.0, 0.0]),
     ["rod 's'", "zero-length"]),
    ("coincident cable nodes", lambda d: _mutate(d, "nodes", 2, position=[1.0, 0.0, 0.0]),
     ["cable 'k'", "zero-length cable"]),
    ("cable to itself", lambda d: _mutate(d, "cables", 0, nodes=["b", "b"]),
     ["cable 'k'", "two different nodes"]),
    ("negative stiffness", lambda d: _mutate(d, "cables", 0, stiffness=-3.0),
     ["cable 'k'", "stiffness must be > 0"]),
    ("pretension too high", lambda d: _mutate(d, "cables", 0, pretension=500.0),
     ["cable 'k'", "non-positive rest length", "expected pretension < stiffness * length"]),
    ("unknown top-level field", lambda d: {**d, "colour": "red"},
     ["unknown top-level field 'colour'"]),
    ("missing field", lambda d: d["rods"][0].pop("radius") and d,
     ["rods[0] 'r'", "radius"]),
    ("unknown motor field", lambda d: _mutate(d, "cables", 0, motor={"speed": 1.0}),
     ["cables[0] 'k' motor", "unknown field 'speed'", "max_speed"]),
]


@pytest.mark.parametrize(("mutation", "fragments"), [c[1:] for c in BAD_YAML],
                         ids=[c[0] for c in BAD_YAML])
def test_bad_yaml_names_file_item_and_expectation(tmp_path, mutation, fragments):
    path = _write(tmp_path, mutation(_good()))
    with pytest.raises(StructureError) as info:
        load_structure(path)
    message = str(info.value)
    assert str(path) in message
    for fragment in fragments:
        assert fragment in message


def test_invalid_yaml_syntax_names_file(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text("nodes: [a, b\n")
    with pytest.raises(StructureError, match="not valid YAML") as info:
        load_structure(path)
    assert str(path) in str(info.value)


def test_yaml_defaults_merge_under_items(tmp_path):
    data = _good()
    data["defaults"] = {"cable": {"damping": 3.0, "motor": {"max_speed": 0.2, "max_tension": 9.0}}}
    data["cables"][0]["motor"] = {"max_tension": 4.0}
    s = load_structure(_write(tmp_path, data))
    expected = Cable("k", ("b", "c"), 100.0, damping=3.0, pretension=5.0,
                     motor=Motor(max_speed=0.2, max_tension=4.0))
    assert s.cables[0] == expected


@pytest.mark.parametrize("build", [tetraspine3, prism3], ids=["tetraspine3", "prism3"])
def test_save_load_round_trip(tmp_path, build):
    original = build()
    path = tmp_path / "robot.yaml"
    save_structure(original, path)
    loaded = load_structure(path)
    assert loaded == original  # exact: YAML writes floats with repr, which round-trips
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left behind


# -- rigid groups and mass properties ------------------------------------------------------------


def test_rods_sharing_nodes_form_one_body():
    nodes = (*_nodes(), Node("d", (5.0, 0.0, 0.0)), Node("e", (5.0, 1.0, 0.0)),
             Node("m", (9.0, 0.0, 0.0)))
    rods = (*_rods(), Rod("t", ("d", "e"), 0.01, linear_density=0.1, tags=("stick",)))
    s = Structure("t", nodes, rods, point_masses=(PointMass("m", 0.2),))
    groups = {g.name: g for g in s.rigid_groups()}
    assert set(groups) == {"rigid_0", "stick", "m"}
    assert set(groups["rigid_0"].rods) == {"r", "s"}
    assert set(groups["rigid_0"].nodes) == {"a", "b", "c"}
    assert groups["m"].rods == () and groups["m"].nodes == ("m",)


def test_mass_properties_of_an_l_shape_match_closed_form():
    """Two perpendicular 1 m rods from the origin plus a point mass at the corner."""
    lam, r, m0, r0 = 0.3, 0.02, 0.5, 0.01
    s = Structure("l", _nodes(), (Rod("r", ("a", "b"), r, linear_density=lam),
                                  Rod("s", ("a", "c"), r, linear_density=lam)),
                  point_masses=(PointMass("a", m0, r0),))
    props = mass_properties(s, s.rigid_groups()[0])
    m_rod = lam * 1.0
    total = 2 * m_rod + m0
    com = np.array([0.5 * m_rod, 0.5 * m_rod, 0.0]) / total
    # inertia about the origin, then shifted to the COM (parallel axes, by hand)
    axial, across_c = 0.5 * m_rod * r**2, m_rod * (3 * r**2 + 1.0) / 12
    across_end = across_c + m_rod * 0.25  # rod about the perpendicular axis through its end
    sphere = 0.4 * m0 * r0**2
    i_origin = np.zeros((3, 3))
    # rod along x (centre (0.5, 0, 0)) and rod along y (centre (0, 0.5, 0))
    i_origin[0, 0] = axial + across_end + sphere
    i_origin[1, 1] = across_end + axial + sphere
    i_origin[2, 2] = 2 * across_end + sphere
    # products of inertia: each rod lies on an axis, so only the cross term of the whole is 0
    expected = i_origin - total * (com @ com * np.eye(3) - np.outer(com, com))
    assert props.mass == pytest.approx(total, rel=1e-14)  # rounding only
    np.testing.assert_allclose(props.com, com, rtol=0, atol=1e-15)  # rounding only
    np.testing.assert_allclose(props.inertia, expected, rtol=0, atol=1e-14)  # rounding only


def test_a_remembered_cable_length_equals_a_computed_one_and_follows_its_structure() -> None:
    """cable_length is computed once per cable of a structure: every cable's remembered value
    equals the computation, bit for bit; a structure with moved nodes (a new structure) and an
    equal cable built again get their own."""
    import dataclasses

    from tensim.models import preset

    for name in ("tetraspine3", "six_bar"):
        structure = preset(name).build()
        for cable in structure.cables:
            assert structure.cable_length(cable) == structure._cable_length(cable)
            assert structure.cable_length(dataclasses.replace(cable)) == \
                structure._cable_length(cable)
        moved = dataclasses.replace(structure, nodes=tuple(
            dataclasses.replace(n, position=tuple(2.0 * np.asarray(n.position)))
            for n in structure.nodes))
        cable = structure.cables[0]
        assert moved.cable_length(cable) == moved._cable_length(cable)
        assert moved.cable_length(cable) != structure.cable_length(cable)


def test_rigid_groups_are_found_once_and_are_those_of_a_fresh_structure() -> None:
    """rigid_groups is remembered per structure: a second call gives the same groups, equal
    to those a newly built copy of the structure finds."""
    import dataclasses

    from tensim.models import preset

    structure = preset("tetraspine3").build()
    first = structure.rigid_groups()
    assert structure.rigid_groups() is first
    assert dataclasses.replace(structure).rigid_groups() == first
