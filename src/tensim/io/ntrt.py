"""Imports the original toolkit's (NTRTsim's) YAML structure files as tensim structures.

The toolkit's files carry no units: its models use kilograms and seconds with metres,
decimetres or centimetres (the gravity the application set tells which: 9.81, 98.1 or
981). With ``s`` metres per file unit, positions, radii, lengths and speeds scale by ``s``,
forces (pretension, max_tension, in kg x unit/s^2) by ``s``, densities (kg/unit^3) by
``1/s^3``; stiffness (kg/s^2 = N/m) and damping (kg/s = N s/m) keep their numbers. Its frame
is Y-up; tensim's is Z-up, so (x, y, z) becomes (x, -z, y) (a quarter turn about x).

Pairs are built as the toolkit builds them: the most recently declared builder whose tags the
pair carries wins, rod builders before cable builders; a substructure's name counts as a tag
of its own pairs. Nodes whose names carry a sphere builder's tags become spheres (point
masses). Rods that share a node form one rigid body, and nodes that coincide are merged (the
toolkit compounds bodies that touch). Each cable's anchors sit on its line, as far in as makes
its length the toolkit's (whose anchors sit on the body surfaces beside the nodes). What tensim
cannot represent is approximated and listed in :attr:`NtrtImport.notes`.
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from tensim._input import is_real
from tensim.io._ntrt_anchor import Rigid, anchor
from tensim.io._ntrt_parts import Builder, Pair, Part
from tensim.io._ntrt_tree import read_tree
from tensim.structure import (
    Cable,
    CableContact,
    Motor,
    Node,
    PointMass,
    Rod,
    Structure,
    StructureError,
    mass_properties,
)

UNITS = {"m": 1.0, "dm": 0.1, "cm": 0.01, "mm": 0.001}  # metres per file unit
_FRAMES = {"y": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
           "z": np.eye(3)}
_MERGE_TOL = 1e-9  # m: nodes closer than this are one node
_DEFAULT_STEP = 1e-3  # s: tensim's default physics step (WorldOptions.timestep)
_STATIC_DENSITY = 1e-3  # kg/m^3: a nominal density for the toolkit's massless (static) rods
_STATIC_TAG = "massless"  # tags the rods the file gave density 0

# builder class -> parameter defaults (TensegrityModel.h), in file units
_ROD = {"radius": 0.5, "density": 1.0, "friction": 1.0, "roll_friction": 0.0,
        "restitution": 0.2}
_BOX = {"width": 1.0, "height": 1.0, "density": 1.0, "friction": 1.0, "roll_friction": 0.0,
        "restitution": 0.2}
_CABLE = {"stiffness": 1000.0, "damping": 10.0, "pretension": 0.0, "history": 0.0,
          "max_tension": 1000.0, "target_velocity": 100.0, "min_actual_length": 0.1,
          "min_rest_length": 0.1, "rotation": 0.0}
_BASIC = {**_CABLE, "moveCablePointAToEdge": True, "moveCablePointBToEdge": True}
_KINEMATIC = {**_CABLE, "radius": 1.0, "motor_friction": 0.0, "motor_inertia": 1.0,
              "back_drivable": 0.0}
_SPHERE = {"radius": 0.5, "density": 1.0, "friction": 1.0, "roll_friction": 0.0,
           "restitution": 0.2}
_CLASSES = {"tgRodInfo": _ROD, "tgBoxInfo": _BOX, "tgSphereInfo": _SPHERE,
            "tgBasicActuatorInfo": _BASIC, "tgBasicContactCableInfo": _BASIC,
            "tgKinematicActuatorInfo": _KINEMATIC, "tgKinematicContactCableInfo": _KINEMATIC}
_RIGID = ("tgRodInfo", "tgBoxInfo")  # the rigid builders that build pairs (spheres: nodes)
_WIRES = ("tgBasicActuatorInfo", "tgBasicContactCableInfo", "tgKinematicActuatorInfo",
          "tgKinematicContactCableInfo")


@dataclasses.dataclass(frozen=True)
class NtrtImport:
    """An imported model.

    Attributes:
        structure: the tensim structure (SI units, Z up).
        notes: what was approximated or left out, one line each.
        files: the files read (the top file, then its substructures').
        max_step: the longest physics step at which its cable damping stays stable [s]
            (:func:`damping_step`).
    """

    structure: Structure
    notes: tuple[str, ...]
    files: tuple[str, ...]
    max_step: float = math.inf


def import_ntrt(path: str | os.PathLike[str], units: str, *, up: str = "y",
                clearance: float | None = None, name: str | None = None) -> NtrtImport:
    """Reads an NTRTsim YAML structure file (and its substructure files).

    Args:
        path: the top file.
        units: the file's length unit: ``"m"``, ``"dm"``, ``"cm"`` or ``"mm"``.
        up: the file's up axis, ``"y"`` (the toolkit's) or ``"z"``.
        clearance: if given, lift or lower the model so its lowest rod or sphere surface is this far
            above the ground [m]; None keeps the file's positions.
        name: the structure's name (default: the file's stem).

    Raises:
        StructureError: naming the file, the entry and what was expected.
        ValueError: an unknown unit or up axis.
    """
    if units not in UNITS:
        raise ValueError(f"unknown units {units!r}; expected one of {list(UNITS)}")
    if up not in _FRAMES:
        raise ValueError(f"unknown up axis {up!r}; expected 'y' or 'z'")
    if clearance is not None and not (is_real(clearance) and clearance >= 0):
        raise ValueError(f"clearance must be a finite distance >= 0 m, got {clearance!r}")
    path = Path(path)
    tree = read_tree(path)
    converter = _Converter(UNITS[units], _FRAMES[up], str(path))
    for builder in tree.builders:
        converter.check(builder)
    structure = converter.build(tree.top, tree.pairs, tree.builders, name or path.stem, clearance)
    step = damping_step(structure)
    if step < _DEFAULT_STEP:
        converter.notes.append(f"explicit cable damping needs a physics step below {step:.2g} s "
                               f"(2 m / sum of b of the lightest body): simulate with --dt "
                               f"{step:.1g} or less")
    notes = tuple(dict.fromkeys((*tree.notes, *converter.notes)))  # a part read twice notes once
    return NtrtImport(structure, notes, tuple(str(f) for f in tree.files), step)


def damping_step(structure: Structure) -> float:
    """The longest physics step at which the cables' damping stays stable [s].

    Cable forces are applied explicitly, and an explicit step of a mass m held by dampers of
    total b (N s/m) diverges once it exceeds 2 m / b; this is that bound for the free rigid
    body where it is smallest (inf if no cable damps a free body).
    """
    step = math.inf
    for group in structure.rigid_groups():
        damping = sum(c.damping for c in structure.cables if set(c.path) & set(group.nodes))
        if not group.fixed and damping > 0:
            step = min(step, 2 * mass_properties(structure, group).mass / damping)
    return step


def _matching(pair: Pair, builders: list[Builder]) -> Builder | None:
    """The toolkit's choice: the latest rod builder whose tags the pair has, else cable."""
    tags = set(pair.tags) | ({pair.owner.name} if pair.owner.name else set())
    for kinds in (_RIGID, _WIRES):
        for builder in reversed(builders):
            if builder.cls in kinds and set(builder.tags) <= tags:
                return builder
    return None


