"""Topology files: what a designer knows before the form is found.

A topology file is a structure file (see :mod:`tensim.structure`) whose nodes may lack a
``position`` (or give a rough one) and whose cables give no ``pretension`` or ``rest_length``,
plus a ``groups`` mapping that sets one value per group of members::

    name: prism3
    min_tension: 20            # N, optional: scales the found prestress
    elevation: 0.05            # m, optional: the lowest node's height (no positions given)
    nodes: [{name: b0}, {name: b1}, ...]
    rods: [{name: rod_0, nodes: [b0, t0], radius: 0.01, linear_density: 0.3, tags: [rod]}]
    cables: [{name: top_0, nodes: [t0, t1], stiffness: 4000, tags: [top]}, ...]
    groups:
      top: {force_density: 1.0}          # N/m, > 0 for cables
      rod: {length: 0.44}                # m: every member of the group this long
      vertical: {}                       # force density found by the form finding

A member belongs to the first of its tags (or, failing those, its own name) that ``groups``
names. Members of one group are meant to be images of each other under a symmetry of the
form: they share one force density and one length.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Any, NoReturn

from tensim._input import InputError, describe, is_real, load_yaml_file
from tensim.structure import StructureError

_TOP = {"name", "nodes", "rods", "cables", "point_masses", "defaults", "groups", "min_tension",
        "elevation"}
_GROUP_FIELDS = ("force_density", "length")


@dataclasses.dataclass(frozen=True)
class Group:
    """One value per group of members that a symmetry maps onto each other.

    Attributes:
        force_density: q = t / L of every member [N/m] (> 0 cables, < 0 rods), or None to
            let the form finding choose it.
        length: target length of every member [m], or None.
    """

    force_density: float | None = None
    length: float | None = None


@dataclasses.dataclass(frozen=True)
class Member:
    """A rod or a cable as the form finding sees it: a bar between two nodes.

    Attributes:
        name: the rod's or cable's name.
        rod: True for a rod (compression), False for a cable (tension).
        nodes: its two end nodes.
        group: the name of its group.
    """

    name: str
    rod: bool
    nodes: tuple[str, str]
    group: str


@dataclasses.dataclass(frozen=True)
class Topology:
    """A structure without a form: nodes, members in groups, and the rest of its file.

    Attributes:
        name: structure name.
        nodes: node names, in file order.
        positions: node name -> rough position (3,) [m] for the nodes that give one.
        members: rods first, then cables.
        groups: group name -> its values.
        min_tension: the smallest cable tension of the formed structure [N], or None to take
            the force densities as given in N/m.
        elevation: height of the lowest node when no node gives a position [m].
        data: the file's mapping (rods, cables, point masses, defaults) for building the
            formed structure.
    """

    name: str
    nodes: tuple[str, ...]
    positions: dict[str, tuple[float, float, float]]
    members: tuple[Member, ...]
    groups: dict[str, Group]
    min_tension: float | None
    elevation: float
    data: dict[str, Any]


def _fail(message: str, item: str | None = None) -> NoReturn:
    raise StructureError(message, item=item)


def _number(value: Any, item: str, field: str, unit: str, sign: str = "") -> float:
    if not is_real(value):
        _fail(f"{field} must be a finite number [{unit}], got {describe(value)}", item)
    if sign == "+" and value <= 0:
        _fail(f"{field} must be > 0 {unit}, got {value}", item)
    return float(value)


def _groups(raw: Any) -> dict[str, Group]:
    if not isinstance(raw, dict) or not raw:
        _fail(f"groups must be a mapping of group names to {{force_density, length}}, got "
              f"{describe(raw)}", "groups")
    out = {}
    for name, fields in raw.items():
        item = f"groups {name!r}"
        fields = {} if fields is None else fields
        if not isinstance(fields, dict):
            _fail(f"expected a mapping of {list(_GROUP_FIELDS)}, got {describe(fields)}", item)
        unknown = sorted(set(fields) - set(_GROUP_FIELDS))
        if unknown:
            _fail(f"unknown field {unknown[0]!r}; expected {list(_GROUP_FIELDS)}", item)
        q = fields.get("force_density")
        length = fields.get("length")
        out[str(name)] = Group(
            None if q is None else _number(q, item, "force_density", "N/m"),
            None if length is None else _number(length, item, "length", "m", "+"))
        if q is not None and q == 0:
            _fail("force_density must not be 0 N/m (a member that carries nothing is no "
                  "member); leave it out to let the form finding choose it", item)
    return out


def _member(raw: Any, rod: bool, index: int, default_tags: Any,
            groups: dict[str, Group]) -> Member:
    section = "rods" if rod else "cables"
    if not isinstance(raw, dict) or "name" not in raw:
        _fail(f"expected a mapping with a name, got {describe(raw)}", f"{section}[{index}]")
    item = f"{section}[{index}] {raw['name']!r}"
    nodes = raw.get("nodes")
    if not (isinstance(nodes, list) and len(nodes) == 2 and all(isinstance(n, str)
                                                               for n in nodes)):
        _fail(f"nodes must be two node names, got {describe(nodes)}", item)
    if not rod:
        for field in ("pretension", "rest_length"):
            if field in raw:
                _fail(f"{field} is set by the form finding (from its group's force density); "
                      "leave it out of a topology file", item)
        for field in ("via", "wrap"):
            if raw.get(field):
                _fail(f"form finding takes straight cables; this one has {field}", item)
    tags = raw.get("tags", default_tags) or []
    if isinstance(tags, str) or not isinstance(tags, list):
        _fail(f"tags must be a list of strings, got {describe(tags)}", item)
    group = next((str(t) for t in [*tags, raw["name"]] if t in groups), None)
    if group is None:
        _fail(f"belongs to no group: none of its tags {tags} nor its name is listed under "
              f"groups ({sorted(groups)})", item)
    q = groups[group].force_density
    if q is not None and (q < 0) != rod:
        _fail(f"group {group!r} has force_density {q:g} N/m; a "
              f"{'rod pushes: expected < 0' if rod else 'cable pulls: expected > 0'}", item)
    return Member(str(raw["name"]), rod, (nodes[0], nodes[1]), group)


def topology_from_dict(data: Any) -> Topology:
    """Reads the mapping of a topology file.

    Raises:
        StructureError: naming the item and what was expected.
    """
    if not isinstance(data, dict):
        _fail("expected a mapping with 'nodes', 'rods', 'cables' and 'groups'")
    unknown = sorted(set(data) - _TOP)
    if unknown:
        _fail(f"unknown top-level field {unknown[0]!r}; expected {sorted(_TOP)}")
    groups = _groups(data.get("groups"))
    nodes: list[str] = []
    positions: dict[str, tuple[float, float, float]] = {}
    raw_nodes = data.get("nodes")
    if not isinstance(raw_nodes, list) or not raw_nodes:
        _fail(f"nodes must be a list of mappings, got {describe(raw_nodes)}", "nodes")
    for i, raw in enumerate(raw_nodes):
        if not isinstance(raw, dict) or not isinstance(raw.get("name"), str):
            _fail(f"expected a mapping with a name, got {describe(raw)}", f"nodes[{i}]")
        item = f"nodes[{i}] {raw['name']!r}"
        if raw.get("fixed"):
            _fail("form finding takes free-standing structures; no node may be fixed", item)
        position = raw.get("position")
        if position is not None:
            if not (isinstance(position, list) and len(position) == 3
                    and all(is_real(v) for v in position)):
                _fail(f"position must be three finite numbers [m], got {describe(position)}",
                      item)
            positions[raw["name"]] = (float(position[0]), float(position[1]),
                                      float(position[2]))
        nodes.append(raw["name"])
    defaults = data.get("defaults") or {}
    if not isinstance(defaults, dict):
        _fail(f"defaults must be a mapping, got {describe(defaults)}", "defaults")
    for field in ("pretension", "rest_length"):
        if field in (defaults.get("cable") or {}):
            _fail(f"{field} is set by the form finding; leave it out of a topology file",
                  "defaults cable")
    members = []
    for section, rod in (("rods", True), ("cables", False)):
        items = data.get(section) or []
        if not isinstance(items, list):
            _fail(f"'{section}' must be a list of mappings, got {describe(items)}")
        default_tags = (defaults.get(section[:-1]) or {}).get("tags")
        members += [_member(raw, rod, i, default_tags, groups) for i, raw in enumerate(items)]
    known = set(nodes)
    for member in members:
        for end in member.nodes:
            if end not in known:
                _fail(f"unknown node {end!r}", f"{'rod' if member.rod else 'cable'} "
                      f"{member.name!r}")
    used = {m.group for m in members}
    unused = sorted(set(groups) - used)
    if unused:
        _fail(f"group {unused[0]!r} has no members (no rod or cable carries that tag or name)",
              "groups")
    min_tension = data.get("min_tension")
    if min_tension is not None:
        min_tension = _number(min_tension, "min_tension", "min_tension", "N", "+")
    elevation = _number(data.get("elevation", 0.05), "elevation", "elevation", "m")
    return Topology(str(data.get("name", "structure")), tuple(nodes), positions,
                    tuple(members), groups, min_tension, elevation, data)


def load_topology(path: str | os.PathLike[str]) -> Topology:
    """Reads a topology file.

    Raises:
        StructureError: naming the file, the item and what was expected.
        FileNotFoundError: no such file.
    """
    path = Path(path)
    try:
        data = load_yaml_file(path)
    except InputError as err:
        raise StructureError(str(err)) from None
    try:
        return topology_from_dict(data)
    except StructureError as err:
        raise err.with_source(str(path)) from None


