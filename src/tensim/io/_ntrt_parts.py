"""The parts of an original-toolkit (NTRTsim) model as its YAML builder holds them.

A :class:`Part` is one structure of the file tree (the top file or a substructure) with its
nodes in file units; :class:`Pair` is a node pair that a builder may turn into a rod or a cable;
the helpers find children and nodes breadth-first, as the toolkit's ``tgStructure`` does.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from tensim.structure import StructureError

RIGID_CLASSES = ("tgRodInfo", "tgBoxInfo", "tgSphereInfo")  # the builders of rigid bodies


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
    """A builder entry: pairs (for spheres: nodes) carrying all of ``tags`` are built as ``cls``.

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
    """A whole model: the top part, every pair and the builders in the order they were added,
    the files read and what the reader noted (lines the toolkit's reader ignores)."""

    top: Part
    pairs: list[Pair]
    builders: list[Builder]
    files: list[Path]
    notes: list[str] = dataclasses.field(default_factory=list)


def fail(source: Path, item: str, message: str) -> StructureError:
    """An error naming the file and the entry."""
    return StructureError(message, item=item, source=str(source))


def find_child(part: Part, name: str, path: Path, item: str) -> Part:
    """The substructure called ``name`` below ``part``, the first found breadth-first."""
    for child in list(part.walk())[1:]:
        if child.name == name:
            return child
    raise fail(path, item, f"no substructure {name!r}; substructures: "
               f"{[c.prefix.rstrip('/') for c in list(part.walk())[1:]]}")


def find_node(part: Part, ref: str, path: Path, item: str) -> tuple[Part, str]:
    """The node ``ref`` (``node`` or ``child.node``) searched from ``part`` breadth-first."""
    *children, name = ref.split(".")
    target = part
    for child in children:
        target = find_child(target, child, path, item)
    for candidate in target.walk():
        if name in candidate.nodes:
            return candidate, name
    raise fail(path, item, f"unknown node {ref!r}; nodes here: {sorted(target.nodes)}")


def position(end: tuple[Part, str]) -> np.ndarray:
    """A node's current position (file units)."""
    return end[0].nodes[end[1]]


def same_pair(one: Pair, ends: tuple[tuple[Part, str], tuple[Part, str]]) -> bool:
    """The toolkit's pair equality: the same start and end positions, in that direction."""
    return all(np.array_equal(position(a), position(b))
               for a, b in zip(one.ends, ends, strict=True))


def add_pair(tree: Tree, owner: Part, ends: tuple[tuple[Part, str], tuple[Part, str]],
             tags: tuple[str, ...], label: str) -> None:
    """Adds a pair of found nodes to ``owner``, refused (as the toolkit does) if ``owner``
    already has one from the same place to the same place (the reverse is another pair)."""
    if ends[0] == ends[1]:
        raise fail(owner.source, label, "a pair needs two different nodes")
    for other in tree.pairs:
        if other.owner is owner and same_pair(other, ends):
            raise fail(owner.source, label, f"this pair is already declared ({other.label})")
    tree.pairs.append(Pair(ends, tags, owner, label))
