"""Members that hold: rods against Euler buckling and yield, cables against their breaking load.

The simulation's rods are rigid; a rod's :class:`tensim.structure.RodSection` says whether the
real tube holds the axial force it carries. That force comes from node equilibrium with every
rod a pin-ended bar (as in the force density method): at each node the cables' pulls
sum_c t_c u_c and the rods' axial forces f_r u_r balance, solved by least squares over all
rods at once. A rod whose force that leaves undetermined (rods that share nodes can carry any
internal self-stress) or whose ends are not balanced by axial forces alone (a rigid joint in
bending) gets no figure. Point masses, gravity and inertia are left out: the forces are those
of the prestress, or of the cable tensions of a run at each recorded instant.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping

import numpy as np

from tensim.structure import Structure

BALANCE_TOLERANCE = 1e-6  # node imbalance left by axial forces, relative to the largest pull


@dataclasses.dataclass(frozen=True)
class RodCheck:
    """One rod's axial force against what its section holds.

    Attributes:
        rod: the rod's name.
        force: axial force, negative in compression [N]; None where it is not determined.
        length: end-to-end length [m].
        buckling_load: Euler load pi^2 E I / L^2 [N], or None without a section.
        yield_load: sigma_y A [N], or None without a section.
        mass: the section's mass, density x A x L [kg], or None without a density.
    """

    rod: str
    force: float | None
    length: float
    buckling_load: float | None
    yield_load: float | None
    mass: float | None

    @property
    def buckling_margin(self) -> float | None:
        """P_cr / |compression| - 1 [-] (None without a section or in tension)."""
        if self.force is None or self.buckling_load is None or self.force >= 0:
            return None
        return self.buckling_load / -self.force - 1.0

    @property
    def yield_margin(self) -> float | None:
        """sigma_y A / |force| - 1 [-] (None without a section or a force)."""
        if self.force is None or self.yield_load is None or self.force == 0:
            return None
        return self.yield_load / abs(self.force) - 1.0


@dataclasses.dataclass(frozen=True)
class CableCheck:
    """One cable's tension against its breaking load.

    Attributes:
        cable: the cable's name.
        tension: its (peak) tension [N].
        breaking_load: the tension at which it breaks [N], or None if not given.
    """

    cable: str
    tension: float
    breaking_load: float | None

    @property
    def margin(self) -> float | None:
        """breaking load / tension - 1 [-] (None without a breaking load)."""
        if self.breaking_load is None or self.tension <= 0:
            return None
        return self.breaking_load / self.tension - 1.0


def bar_forces(structure: Structure, tensions: np.ndarray,
               positions: Mapping[str, np.ndarray] | None = None,
               loads: Mapping[str, np.ndarray] | None = None,
               supports: tuple[str, ...] = ()) -> dict[str, float | None]:
    """Each rod's axial force (negative in compression) [N] that balances the cables' pulls
    and the external loads at the nodes, with every rod a pin-ended bar.

    Args:
        structure: the structure (its topology; its positions unless ``positions`` is given).
        tensions: (n_cables,) cable tensions [N].
        positions: node -> (3,) position [m]; default: the build pose.
        loads: node -> (3,) external force on it [N] (weights included, if wanted).
        supports: nodes held by the ground, which supplies whatever force they need.
    """
    where = {n.name: (np.asarray(positions[n.name]) if positions is not None
                      else structure.position(n.name)) for n in structure.nodes}
    free = [n.name for n in structure.nodes if not n.fixed and n.name not in supports]
    row = {name: 3 * i for i, name in enumerate(free)}
    pull = np.zeros(3 * len(free))
    for node, load in (loads or {}).items():
        if node in row:
            pull[row[node]:row[node] + 3] += load
    for cable, t in zip(structure.cables, tensions, strict=True):
        path = cable.path
        for a, b in itertools.pairwise(path):
            unit = (where[b] - where[a]) / np.linalg.norm(where[b] - where[a])
            for node, sign in ((a, 1.0), (b, -1.0)):
                if node in row:
                    pull[row[node]:row[node] + 3] += sign * t * unit
    matrix = np.zeros((3 * len(free), len(structure.rods)))
    for k, rod in enumerate(structure.rods):
        a, b = rod.nodes
        unit = (where[b] - where[a]) / np.linalg.norm(where[b] - where[a])
        for node, sign in ((a, 1.0), (b, -1.0)):  # a bar in tension pulls its ends together
            if node in row:
                matrix[row[node]:row[node] + 3, k] = sign * unit
    forces, *_ = np.linalg.lstsq(matrix, -pull, rcond=None)
    scale = max(float(np.abs(tensions).max()) if len(tensions) else 0.0,
                float(np.abs(pull).max()) if len(pull) else 0.0, 1e-300)
    unbalanced = np.abs(matrix @ forces + pull).reshape(-1, 3).max(axis=1) > \
        BALANCE_TOLERANCE * scale
    _, sv, vt = np.linalg.svd(matrix)
    free_modes = vt[int((sv > 1e-9 * max(sv.max(), 1e-300)).sum()):]
    out: dict[str, float | None] = {}
    for k, rod in enumerate(structure.rods):
        loose = any(unbalanced[row[n] // 3] for n in rod.nodes if n in row)
        undetermined = free_modes.size and np.abs(free_modes[:, k]).max() > 1e-9
        out[rod.name] = None if loose or undetermined else float(forces[k])
    return out


def end_forces(structure: Structure, tensions: np.ndarray,
               positions: Mapping[str, np.ndarray]) -> dict[str, float | None]:
    """Each rod's axial force from the cables' pulls at its ends alone, the more compressive
    of its two ends [N]: for a moving robot whose ends also carry ground forces and inertia,
    which the cables' pulls do not balance. Rods that share a node get their
    :func:`bar_forces` figure."""
    pulls = {n.name: np.zeros(3) for n in structure.nodes}
    for cable, t in zip(structure.cables, tensions, strict=True):
        for a, b in itertools.pairwise(cable.path):
            unit = (positions[b] - positions[a]) / np.linalg.norm(positions[b] - positions[a])
            pulls[a] += t * unit
            pulls[b] -= t * unit
    shared = {n for g in structure.rigid_groups() if len(g.rods) > 1 for n in g.nodes}
    shared_forces = bar_forces(structure, tensions, positions) if shared else {}
    out: dict[str, float | None] = {}
    for rod in structure.rods:
        a, b = rod.nodes
        if a in shared:
            out[rod.name] = shared_forces[rod.name]
            continue
        axis = (positions[b] - positions[a]) / np.linalg.norm(positions[b] - positions[a])
        out[rod.name] = float(min(-pulls[a] @ axis, pulls[b] @ axis))
    return out


def node_weights(structure: Structure, gravity: float) -> dict[str, np.ndarray]:
    """Node -> (3,) weight carried there [N]: its point mass and half of each rod ending
    there."""
    weight = {n.name: np.zeros(3) for n in structure.nodes}
    for mass in structure.point_masses:
        weight[mass.node][2] -= mass.mass * gravity
    for rod in structure.rods:
        half = rod.mass_per_length() * structure.distance(*rod.nodes) * gravity / 2
        for node in rod.nodes:
            weight[node][2] -= half
    return weight


def rod_checks(structure: Structure, forces: Mapping[str, float | None]) -> list[RodCheck]:
    """Each rod's force against its section's buckling and yield loads."""
    checks = []
    for rod in structure.rods:
        length = structure.distance(*rod.nodes)
        section = rod.section
        mass = None if section is None or section.density is None else \
            section.density * section.area * length
        checks.append(RodCheck(rod.name, forces.get(rod.name), length,
                               None if section is None else section.buckling_load(length),
                               None if section is None else section.yield_load(), mass))
    return checks


def cable_checks(structure: Structure, tensions: np.ndarray) -> list[CableCheck]:
    """Each cable's tension against its breaking load."""
    return [CableCheck(c.name, float(t), c.breaking_load)
            for c, t in zip(structure.cables, tensions, strict=True)]


def section_mass(structure: Structure) -> tuple[float, float]:
    """The robot's mass with each rod's section where it gives a density (else the rod as
    modelled), point masses included [kg]; and the modelled mass [kg] for comparison."""
    total = 0.0
    for check, rod in zip(rod_checks(structure, {}), structure.rods, strict=True):
        total += check.mass if check.mass is not None else rod.mass_per_length() * check.length
    total += sum(p.mass for p in structure.point_masses)
    return total, structure.total_mass()


def worst_margin(rods: list[RodCheck], cables: list[CableCheck]) -> float:
    """The smallest margin of all checks [-] (inf where nothing is checked)."""
    values = [m for r in rods for m in (r.buckling_margin, r.yield_margin) if m is not None]
    values += [c.margin for c in cables if c.margin is not None]
    return min(values, default=math.inf)
