"""Imports a tensegrity robot's MuJoCo MJCF file as a tensim structure.

MuJoCo reads and compiles the file; the importer takes the compiled model at its reference
pose (``qpos0``):

- bodies with capsule and cylinder geoms become rods, their spheres end caps and point masses,
  with the body's mass and inertia kept (:mod:`tensim.io._mjcf_bodies`); a body without a joint
  is fixed to the world;
- the sites that spatial tendons pass through become nodes (sites between a tendon's ends,
  via nodes);
- each spatial tendon becomes a cable: its stiffness, damping and ``springlength`` (the upper
  end of a dead band is the rest length), its lower length limit a motor stop;
- each actuator on a tendon becomes the cable's motor as faithfully as tensim's motor allows
  (:mod:`tensim.io._mjcf_motors`), a tendon without one a passive cable;
- time step, gravity, friction, contact ``solref``, ``condim``, cone and no-slip iterations go
  into :class:`~tensim.model.WorldOptions` (:mod:`tensim.io._mjcf_world`).

What tensim does differently is listed in :attr:`MjcfImport.notes` and, per actuator, in
:attr:`ActuatorMapping.differences`; each is also issued as an :class:`MjcfImportWarning`.
What is not a tensegrity (joints other than free ones, nested bodies, meshes and other
shapes, fixed tendons, wrapping around geoms, actuators on joints) is refused with a
:class:`~tensim.structure.StructureError` naming the file and the element.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from collections.abc import Mapping
from pathlib import Path

import mujoco
import numpy as np

from tensim.io import _mjcf_bodies, _mjcf_read, _mjcf_world
from tensim.io._mjcf_motors import (
    NODE_SITE,
    USER_TEXT,
    ActuatorMapping,
    CommandMap,
    Spring,
    map_actuator,
)
from tensim.model import WorldOptions
from tensim.structure import (
    PASSIVE,
    Cable,
    RigidGroup,
    Structure,
    StructureError,
    mass_properties,
    save_structure,
)

__all__ = ["ActuatorMapping", "CommandMap", "MjcfImport", "MjcfImportWarning",
           "import_mjcf", "save_import", "stable_step"]


class MjcfImportWarning(UserWarning):
    """tensim represents part of an imported MJCF file differently (the message says how)."""


@dataclasses.dataclass(frozen=True)
class MjcfImport:
    """An imported MJCF model.

    Attributes:
        structure: the tensim structure.
        world: the file's world settings as tensim's world options.
        actuators: how each tendon actuator became a motor, in the file's order.
        notes: what was approximated, left out or chosen, one line each (the actuators'
            differences included).
        source: the file read.
        max_step: the longest physics step at which tensim's explicit step integrates the
            structure's stiffest mode [s] (:func:`stable_step`); run at half of it or less.
        node_frames: node name -> (the file's body id that carries it, (3,) its position in
            that body's frame [m]).
    """

    structure: Structure
    world: WorldOptions
    actuators: tuple[ActuatorMapping, ...]
    notes: tuple[str, ...]
    source: str
    max_step: float
    node_frames: Mapping[str, tuple[int, np.ndarray]] = dataclasses.field(default_factory=dict)

    def command_line(self) -> str:
        """The ``tensim simulate`` world options that reproduce the file's settings."""
        return _mjcf_world.command_line(self.world)

    def rest_lengths(self, controls: Mapping[str, float]) -> dict[str, float]:
        """The rest-length command [m] of every motorised cable whose actuator takes a target,
        for the file's controls (actuator name -> ctrl; the others keep their start): what a
        controller file's ``rest_lengths`` holds to do what those controls do.

        Raises:
            KeyError: a control names no actuator with a target (a rate, or no motor).
        """
        targets = {a.actuator: (a, a.command) for a in self.actuators
                   if a.command is not None and not a.command.rate}
        unknown = sorted(set(controls) - set(targets))
        if unknown:
            raise KeyError(f"{self.source}: no actuator {unknown[0]!r} whose control is a "
                           f"target; those are {sorted(targets)}")
        return {a.cable: command.offset + command.scale * controls[name]
                if name in controls else _start(a)
                for name, (a, command) in targets.items()}

    def header(self) -> list[str]:
        """Comment lines for the written structure file: the source, the run options, the
        actuator mappings and every note."""
        lines = [f"imported from {Path(self.source).name} by tensim import-mjcf",
                 f"run with: {self.command_line()}"]
        if math.isfinite(self.max_step):
            lines.append(f"stable below: {self.max_step:.3g} s (tensim's Euler step; run at "
                         "half of it or less)")
        for a in self.actuators:
            if a.command is not None:
                u = "rate of ctrl" if a.command.rate else "ctrl"
                what = "target-length" if a.motor.pd else "rest-length"
                lines.append(f"actuator {a.actuator!r} -> cable {a.cable!r} ({a.kind}): "
                             f"{what} command = {a.command.offset:.6g} + "
                             f"{a.command.scale:.6g} x {u} [m]")
        return lines + [f"note: {n}" for n in self.notes]


def _start(a: ActuatorMapping) -> float:
    """The command a cable starts with: a PD motor's target, else its rest length [m]."""
    return a.motor.pd_target if a.motor.pd_target is not None else a.rest_length


def import_mjcf(path: str | os.PathLike[str] | None = None, *, xml: str | None = None,
                name: str | None = None, warn: bool = True) -> MjcfImport:
    """Reads a tensegrity robot from an MJCF file (or ``xml`` text).

    Args:
        path: the MJCF file.
        xml: MJCF text instead of a file.
        name: the structure's name (default: the file's model name, else its stem).
        warn: issue each note as an :class:`MjcfImportWarning`.

    Raises:
        StructureError: MuJoCo cannot read the file, or it holds something that is not a
            tensegrity (the message names the file and the element).
        FileNotFoundError: no such file.
    """
    if (path is None) == (xml is None):
        raise ValueError("give exactly one of path or xml")
    f = _mjcf_read.load(path, xml)
    world, contact, notes = _mjcf_world.world(f)
    used = _used_sites(f)
    bodies = _mjcf_bodies.convert(f, used, contact)
    notes += bodies.notes
    cables, actuators = _cables(f, bodies.site_node, notes,
                                {n.name: np.asarray(n.position) for n in bodies.nodes})
    if f.model.nkey:
        key = f.name(mujoco.mjtObj.mjOBJ_KEY, 0, "#0")
        notes.append(f"the rest lengths start at the controls of keyframe {key!r}; the build "
                     "pose is the bodies' own (qpos0), not the keyframe's")
    title = name or f.model.names[:f.model.names.index(b"\0")].decode() or \
        (Path(path).stem if path is not None else "mjcf")
    try:
        structure = Structure(title, tuple(bodies.nodes), tuple(bodies.rods), tuple(cables),
                              tuple(bodies.point_masses))
    except StructureError as err:
        raise err.with_source(f.source) from None
    thin = [g.name for g in structure.rigid_groups() if not g.fixed and _thin(structure, g,
                                                                             world)]
    if thin:
        notes.append(f"bodies {thin} are thin rods: tensim's compiler raises their axial "
                     f"inertia to {world.min_inertia_ratio:g} of their transverse one "
                     "(WorldOptions.min_inertia_ratio; 0 keeps the file's)")
    step = stable_step(structure)
    if world.timestep > step / 2:
        from tensim.design.check import nice_step

        notes.append(f"tensim's cable law is explicit (Euler): its stiffest mode needs a step "
                     f"below {step:.3g} s to stay stable and below half that to damp right, so "
                     f"the file's {world.timestep:g} s does not hold it; run with --dt "
                     f"{nice_step(step / 2):g}")
    for field, default in (("gravity", (0.0, 0.0, -9.81)), ("contact_timeconst", 0.02)):
        if getattr(world, field) != default:
            notes.append(f"{field} {getattr(world, field)} has no command-line option: "
                         f"WorldOptions({field}=...) from Python (import_mjcf(...).world)")
    notes = list(dict.fromkeys(notes))
    if warn:
        for note in notes:
            warnings.warn(f"{f.source}: {note}", MjcfImportWarning, stacklevel=2)
    frames = {}
    for node, body in bodies.node_body.items():
        rotation = f.data.xmat[body].reshape(3, 3)
        frames[node] = (body, rotation.T @ (structure.position(node) - f.data.xpos[body]))
    return MjcfImport(structure, world, tuple(actuators), tuple(notes), f.source, step, frames)


def save_import(result: MjcfImport, path: str | os.PathLike[str]) -> Path:
    """Writes the structure as YAML with :meth:`MjcfImport.header` as comments; returns the
    path."""
    path = Path(path)
    save_structure(result.structure, path, header=result.header())
    return path


def _used_sites(f: _mjcf_read.Loaded) -> set[int]:
    """The sites tendons pass through (and, in tensim's own export, its node sites)."""
    m = f.model
    used = {int(m.wrap_objid[k]) for t in range(m.ntendon)
            for k in range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t])}
    if f.spec.text(USER_TEXT) is not None:
        used |= {s for s in range(m.nsite) if m.site(s).name.startswith(NODE_SITE)}
    return used


