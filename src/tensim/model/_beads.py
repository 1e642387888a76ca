"""Contact cables: the light collision beads a cable's tendon runs over (see docs/cables.md).

A contact cable stays one spatial tendon with one actuator (the same law, motor and impedance
control as any cable); its path runs through a site at the centre of each bead, a small sphere
on three slide joints between the path's points. The tendon's tension therefore pulls each bead
along both spans that meet there, and presses it on whatever it touches: the ground, terrain,
blocks and walls (beads do not touch the robot's rods, nor each other). A weak zero-length
spring on each span keeps the beads spread and in order while the cable is slack. Names:
bodies ``<cable>_bead<k>`` (k from 0 along the path), their geoms and sites after them, span
springs ``<cable>_span<k>``.
"""

from __future__ import annotations

import itertools
import logging
import math

import mujoco
import numpy as np

from tensim._input import InputError
from tensim.limits import MAX_BEADS, check_count
from tensim.structure import Cable, CableContact, Structure

BEAD_PRIORITY = 3  # outranks the terrain's 2: bead contacts use the beads' own parameters
BEAD_BIT = 2  # contype bit of the world's geoms that beads touch (robot geoms lack it)
# Bead inertia bound (docs/cables.md): a bead between spans of length l under tension T is a
# transverse spring of 2 T / l; one that bends the path by a right angle takes the cable's
# stiffness k as about 4 k and its damping b explicitly. Semi-implicit Euler at step dt then
# needs an inertia of at least max(2 T dt^2 / l, 4 k dt^2, b dt / 2) (measured:
# examples/contact_cables.py). Each bead gets SAFETY times that, with T the motor's tension
# limit: its own mass, and the rest as armature on its slide joints (inertia without weight).
SAFETY = 4.0
SPRING_SHARE = 1.0  # a span spring pulls with this many bead weights at the build span
# Beads are light and the tension presses them hard: MuJoCo's constraints, soft in
# acceleration, would let them sink; bead contacts and span limits get the stiffest setting
# that MuJoCo recommends (a time constant of two steps) and a hard impedance.
SOLREF_STEPS = 2.0
SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)
SPAN_RANGE = (0.25, 1.5)  # spans stay within these multiples of their build length (limits)
# Beads whose inertia passes the moving robot's mass slow every load they carry: a warning
# with the figures; past ten times that mass (a spacing so fine that the bound above asks
# tonnes) they would drag it, and are refused.
WARN_INERTIA_SHARE = 1.0
MAX_INERTIA_SHARE = 10.0
_log = logging.getLogger(__name__)


def _count(cable: Cable, points: tuple[np.ndarray, ...]) -> float:
    """Beads of the cable, counted without building them (inf past any float) [-]."""
    assert cable.contact is not None
    total = 0.0
    for a, b in itertools.pairwise(points):
        ratio = float(np.linalg.norm(b - a)) / cable.contact.spacing
        total += max(1.0, math.ceil(ratio) - 1.0) if math.isfinite(ratio) else math.inf
    return total


def check_beads(structure: Structure, timestep: float, moving_mass: float) -> None:
    """Refuses contact cables whose beads would be too many (:data:`tensim.limits.MAX_BEADS`
    in all) or, with the inertia each needs to be stable at ``timestep`` [s], would outweigh
    the robot's moving bodies (``moving_mass`` [kg]) ten times and drag the loads they carry;
    warns where they outweigh them at all.

    Raises:
        InputError: naming the cable, the figures and what to change.
    """
    cables = [c for c in structure.cables if c.contact is not None]
    counts = [_count(c, structure.cable_points(c)) for c in cables]
    for cable, count in zip(cables, counts, strict=True):
        check_count(f"contact cable {cable.name!r} at a bead spacing of "
                    f"{cable.contact.spacing:g} m: beads",  # type: ignore[union-attr]
                    count, MAX_BEADS, forceable=False)
    check_count("contact cables: beads in all", sum(counts), MAX_BEADS, forceable=False)
    inertia = {c.name: n * max(c.contact.mass,  # type: ignore[union-attr]
                               stable_inertia(c, shortest_span(c, structure.cable_points(c)),
                                              timestep))
               for c, n in zip(cables, counts, strict=True)}
    total = sum(inertia.values())
    if moving_mass <= 0 or total <= WARN_INERTIA_SHARE * moving_mass:
        return
    worst = max(inertia, key=inertia.__getitem__)
    figures = (f"contact cables: their beads need {total:.4g} kg of inertia to be stable at a "
               f"timestep of {timestep:g} s ({worst!r}: {inertia[worst]:.4g} kg), more than "
               f"{'ten times ' if total > MAX_INERTIA_SHARE * moving_mass else ''}the robot's "
               f"{moving_mass:.4g} kg of moving bodies")
    advice = ("Take a larger bead spacing (contact: spacing), a smaller timestep (--dt), or a "
              "lower motor max_tension (see docs/cables.md, Limits)")
    if total > MAX_INERTIA_SHARE * moving_mass:
        raise InputError(f"{figures}: they would drag every load they carry. {advice}")
    _log.warning("%s: they slow the loads they carry. %s", figures, advice)


