"""Reads the original toolkit's YAML structure files into flat, tagged nodes and node pairs.

This follows NTRTsim's ``yamlbuilder`` (``TensegrityModel.cpp``): a file has ``nodes`` (name:
[x, y, z]), ``pair_groups`` (tags: list of [node, node]), ``builders`` (tags: {class,
parameters}), ``substructures`` (name or ``a/b/c``: {path, rotation, scale, offset,
translation}) and ``bond_groups`` (pairs between substructures, ``a/b/node_node``, or
``a/b/node_edge``: see :mod:`tensim.io._ntrt_edge`). The substructures with a ``path`` are read
first; then every entry, with a path or without, turns the substructures it names about
``rotation.reference`` (default: the centroid), then every entry scales them about their
centroid, moves them by ``offset`` times their index in its ``a/b/c`` list, then by
``translation``. Everything stays in the file's units and frame here; :mod:`tensim.io.ntrt`
converts.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from tensim._input import InputError, describe, is_real, load_yaml, read_text
from tensim.io._ntrt_edge import add_node_edge
from tensim.io._ntrt_parts import Builder, Part, Tree, add_pair, fail, find_child, find_node
from tensim.structure import StructureError

MAX_FILES = 10_000  # most substructure files a model may read (each use counted)
_TOP_KEYS = ("nodes", "pair_groups", "builders", "substructures", "bond_groups")
_CHILD_KEYS = ("path", "rotation", "translation", "scale", "offset")
_ROTATION_KEYS = ("axis", "angle", "reference")


def _vector(value: Any, source: Path, item: str) -> np.ndarray:
    if not (isinstance(value, list) and len(value) == 3 and all(is_real(v) for v in value)):
        raise fail(source, item, f"expected three finite numbers, got {describe(value)}")
    return np.array([float(v) for v in value])


def _number(value: Any, source: Path, item: str) -> float:
    if not is_real(value):
        raise fail(source, item, f"expected a finite number, got {describe(value)}")
    return float(value)


def _mapping(value: Any, source: Path, item: str, keys: tuple[str, ...] | None = None
             ) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise fail(source, item, f"expected a mapping, got {describe(value)}"
                   + (" (line 1)" if item == "top level" else ""))
    unknown = [k for k in value if keys is not None and k not in keys]
    if unknown:
        raise fail(source, item, f"unknown key {unknown[0]!r}; expected one of {list(keys or ())}")
    return {str(k): v for k, v in value.items()}


def _load(path: Path, parent: Path | None, notes: list[str]) -> dict[str, Any]:
    try:
        text = read_text(path)
    except OSError as err:
        where = str(parent) if parent else str(path)
        raise StructureError(f"cannot read structure file {str(path)!r}: {err.strerror or err}",
                             source=where) from None
    except InputError as err:  # names the file already
        raise StructureError(str(err)) from None
    text = _as_toolkit_reads(text, path, notes)
    try:
        data = load_yaml(text, str(path))  # refuses duplicate keys, as the toolkit does
    except InputError as err:
        raise StructureError(str(err)) from None
    return _mapping(data, path, "top level", _TOP_KEYS)


def _as_toolkit_reads(text: str, path: Path, notes: list[str]) -> str:
    """The text as the toolkit's reader (yaml-cpp) takes it, in terms PyYAML reads alike.

    yaml-cpp takes a tab after a line's indentation as a space, and a ``%`` in the first column
    after some content as a directive that ends the document: the lines after it are a second
    document, which the toolkit never reads.
    """
    lines = text.splitlines()
    started = False
    for number, line in enumerate(lines):
        if line.startswith("%") and started:
            notes.append(f"{path.name} line {number + 1} starts with '%', which ends the YAML "
                         f"document for the toolkit's reader: its {len(lines) - number} last "
                         "line(s) were ignored, as the toolkit ignores them")
            lines = lines[:number]
            break
        started = started or (bool(line.strip()) and not line.lstrip().startswith("#"))
        indent = len(line) - len(line.lstrip(" \t"))  # a tab here is an error for both
        lines[number] = line[:indent] + line[indent:].replace("\t", " ")
    return "\n".join(lines) + "\n"


def read_tree(path: Path) -> Tree:
    """Reads ``path`` and every substructure file it names.

    Raises:
        StructureError: naming the file, the entry and what was expected.
    """
    builders = [Builder(("rod",), "tgRodInfo", {}, "default"),
                Builder(("string",), "tgBasicActuatorInfo", {}, "default"),
                Builder(("box",), "tgBoxInfo", {}, "default"),
                Builder(("sphere",), "tgSphereInfo", {}, "default")]
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
    data = _load(path, chain[-1] if chain else None, tree.notes)
    tree.files.append(path)
    # the toolkit's order: substructures (and their builders), own builders, nodes, pairs, bonds
    entries = {key: _mapping(attrs, path, f"substructures {key!r}", _CHILD_KEYS)
               for key, attrs in _mapping(data.get("substructures"), path,
                                          "substructures").items()}
    for key, attrs in entries.items():
        if "path" in attrs:
            _add_children(tree, part, path, key, attrs, (*chain, resolved))
    _transform_children(part, entries, path)
    for key, entry in _mapping(data.get("builders"), path, "builders").items():
        entry = _mapping(entry, path, f"builders {key!r}", ("class", "parameters"))
        if "class" not in entry:
            raise fail(path, f"builders {key!r}", "no 'class' given (e.g. tgRodInfo)")
        if not isinstance(entry["class"], str):
            raise fail(path, f"builders {key!r}", f"'class' must be a builder class name, got "
                       f"{describe(entry['class'])}")
        tree.builders.append(Builder(tuple(key.split()), entry["class"],
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
                raise fail(path, f"bond_groups {key!r} {inner!r}", "expected a tag and a bond "
                            "like 'a/b/node_node', one nested in the other")
            _add_bonds(tree, part, path, bonds, tags, pairs)


def _add_children(tree: Tree, part: Part, path: Path, key: str, attrs: dict[str, Any],
                  chain: tuple[Path, ...]) -> None:
    item = f"substructures {key!r}"
    if not isinstance(attrs["path"], str) or not attrs["path"]:
        raise fail(path, f"{item} path", f"expected a file path, got {attrs['path']!r}")
    child_path = path.parent / attrs["path"]
    for name in key.split("/"):
        if any(c.name == name for c in part.children):
            raise fail(path, item, f"substructure name {name!r} is used twice")
        child = Part(name, f"{part.prefix}{name}/", child_path)
        part.children.append(child)
        _read_part(tree, child, child_path, chain)


def _transform_children(part: Part, entries: dict[str, dict[str, Any]], path: Path) -> None:
    """Every entry's rotation, then every entry's scale, offset x index and translation.

    As the toolkit does, an entry transforms the substructures it names (searched breadth-first
    below ``part``) whether or not it has a ``path``: entries without one only transform.
    """
    named = {key: [find_child(part, name, path, f"substructures {key!r}")
                   for name in key.split("/")] for key in entries}
    for key, attrs in entries.items():
        if attrs.get("rotation") is not None:
            for child in named[key]:
                _rotate(child, attrs["rotation"], path, f"substructures {key!r} rotation")
    for key, attrs in entries.items():
        for index, child in enumerate(named[key]):
            _scale_and_move(child, attrs, index, path, f"substructures {key!r}")


def _positions(child: Part) -> list[np.ndarray]:
    return [p for part in child.walk() for p in part.nodes.values()]


def _rotate(child: Part, rotation: Any, path: Path, item: str) -> None:
    """Turns ``child`` by ``angle`` degrees about ``axis`` through ``reference`` (or its
    centroid)."""
    rot = _mapping(rotation, path, item, _ROTATION_KEYS)
    axis = _vector(rot.get("axis"), path, f"{item} axis")
    if not np.linalg.norm(axis) > 0 or "angle" not in rot:
        raise fail(path, item, "needs a non-zero 'axis' and an 'angle' [deg]")
    nodes = _positions(child)
    if not nodes:
        return
    angle = _number(rot["angle"], path, f"{item} angle")
    turn = Rotation.from_rotvec(axis / np.linalg.norm(axis) * math.radians(angle))
    ref = (_vector(rot["reference"], path, f"{item} reference") if "reference" in rot
           else np.mean(nodes, axis=0))
    for p in nodes:
        p[:] = ref + turn.apply(p - ref)


def _scale_and_move(child: Part, attrs: dict[str, Any], index: int, path: Path,
                    item: str) -> None:
    """Scale about the centroid, then offset x index, then translation: the toolkit's order."""
    nodes = _positions(child)
    if not nodes:
        return
    if attrs.get("scale") is not None:
        factor = _number(attrs["scale"], path, f"{item} scale")
        if not factor > 0:
            raise fail(path, f"{item} scale", f"expected a factor > 0, got {attrs['scale']!r}")
        centre = np.mean(nodes, axis=0)
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
        raise fail(path, item, f"expected a list of [node, node] pairs, got {pairs!r}")
    return [(str(a), str(b)) for a, b in pairs]