def _spring(f: _mjcf_read.Loaded, t: int, name: str, notes: list[str]) -> Spring:
    m = f.model
    low, high = (float(v) for v in m.tendon_lengthspring[t])
    if low > 0 and m.tendon_stiffness[t] > 0:
        notes.append(f"tendon {name!r}: its spring also pushes below {low:g} m (the low end "
                     "of its springlength); tensim's cable is slack below its rest length")
    extra = {"stiffnesspoly": m.tendon_stiffnesspoly[t], "dampingpoly": m.tendon_dampingpoly[t],
             "frictionloss": m.tendon_frictionloss[t], "armature": m.tendon_armature[t],
             "springyield": m.tendon_springyield[t]}
    for key, value in extra.items():
        if np.any(value):
            notes.append(f"tendon {name!r}: {key} {np.round(value, 6).tolist()} is not carried "
                         "(tensim's cable is linear in stretch and stretch rate)")
    if m.tendon_limited[t] and math.isfinite(m.tendon_range[t][1]):
        notes.append(f"tendon {name!r}: its upper length limit {m.tendon_range[t][1]:g} m is "
                     "not carried (tensim's cables have no length stop); the lower one stops "
                     "the motor")
    if m.tendon_damping[t] > 0:
        notes.append("MuJoCo damps a tendon whether taut or slack; tensim's cable damps only "
                     "while taut")
    return Spring(float(m.tendon_stiffness[t]), float(m.tendon_damping[t]), (low, high),
                  float(f.data.ten_length[t]), t)