def _sphere_builder(part: Part, node: str, builders: list[Builder]) -> Builder | None:
    """The latest sphere builder whose tags the node's name (and its substructure's) carries:
    the toolkit makes a sphere of every such node."""
    tags = set(node.split()) | ({part.name} if part.name else set())
    return next((b for b in reversed(builders)
                 if b.cls == "tgSphereInfo" and set(b.tags) <= tags), None)


class _Converter:
    """Turns the file tree into tensim records, in SI units and tensim's frame."""

    def __init__(self, scale: float, frame: np.ndarray, source: str):
        self.scale, self.frame, self.source = scale, frame, source
        self.notes: list[str] = []

    def _note(self, line: str) -> None:
        if line not in self.notes:
            self.notes.append(line)

    def check(self, builder: Builder) -> None:
        """Refuses unknown classes and parameters, as the toolkit does."""
        item = f"builders {' '.join(builder.tags)!r}"
        if builder.cls not in _CLASSES:
            raise StructureError(f"unsupported builder class {builder.cls!r}; supported: "
                                 f"{list(_CLASSES)}", item=item, source=builder.source)
        known = _CLASSES[builder.cls]
        for key, value in builder.parameters.items():
            if key not in known:
                raise StructureError(f"unsupported {builder.cls} parameter {key!r}; expected "
                                     f"one of {list(known)}", item=item, source=builder.source)
            if isinstance(known[key], bool):
                if not isinstance(value, bool):
                    raise StructureError(f"parameter {key!r} must be true or false, got "
                                         f"{value!r}", item=item, source=builder.source)
            elif not is_real(value):
                raise StructureError(f"parameter {key!r} must be a number, got {value!r}",
                                     item=item, source=builder.source)

    def _params(self, builder: Builder) -> dict[str, Any]:
        """The builder's parameters over the toolkit's defaults (file units)."""
        return {**_CLASSES[builder.cls], **builder.parameters}

    def build(self, top: Part, pairs: list[Pair], builders: list[Builder], name: str,
              clearance: float | None) -> Structure:
        """The structure: merged nodes, built pairs, placed above the ground if asked."""
        position, canonical = self._nodes(top)
        spheres = self._spheres(top, builders, canonical)
        rods, cables = self._members(pairs, builders, canonical, position, spheres)
        rigid = {n for r in rods for n in r.nodes} | {m.node for m in spheres}
        for cable in cables:
            for end in cable.nodes:
                if end not in rigid:
                    raise StructureError(f"node {end!r} ends a cable but no rod or sphere: the "
                                         "toolkit attaches cables to rigid bodies only",
                                         item=f"cable {cable.name!r}", source=self.source)
        if clearance is not None:
            lowest = min([min(position[n][2] for n in r.nodes) - r.radius for r in rods]
                         + [position[m.node][2] - m.radius for m in spheres])
            lift = np.array([0.0, 0.0, clearance - lowest])
            position = {n: p + lift for n, p in position.items()}
        used = rigid | {n for c in cables for n in c.nodes}
        if len(used) < len(position):
            self._note(f"{len(position) - len(used)} node(s) on no rod, sphere or cable were "
                       "left out")
        nodes = tuple(Node(n, tuple(p), tags=_node_tags(n)) for n, p in position.items()
                      if n in used)
        try:
            return _fix_static(Structure(name, nodes, tuple(rods), tuple(cables),
                                         tuple(spheres)))
        except StructureError as err:
            raise err.with_source(self.source) from None

    def _spheres(self, top: Part, builders: list[Builder], canonical: dict[str, str]
                 ) -> list[PointMass]:
        """The toolkit's spheres (``tgSphereInfo``) as point masses: solid spheres at nodes.

        Spheres at one place are one body (the toolkit compounds them): masses add, the
        largest radius stays.
        """
        found: dict[str, list[tuple[float, float]]] = {}
        for part in top.walk():
            for node in part.nodes:
                builder = _sphere_builder(part, node, builders)
                if builder is not None:
                    p = self._params(builder)
                    mass = p["density"] * 4.0 / 3.0 * math.pi * p["radius"] ** 3  # kg
                    found.setdefault(canonical[_full(part, node)], []).append(
                        (mass, p["radius"] * self.scale))
        if found:
            self._note("spheres are point masses (solid spheres) at their node; their "
                       "friction, rolling friction and restitution are not modelled")
        if any(len(v) > 1 for v in found.values()):
            self._note("spheres at one place were joined into one (masses added)")
        try:
            return [PointMass(n, sum(m for m, _ in v), max(r for _, r in v))
                    for n, v in found.items()]
        except StructureError as err:
            raise err.with_source(self.source) from None

    def _members(self, pairs: list[Pair], builders: list[Builder], canonical: dict[str, str],
                 position: dict[str, np.ndarray], spheres: list[PointMass]
                 ) -> tuple[list[Rod], list[Cable]]:
        """Rods and cables from the pairs, each built by the builder the toolkit would pick."""
        rods: list[Rod] = []
        bodies: dict[str, list[Rigid]] = {m.node: [Rigid(np.array([position[m.node]] * 2),
                                                         m.radius, sphere=True)]
                                          for m in spheres}
        wires: list[tuple[Pair, Builder, tuple[str, str]]] = []
        counts: dict[str, int] = {}
        unbuilt = []
        for pair in pairs:
            ends = (canonical[_full(*pair.ends[0])], canonical[_full(*pair.ends[1])])
            if ends[0] == ends[1]:
                raise StructureError("its two nodes coincide", item=pair.label,
                                     source=str(pair.owner.source))
            builder = _matching(pair, builders)
            if builder is None:
                unbuilt.append(" ".join(pair.tags))
            elif builder.cls in _RIGID:
                rods.append(self._rod(_unique_name(pair, counts), ends, pair, builder))
                body = Rigid(np.array([position[n] for n in ends]), self._surface(builder))
                for node in ends:
                    bodies.setdefault(node, []).append(body)
            else:
                wires.append((pair, builder, ends))
        if unbuilt:
            self._note(f"{len(unbuilt)} pair(s) match no builder and were left out (tags: "
                       f"{sorted(set(unbuilt))})")
        if not rods and not spheres:
            raise StructureError("no pair is built as a rod and no node as a sphere; expected "
                                 "a tgRodInfo builder matching some pair_groups tags",
                                 source=self.source)
        return rods, [self._cable(_unique_name(p, counts), ends, p, b, position, bodies)
                      for p, b, ends in wires]

    def _surface(self, builder: Builder) -> float:
        """How far the toolkit moves a cable's anchor off a rod's axis [m]."""
        p = self._params(builder)
        return (p["width"] if builder.cls == "tgBoxInfo" else p["radius"]) * self.scale

    def _nodes(self, top: Part) -> tuple[dict[str, np.ndarray], dict[str, str]]:
        """SI positions of the distinct nodes, and every node's name -> its merged name."""
        position: dict[str, np.ndarray] = {}
        canonical: dict[str, str] = {}
        for part in top.walk():
            for node, p in part.nodes.items():
                full, si = _full(part, node), self.frame @ (p * self.scale)
                same = next((n for n, q in position.items()
                             if np.linalg.norm(q - si) < _MERGE_TOL), None)
                if same is None:
                    position[full] = si
                canonical[full] = same or full
        merged = len(canonical) - len(position)
        if merged:
            self._note(f"{merged} node(s) coincide with another and were merged into it")
        return position, canonical

    def _rod(self, name: str, ends: tuple[str, str], pair: Pair, builder: Builder) -> Rod:
        """A rod (or a box as a rod) in SI: radius x s, density / s^3."""
        p, s = self._params(builder), self.scale
        if p["roll_friction"]:
            self._note("roll_friction is ignored (no rolling friction on rods)")
        radius = p.get("radius", 0.0) * s
        if builder.cls == "tgBoxInfo":
            self._note("boxes are approximated as rods of the same cross-section area "
                       "(same mass) and round section")
            radius = float(np.sqrt(p["width"] * p["height"] / np.pi)) * s
        density = p["density"] / s**3
        if density == 0:
            self._note(f"rods of density 0 (massless in the toolkit) get {_STATIC_DENSITY} "
                       "kg/m^3; a rigid body made only of them is fixed to the world, as the "
                       "toolkit makes a massless body static")
            density, tags = _STATIC_DENSITY, (*_record_tags(pair), _STATIC_TAG)
        else:
            tags = _record_tags(pair)
        try:
            return Rod(name, ends, radius, density=density,
                       friction=p["friction"], restitution=p["restitution"], tags=tags)
        except StructureError as err:
            raise StructureError(err.detail, item=f"{err.item} ({pair.label})",
                                 source=str(pair.owner.source)) from None

    def _cable(self, name: str, ends: tuple[str, str], pair: Pair, builder: Builder,
               position: dict[str, np.ndarray], bodies: dict[str, list[Rigid]]) -> Cable:
        """A cable in SI: forces, lengths and speeds x s; stiffness and damping as they are."""
        p, s = self._params(builder), self.scale
        contact = "Contact" in builder.cls
        if contact:
            self._note("contact cables become tensim contact cables (contact: true): they "
                       "touch the ground and obstacles; cable-rod contact is not modelled")
        if builder.cls.startswith("tgKinematic"):
            self._note("kinematic actuators' motor dynamics (radius, friction, inertia, back "
                       "drive) are not modelled: the motor is a rate-limited rest length")
        # the toolkit moves each anchor onto the body's surface beside the node; tensim's sit
        # on the cable's line, as far in as gives the toolkit's length (so its rest length)
        a, b = (position[n] for n in ends)
        moved = (p["moveCablePointAToEdge"], p["moveCablePointBToEdge"]) \
            if builder.cls == "tgBasicActuatorInfo" else (True, True)  # the others always move
        tips = [anchor(x, y, bodies.get(n, []) if move else [], p["rotation"])
                for x, y, n, move in ((a, b, ends[0], moved[0]), (b, a, ends[1], moved[1]))]
        offset = (np.linalg.norm(a - b) - np.linalg.norm(tips[0] - tips[1])) / 2
        if offset < 0:
            self._note("cables whose toolkit anchors lie farther apart than their nodes are "
                       "anchored at their nodes: at the same pretension, a shorter rest length")
        motor = Motor(max_speed=p["target_velocity"] * s, max_tension=p["max_tension"] * s,
                      min_rest_length=p["min_rest_length"] * s,
                      min_length=p["min_actual_length"] * s)
        try:
            return Cable(name, ends, p["stiffness"], damping=p["damping"],
                         pretension=p["pretension"] * s,
                         anchor_offset=max(float(offset), 0.0),
                         motor=motor, tags=_record_tags(pair),
                         contact=CableContact() if contact else None)
        except StructureError as err:
            raise StructureError(err.detail, item=f"{err.item} ({pair.label})",
                                 source=str(pair.owner.source)) from None


