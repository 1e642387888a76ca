"""Carries an MJCF file's world and contact settings into tensim's :class:`WorldOptions` and
rods, and names what has no home there.

Contacts between a robot geom and the file's ground plane are mixed as MuJoCo mixes them: the
geom of higher ``priority`` gives its parameters; at equal priority friction and ``condim``
take the larger and ``solref``/``solimp`` the ``solmix``-weighted mean. Each rod keeps its
sliding friction and, from the contact's damping ratio, its restitution; the time constant,
``condim`` and torsional and rolling friction are one setting of the world in tensim.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import mujoco
import numpy as np

from tensim.io._mjcf_read import GEOM, SHAPES, Loaded, kind_name
from tensim.model import WorldOptions

_SOLIMP = np.array([0.9, 0.95, 0.001, 0.5, 2.0])  # MuJoCo's default, which tensim uses
_CONES = {mujoco.mjtCone.mjCONE_PYRAMIDAL: "pyramidal", mujoco.mjtCone.mjCONE_ELLIPTIC: "elliptic"}


@dataclasses.dataclass(frozen=True)
class Contact:
    """One geom's contact with the ground, mixed as MuJoCo mixes it."""

    friction: np.ndarray  # (3,) sliding [-], torsional [m], rolling [m]
    solref: np.ndarray  # (2,) time constant [s], damping ratio [-]
    solimp: np.ndarray  # (5,)
    condim: int


def restitution(dampratio: float) -> float:
    """The coefficient of restitution of MuJoCo's contact spring with this damping ratio (the
    inverse of :func:`tensim.terrain.restitution_dampratio`)."""
    if dampratio >= 1:
        return 0.0
    return math.exp(-math.pi * dampratio / math.sqrt(1.0 - dampratio**2))


def _mix(m: mujoco.MjModel, g: int, ground: int | None) -> Contact:
    own = Contact(m.geom_friction[g].copy(), m.geom_solref[g].copy(), m.geom_solimp[g].copy(),
                  int(m.geom_condim[g]))
    if ground is None:
        return own
    other = Contact(m.geom_friction[ground].copy(), m.geom_solref[ground].copy(),
                    m.geom_solimp[ground].copy(), int(m.geom_condim[ground]))
    if m.geom_priority[g] != m.geom_priority[ground]:
        return own if m.geom_priority[g] > m.geom_priority[ground] else other
    a, b = m.geom_solmix[g], m.geom_solmix[ground]
    w = 0.5 if a + b <= 0 else a / (a + b)
    return Contact(np.maximum(own.friction, other.friction),
                   w * own.solref + (1 - w) * other.solref,
                   w * own.solimp + (1 - w) * other.solimp, max(own.condim, other.condim))


def world(f: Loaded) -> tuple[WorldOptions, dict[int, tuple[float, float]], list[str]]:
    """The world options, each robot geom's (sliding friction, restitution), and notes."""
    m, notes = f.model, []
    planes = [g for g in range(m.ngeom) if m.geom_bodyid[g] == 0 and
              m.geom_type[g] == GEOM.mjGEOM_PLANE]
    others = [g for g in range(m.ngeom) if m.geom_bodyid[g] == 0 and g not in planes]
    ground = planes[0] if planes else None
    if ground is None:
        notes.append("the file has no ground plane; tensim adds its flat ground at z = 0 "
                     "(or --terrain)")
    if len(planes) > 1 or others:
        notes.append(f"the world's other geoms ({len(planes) - 1 + len(others)}: walls, "
                     "obstacles, height fields) are not imported; tensim's --terrain builds "
                     "grounds")
    robot = [g for g in range(m.ngeom) if m.geom_bodyid[g] != 0 and
             GEOM(m.geom_type[g]) in SHAPES]
    contacts = {g: _mix(m, g, ground) for g in robot}
    per_geom, fields = {}, _options(f, notes)
    direct = {g: c.solref.tolist() for g, c in contacts.items() if c.solref[0] <= 0}
    if direct:
        values = sorted({tuple(v) for v in direct.values()})
        notes.append(f"{', '.join(f.geom_item(g) for g in direct)}: a direct contact solref "
                     f"{' or '.join(str(list(v)) for v in values)} (stiffness, damping) has no "
                     "home in tensim: its rods take a time constant and a restitution; chosen "
                     "MuJoCo's defaults (0.02 s, damping ratio 1)")
    for g, c in contacts.items():
        if g in direct:
            c = contacts[g] = dataclasses.replace(c, solref=np.array([0.02, 1.0]))
        sliding = float(c.friction[0]) if c.condim > 1 else 0.0
        per_geom[g] = (sliding, restitution(float(c.solref[1])))
    if contacts:
        fields.update(_shared(f, list(contacts.values()), notes))
    return WorldOptions(**fields), per_geom, notes