def _add_bonds(tree: Tree, part: Part, path: Path, bonds: str, tags: str, pairs: Any) -> None:
    item = f"bond_groups {bonds!r}"
    *names, kind = bonds.split("/")
    if kind not in ("node_node", "node_edge") or len(names) < 2:
        raise fail(path, item, "expected 'a/b/node_node' or 'a/b/node_edge' (two or more "
                    "substructures, then the bond type)")
    for first, second in itertools.pairwise(names):
        one, two = find_child(part, first, path, item), find_child(part, second, path, item)
        if kind == "node_edge":
            add_node_edge(tree, part, (one, two), tuple(tags.split()),
                          _pair_list(pairs, path, item), f"{item} {tags!r}")
            continue
        for a, b in _pair_list(pairs, path, item):
            _add_pair(tree, part, (one, a), (two, b),
                      (*tags.split(), first, second, f"{first}/{second}"),
                      f"{item} {tags!r} [{a}, {b}]")


def _add_pair(tree: Tree, owner: Part, a: tuple[Part, str], b: tuple[Part, str],
              tags: tuple[str, ...], label: str) -> None:
    ends = (find_node(a[0], a[1], owner.source, label),
            find_node(b[0], b[1], owner.source, label))
    add_pair(tree, owner, ends, tags, label)