def _fix_static(structure: Structure) -> Structure:
    """Fixes to the world every rigid body whose rods all had density 0 (and no sphere)."""
    static = {r.name for r in structure.rods if _STATIC_TAG in r.tags}
    spheres = {m.node for m in structure.point_masses}
    fixed = {n for g in structure.rigid_groups() if g.rods and set(g.rods) <= static
             and not set(g.nodes) & spheres for n in g.nodes}
    if not fixed:
        return structure
    nodes = tuple(dataclasses.replace(n, fixed=True) if n.name in fixed else n
                  for n in structure.nodes)
    return dataclasses.replace(structure, nodes=nodes)


def _full(part: Part, node: str) -> str:
    """A node's tensim name: its substructure path and its name, e.g. ``t1/front``."""
    return f"{part.prefix}{node}"


def _node_tags(name: str) -> tuple[str, ...]:
    return (name.rsplit("/", 1)[0],) if "/" in name else ()


def _record_tags(pair: Pair) -> tuple[str, ...]:
    where = (pair.owner.prefix.rstrip("/"),) if pair.owner.prefix else ()
    return tuple(dict.fromkeys((*pair.tags, *where)))


def _unique_name(pair: Pair, counts: dict[str, int]) -> str:
    """``<substructure path>/<first tag>_<k>``, k counting the pairs with that stem."""
    stem = pair.owner.prefix + "_".join(pair.tags[:1] or ("pair",))
    counts[stem] = counts.get(stem, -1) + 1
    return f"{stem}_{counts[stem]}"