def _options(f: Loaded, notes: list[str]) -> dict[str, Any]:
    o = f.model.opt
    fields: dict[str, Any] = {"timestep": float(o.timestep),
                              "gravity": tuple(float(v) for v in o.gravity),
                              "noslip_iterations": int(o.noslip_iterations)}
    if o.cone in _CONES:
        fields["cone"] = _CONES[mujoco.mjtCone(o.cone)]
    integrator = kind_name(mujoco.mjtIntegrator(o.integrator))
    if integrator != "euler":
        notes.append(f"the file integrates with {integrator}; tensim steps with Euler, its "
                     "cable law explicit (the step that holds the cables: 'stable below')")
    if o.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT:
        notes.append("the file disables contacts; tensim's robot touches its ground")
    return fields


def _shared(f: Loaded, contacts: list[Contact], notes: list[str]) -> dict[str, Any]:
    """The world-wide contact settings: the robot's contacts' own where they agree."""
    fields: dict[str, Any] = {}
    timeconst = sorted({round(float(c.solref[0]), 12) for c in contacts})
    fields["contact_timeconst"] = timeconst[len(timeconst) // 2]
    if len(timeconst) > 1:
        notes.append(f"contact time constants differ between geoms ({timeconst} s); tensim has "
                     f"one for the world: chosen {fields['contact_timeconst']:g} s")
    condims = sorted({c.condim for c in contacts})
    condim = max(condims)
    if condim not in (3, 4, 6):
        condim = 3 if condim < 3 else 4
        notes.append(f"contact condim {condims} has no tensim equivalent; chosen {condim}"
                     " (condim 1 is frictionless: its rods get friction 0)")
    elif len(condims) > 1:
        notes.append(f"contact condim differs between geoms ({condims}); chosen {condim}")
    fields["condim"] = condim
    for k, name in ((1, "torsional_friction"), (2, "rolling_friction")):
        values = sorted({float(c.friction[k]) for c in contacts})
        fields[name] = values[-1]
        if len(values) > 1:
            notes.append(f"{name.replace('_', ' ')} differs between geoms ({values} m); chosen "
                         f"the largest, {values[-1]:g} m")
    if any(not np.allclose(c.solimp, _SOLIMP) for c in contacts):
        notes.append(f"contact solimp {contacts[0].solimp.tolist()} has no home in tensim, "
                     f"which uses MuJoCo's default {_SOLIMP.tolist()}")
    m = f.model
    if np.any(m.geom_margin[m.geom_bodyid != 0]) or np.any(m.geom_gap[m.geom_bodyid != 0]):
        notes.append("contact margin and gap are not carried (tensim uses 0)")
    fields["self_collision"] = _self_collision(m)
    if m.nexclude or m.npair:
        notes.append("explicit contact pairs and exclusions are not carried: tensim's rods "
                     "touch the ground and (with self_collision) each other")
    return fields


def _self_collision(m: mujoco.MjModel) -> bool:
    """Whether the robot's bodies may touch each other: some two robot geoms on different
    bodies have matching contype/conaffinity bits (True for a robot of one body: nothing to
    turn off)."""
    robot = [g for g in range(m.ngeom) if m.geom_bodyid[g] != 0]
    pairs = [(a, b) for i, a in enumerate(robot) for b in robot[i + 1:]
             if m.geom_bodyid[a] != m.geom_bodyid[b]]
    return not pairs or any(m.geom_contype[a] & m.geom_conaffinity[b] or
                            m.geom_contype[b] & m.geom_conaffinity[a] for a, b in pairs)


def command_line(world: WorldOptions) -> str:
    """The ``tensim simulate`` options that give ``world`` (those that differ from the
    defaults)."""
    default = WorldOptions()
    parts = [f"--dt {world.timestep:g}"]
    contact = [f"{key}={getattr(world, field)}" for key, field in (
        ("cone", "cone"), ("noslip", "noslip_iterations"), ("condim", "condim"))
        if getattr(world, field) != getattr(default, field)]
    if world.condim >= 4 and world.torsional_friction != default.torsional_friction:
        contact.append(f"torsional={world.torsional_friction:g}")
    if world.condim == 6 and world.rolling_friction != default.rolling_friction:
        contact.append(f"rolling={world.rolling_friction:g}")
    if contact:
        parts.append("--contact " + ",".join(contact))
    if not world.self_collision:
        parts.append("--no-self-collision")
    return " ".join(parts)