def _cables(f: _mjcf_read.Loaded, site_node: dict[int, str], notes: list[str],
            positions: dict[str, np.ndarray]) -> tuple[list[Cable], list[ActuatorMapping]]:
    m = f.model
    anchored: list[str] = []  # the tendons anchored off their nodes
    drives: dict[int, list[int]] = {}
    for a in range(m.nu):
        drives.setdefault(int(m.actuator_trnid[a][0]), []).append(a)
    cables, mappings = [], []
    differences: dict[str, list[str]] = {}  # what differs -> the actuators it concerns
    for t in range(m.ntendon):
        name = f.name(mujoco.mjtObj.mjOBJ_TENDON, t, f"tendon{t}")
        path = [site_node[int(m.wrap_objid[k])]
                for k in range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t])]
        spring = _spring(f, t, name, notes)
        acts = drives.get(t, [])
        if len(acts) > 1:
            names = [f.name(mujoco.mjtObj.mjOBJ_ACTUATOR, a, f"#{a}") for a in acts]
            raise f.refuse(f"tendon {name!r}", f"is driven by {len(acts)} actuators {names}: "
                           "a tensim cable has one motor")
        if acts:
            mapping = map_actuator(f, acts[0], name, spring)
            mappings.append(mapping)
            for text in mapping.differences:
                differences.setdefault(text, []).append(mapping.actuator)
            k, b, rest, motor = mapping.stiffness, mapping.damping, mapping.rest_length, \
                mapping.motor
        else:
            if spring.stiffness <= 0:
                raise f.refuse(f"tendon {name!r}", "has no spring (stiffness 0) and no "
                               "actuator: a tensim cable needs a stiffness [N/m]")
            k, b, rest, motor = spring.stiffness, spring.damping, spring.dead_band[1], PASSIVE
        item = f"tendon {name!r}"
        if len(set(path)) < len(path):
            raise f.refuse(item, f"passes a node twice ({path}): its sites sit on one rod end")
        offset = _anchor_offset(positions, path, spring.length)
        if offset > 0:
            anchored.append(name)
        try:
            cables.append(Cable(name, (path[0], path[-1]), k, damping=b, rest_length=rest,
                                motor=motor, via=tuple(path[1:-1]), anchor_offset=offset))
        except StructureError as err:
            raise f.refuse(item, err.detail) from None
    if anchored:
        notes.append(f"tendons {anchored}: their sites sit off the nodes they were moved to; "
                     "each cable anchors anchor_offset from its nodes toward each other, so "
                     "that its length in the build pose is the file's (its direction is the "
                     "nodes', not the sites')")
    for text, names in differences.items():
        who = f"actuator {names[0]!r}" if len(names) == 1 else \
            f"actuators {', '.join(map(repr, names))}"
        notes.append(f"{who}: {text}")
    return cables, mappings


def _anchor_offset(positions: dict[str, np.ndarray], path: list[str], length: float) -> float:
    """The anchor offset [m] that gives a two-site tendon whose sites were moved onto nodes
    the file's length ``length`` [m] between its anchors: half of what the move added, where
    it added more than 1e-6 m (0 for a tendon through via nodes, or one the move shortened:
    a cable's anchors only move inward)."""
    if len(path) != 2:
        return 0.0
    added = float(np.linalg.norm(positions[path[0]] - positions[path[1]])) - length
    return added / 2 if added > 1e-6 else 0.0


def stable_step(structure: Structure) -> float:
    """The longest physics step at which tensim's explicit (Euler) step integrates every mode
    of the structure's cables and bodies at its build pose [s] (the modal criterion of
    :func:`tensim.design.stable_timestep`; inf where nothing springs or the analysis does not
    apply)."""
    from tensim.design import stable_timestep, stiffness
    from tensim.design.check import MAX_DOF

    free = sum(not g.fixed for g in structure.rigid_groups())
    if not structure.cables or 6 * free > MAX_DOF:  # the dense eigenproblem's bound
        return math.inf
    return float(stable_timestep(stiffness(structure, count=False))[0])


def _thin(structure: Structure, group: RigidGroup, world: WorldOptions) -> bool:
    moments = mass_properties(structure, group).principal_moments()
    return bool(moments[0] < world.min_inertia_ratio * moments[-1])