def bead_counts(cable: Cable, points: tuple[np.ndarray, ...]) -> tuple[int, ...]:
    """Beads in each span between consecutive path points (anchor, via nodes, anchor)."""
    assert cable.contact is not None
    return tuple(max(1, math.ceil(float(np.linalg.norm(b - a)) / cable.contact.spacing) - 1)
                 for a, b in itertools.pairwise(points))


def bead_positions(cable: Cable, points: tuple[np.ndarray, ...]) -> list[np.ndarray]:
    """(3,) build positions of the beads, in path order: evenly spaced along each span [m]."""
    out = []
    for (a, b), n in zip(itertools.pairwise(points), bead_counts(cable, points), strict=True):
        out += [a + (b - a) * (k + 1) / (n + 1) for k in range(n)]
    return out


def span_lengths(cable: Cable, points: tuple[np.ndarray, ...]) -> list[float]:
    """Build length of each span of the bead path, in path order: between neighbouring beads,
    or a bead and a path point [m]."""
    return [float(np.linalg.norm(b - a)) / (n + 1) for (a, b), n in
            zip(itertools.pairwise(points), bead_counts(cable, points), strict=True)
            for _ in range(n + 1)]


def shortest_span(cable: Cable, points: tuple[np.ndarray, ...]) -> float:
    """The shortest distance between neighbouring beads (or a bead and a path point) [m]."""
    return min(span_lengths(cable, points))


def stable_inertia(cable: Cable, span: float, timestep: float) -> float:
    """The inertia each bead needs at ``timestep`` [kg]: ``SAFETY`` times the bound."""
    bound = max(2 * cable.motor.max_tension / span * timestep**2,
                4 * cable.stiffness * timestep**2, cable.damping * timestep / 2)
    return SAFETY * bound


def bead_armature(cable: Cable, points: tuple[np.ndarray, ...], timestep: float) -> float:
    """Armature of each bead's slide joints [kg]: what its mass lacks of the stable inertia."""
    assert cable.contact is not None
    need = stable_inertia(cable, shortest_span(cable, points), timestep)
    return max(0.0, need - cable.contact.mass)


def add_beads(spec: mujoco.MjSpec, cable: Cable, points: tuple[np.ndarray, ...],
              timestep: float, contact_timeconst: float) -> list[list[str]]:
    """Adds the cable's beads to ``spec``'s world; returns the bead sites of each span."""
    contact: CableContact = cable.contact  # type: ignore[assignment]
    armature = bead_armature(cable, points, timestep)
    positions = iter(bead_positions(cable, points))
    sites: list[list[str]] = []
    k = 0
    for count in bead_counts(cable, points):
        sites.append([])
        for _ in range(count):
            name = f"{cable.name}_bead{k}"
            body = spec.worldbody.add_body(name=name, pos=next(positions).tolist())
            for axis in np.eye(3):
                body.add_joint(name=f"{name}_{'xyz'[int(np.argmax(axis))]}",
                               type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis.tolist(),
                               armature=armature)
            # frictionless: the path slides over what it touches, as a taut string does
            body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                          size=[contact.radius, 0, 0], mass=contact.mass, condim=1,
                          priority=BEAD_PRIORITY,
                          contype=0, conaffinity=BEAD_BIT,
                          solref=[SOLREF_STEPS * timestep, 1.0], solimp=list(SOLIMP), group=3,
                          rgba=[0.35, 0.35, 0.35, 1])
            body.add_site(name=f"{name}_site", size=[0.001, 0, 0], group=5)
            sites[-1].append(f"{name}_site")
            k += 1
    return sites


def add_span_springs(spec: mujoco.MjSpec, cable: Cable, path_sites: list[str],
                     points: tuple[np.ndarray, ...], timestep: float) -> None:
    """A weak zero-length spring tendon on each span of the bead path (keeps slack beads
    spread and in order); its pull at its build length is ``SPRING_SHARE`` bead weights, and
    its length limits are multiples of that build length (spans of a cable through via nodes
    differ: each keeps its own)."""
    assert cable.contact is not None
    spans = span_lengths(cable, points)
    for k, ((a, b), span) in enumerate(zip(itertools.pairwise(path_sites), spans, strict=True)):
        stiffness = SPRING_SHARE * cable.contact.mass * 9.81 / span
        tendon = spec.add_tendon(name=f"{cable.name}_span{k}", stiffness=stiffness,
                                 springlength=[0.0, 0.0], group=5, rgba=[0, 0, 0, 0],
                                 limited=True, range=[SPAN_RANGE[0] * span, SPAN_RANGE[1] * span],
                                 solref_limit=[SOLREF_STEPS * timestep, 1.0],
                                 solimp_limit=list(SOLIMP))
        tendon.wrap_site(a)
        tendon.wrap_site(b)


def bead_bodies(model: mujoco.MjModel, structure: Structure) -> tuple[str, ...]:
    """The bead bodies' names, in cable and path order."""
    names = []
    for cable in structure.cables:
        if cable.contact is None:
            continue
        for k in itertools.count():
            name = f"{cable.name}_bead{k}"
            if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) < 0:
                break
            names.append(name)
    return tuple(names)


def let_world_touch_beads(spec: mujoco.MjSpec) -> None:
    """Gives the world body's geoms (ground, terrain) the bead bit, so beads touch them."""
    for geom in spec.worldbody.geoms:
        geom.contype |= BEAD_BIT
