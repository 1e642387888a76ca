"""Reads the original toolkit's YAML structure files into flat, tagged nodes and node pairs.

This follows NTRTsim's ``yamlbuilder`` (``TensegrityModel.cpp``): a file has ``nodes`` (name:
[x, y, z]), ``pair_groups`` (tags: list of [node, node]), ``builders`` (tags: {class,
parameters}), ``substructures`` (name or ``a/b/c``: {path, rotation, scale, offset,
translation}) and ``bond_groups`` (node pairs between substructures, ``a/b/node_node``). A
substructure is turned about ``rotation.reference`` (default: its centroid), then scaled about
its centroid, moved by ``offset`` times its index in an ``a/b/c`` list, then by
``translation``. Everything stays in the file's units and frame here; :mod:`tensim.io.ntrt`
converts.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from tensim._input import InputError, describe, is_real, load_yaml, read_text
from tensim.structure import StructureError

MAX_FILES = 10_000  # most substructure files a model may read (each use counted)
_TOP_KEYS = ("nodes", "pair_groups", "builders", "substructures", "bond_groups")
_CHILD_KEYS = ("path", "rotation", "translation", "scale", "offset")
_ROTATION_KEYS = ("axis", "angle", "reference")


@dataclasses.dataclass(eq=False)
class Part:
    """One structure of the file tree: the top file or a substructure (positions in file units).

    Attributes:
        name: its substructure name ("" for the top file).
        prefix: its path from the top, ending in "/" ("" for the top), e.g. ``"spine/t1/"``.
        source: the file it came from.
        nodes: node name -> (3,) position, changed in place by the transforms.
        children: its substructures, in file order.
    """

    name: str
    prefix: str
    source: Path
    nodes: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    children: list[Part] = dataclasses.field(default_factory=list)

    def walk(self) -> Iterator[Part]:
        """This part, then its descendants breadth-first (the toolkit's search order)."""
        queue = [self]
        while queue:
            part = queue.pop(0)
            yield part
            queue.extend(part.children)


@dataclasses.dataclass(frozen=True)
class Pair:
    """A node pair that a builder may turn into a rod or a cable.

    Attributes:
        ends: the two nodes as (part, node name).
        tags: the pair's tags (for bonds, plus the two substructure names and ``a/b``).
        owner: the part whose file declared it (its name also matches builder tags).
        label: where it was declared, for messages.
    """

    ends: tuple[tuple[Part, str], tuple[Part, str]]
    tags: tuple[str, ...]
    owner: Part
    label: str


@dataclasses.dataclass(frozen=True)
class Builder:
    """A builder entry: pairs carrying all of ``tags`` are built as ``cls``.

    Attributes:
        tags: the tag search (space-separated in the file).
        cls: the toolkit's builder class name, e.g. ``tgRodInfo``.
        parameters: the parameters given in the file (file units).
        source: the file it came from.
    """

    tags: tuple[str, ...]
    cls: str
    parameters: dict[str, Any]
    source: str


@dataclasses.dataclass
class Tree:
    """A whole model: the top part, every pair and the builders in the order they were added."""

    top: Part
    pairs: list[Pair]
    builders: list[Builder]
    files: list[Path]


def _fail(source: Path, item: str, message: str) -> StructureError:
    return StructureError(message, item=item, source=str(source))


def _vector(value: Any, source: Path, item: str) -> np.ndarray:
    if not (isinstance(value, list) and len(value) == 3 and all(is_real(v) for v in value)):
        raise _fail(source, item, f"expected three finite numbers, got {describe(value)}")
    return np.array([float(v) for v in value])


def _number(value: Any, source: Path, item: str) -> float:
    if not is_real(value):
        raise _fail(source, item, f"expected a finite number, got {describe(value)}")
    return float(value)


def _mapping(value: Any, source: Path, item: str, keys: tuple[str, ...] | None = None
             ) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise _fail(source, item, f"expected a mapping, got {value!r}")
    unknown = [k for k in value if keys is not None and k not in keys]
    if unknown:
        raise _fail(source, item, f"unknown key {unknown[0]!r}; expected one of {list(keys or ())}")
    return {str(k): v for k, v in value.items()}


def _load(path: Path, parent: Path | None) -> dict[str, Any]:
    try:
        text = read_text(path)
    except OSError as err:
        where = str(parent) if parent else str(path)
        raise StructureError(f"cannot read structure file {str(path)!r}: {err.strerror or err}",
                             source=where) from None
    except InputError as err:  # names the file already
        raise StructureError(str(err)) from None
    try:
        data = load_yaml(text, str(path))  # refuses duplicate keys, as the toolkit does
    except InputError as err:
        raise StructureError(str(err)) from None
    return _mapping(data, path, "top level", _TOP_KEYS)


def read_tree(path: Path) -> Tree:
    """Reads ``path`` and every substructure file it names.

    Raises:
        StructureError: naming the file, the entry and what was expected.
    """
    builders = [Builder(("rod",), "tgRodInfo", {}, "default"),
                Builder(("string",), "tgBasicActuatorInfo", {}, "default"),
                Builder(("box",), "tgBoxInfo", {}, "default")]
    tree = Tree(Part("", "", path), [], builders, [])
    _read_part(tree, tree.top, path, chain=())
    return tree


def _read_part(tree: Tree, part: Part, path: Path, chain: tuple[Path, ...]) -> None:
    resolved = path.resolve()
    if resolved in chain:
        raise StructureError("substructure files include each other in a loop",
                             source=str(path))
    if len(tree.files) >= MAX_FILES:
        raise StructureError(f"more than {MAX_FILES} substructure files are read (counting "
                             "each time a file is used); the tree is too large", source=str(path))
    data = _load(path, chain[-1] if chain else None)
    tree.files.append(path)
    # the toolkit's order: substructures (and their builders), own builders, nodes, pairs, bonds
    for key, attrs in _mapping(data.get("substructures"), path, "substructures").items():
        if not isinstance(attrs, dict) or not isinstance(attrs.get("path"), str):
            raise _fail(path, f"substructures {key!r}", "expected a mapping with the 'path' "
                        f"of the substructure's file, got {describe(attrs)}")
        _add_children(tree, part, path, key, _mapping(attrs, path, f"substructures {key!r}",
                                                      _CHILD_KEYS), (*chain, resolved))
    for key, entry in _mapping(data.get("builders"), path, "builders").items():
        entry = _mapping(entry, path, f"builders {key!r}", ("class", "parameters"))
        if "class" not in entry:
            raise _fail(path, f"builders {key!r}", "no 'class' given (e.g. tgRodInfo)")
        if not isinstance(entry["class"], str):
            raise _fail(path, f"builders {key!r}", f"'class' must be a builder class name, got "
                        f"{describe(entry['class'])}")
        tree.builders.append(Builder(tuple(str(key).split()), entry["class"],
                                     _mapping(entry.get("parameters"), path,
                                              f"builders {key!r} parameters"), str(path)))
    for name, xyz in _mapping(data.get("nodes"), path, "nodes").items():
        part.nodes[name] = _vector(xyz, path, f"nodes {name!r}")
    for tags, pairs in _mapping(data.get("pair_groups"), path, "pair_groups").items():
        for a, b in _pair_list(pairs, path, f"pair_groups {tags!r}"):
            _add_pair(tree, part, (part, a), (part, b), tuple(tags.split()),
                      f"pair_groups {tags!r} [{a}, {b}]")
    for key, content in _mapping(data.get("bond_groups"), path, "bond_groups").items():
        for inner, pairs in _mapping(content, path, f"bond_groups {key!r}").items():
            bonds, tags = (key, inner) if "/" in key else (inner, key)
            if ("/" in key) == ("/" in inner):
                raise _fail(path, f"bond_groups {key!r} {inner!r}", "expected a tag and a bond "
                            "like 'a/b/node_node', one nested in the other")
            _add_bonds(tree, part, path, bonds, tags, pairs)


def _add_children(tree: Tree, part: Part, path: Path, key: str, attrs: dict[str, Any],
                  chain: tuple[Path, ...]) -> None:
    item = f"substructures {key!r}"
    if "path" not in attrs:
        raise _fail(path, item, "no 'path' to the substructure's file given")
    child_path = path.parent / str(attrs["path"])
    for index, name in enumerate(key.split("/")):
        if any(c.name == name for c in part.children):
            raise _fail(path, item, f"substructure name {name!r} is used twice")
        child = Part(name, f"{part.prefix}{name}/", child_path)
        part.children.append(child)
        _read_part(tree, child, child_path, chain)
        _transform(child, attrs, index, path, item)


def _transform(child: Part, attrs: dict[str, Any], index: int, path: Path, item: str) -> None:
    """Rotation, scale, offset x index, translation: the toolkit's order."""
    nodes = [p for part in child.walk() for p in part.nodes.values()]
    if not nodes:
        return

    def centroid() -> np.ndarray:
        return np.mean(nodes, axis=0)

    if attrs.get("rotation") is not None:
        rot = _mapping(attrs["rotation"], path, f"{item} rotation", _ROTATION_KEYS)
        axis = _vector(rot.get("axis"), path, f"{item} rotation axis")
        if not np.linalg.norm(axis) > 0 or "angle" not in rot:
            raise _fail(path, f"{item} rotation", "needs a non-zero 'axis' and an 'angle' [deg]")
        angle = _number(rot["angle"], path, f"{item} rotation angle")
        turn = Rotation.from_rotvec(axis / np.linalg.norm(axis) * math.radians(angle))
        ref = (_vector(rot["reference"], path, f"{item} rotation reference")
               if "reference" in rot else centroid())
        for p in nodes:
            p[:] = ref + turn.apply(p - ref)
    if attrs.get("scale") is not None:
        factor = _number(attrs["scale"], path, f"{item} scale")
        if not factor > 0:
            raise _fail(path, f"{item} scale", f"expected a factor > 0, got {attrs['scale']!r}")
        centre = centroid()
        for p in nodes:
            p[:] = centre + factor * (p - centre)
    shift = np.zeros(3)
    if attrs.get("offset") is not None:
        shift += index * _vector(attrs["offset"], path, f"{item} offset")
    if attrs.get("translation") is not None:
        shift += _vector(attrs["translation"], path, f"{item} translation")
    for p in nodes:
        p += shift


def _pair_list(pairs: Any, path: Path, item: str) -> list[tuple[str, str]]:
    if pairs is None:  # an empty group
        return []
    if not isinstance(pairs, list) or not all(isinstance(p, list) and len(p) == 2
                                              for p in pairs):
        raise _fail(path, item, f"expected a list of [node, node] pairs, got {pairs!r}")
    return [(str(a), str(b)) for a, b in pairs]


def _add_bonds(tree: Tree, part: Part, path: Path, bonds: str, tags: str, pairs: Any) -> None:
    item = f"bond_groups {bonds!r}"
    *names, kind = bonds.split("/")
    if kind == "node_edge":
        raise _fail(path, item, "node_edge bonds (which re-pose a substructure onto another) "
                    "are not supported; use node_node bonds")
    if kind != "node_node" or len(names) < 2:
        raise _fail(path, item, "expected 'a/b/node_node' (two or more substructures, then "
                    "the bond type)")
    for first, second in itertools.pairwise(names):
        one, two = _find_child(part, first, path, item), _find_child(part, second, path, item)
        for a, b in _pair_list(pairs, path, item):
            _add_pair(tree, part, (one, a), (two, b),
                      (*tags.split(), first, second, f"{first}/{second}"),
                      f"{item} {tags!r} [{a}, {b}]")


def _find_child(part: Part, name: str, path: Path, item: str) -> Part:
    for child in list(part.walk())[1:]:
        if child.name == name:
            return child
    raise _fail(path, item, f"no substructure {name!r}; substructures: "
                f"{[c.prefix.rstrip('/') for c in list(part.walk())[1:]]}")


def _find_node(part: Part, ref: str, path: Path, item: str) -> tuple[Part, str]:
    """The node ``ref`` (``node`` or ``child.node``) searched from ``part`` breadth-first."""
    *children, name = ref.split(".")
    target = part
    for child in children:
        target = _find_child(target, child, path, item)
    for candidate in target.walk():
        if name in candidate.nodes:
            return candidate, name
    raise _fail(path, item, f"unknown node {ref!r}; nodes here: {sorted(target.nodes)}")


def _add_pair(tree: Tree, owner: Part, a: tuple[Part, str], b: tuple[Part, str],
              tags: tuple[str, ...], label: str) -> None:
    ends = (_find_node(a[0], a[1], owner.source, label),
            _find_node(b[0], b[1], owner.source, label))
    if ends[0] == ends[1]:
        raise _fail(owner.source, label, "a pair needs two different nodes")
    for other in tree.pairs:
        if other.owner is owner and set(other.ends) == set(ends):
            raise _fail(owner.source, label, f"this pair is already declared ({other.label})")
    tree.pairs.append(Pair(ends, tags, owner, label))
