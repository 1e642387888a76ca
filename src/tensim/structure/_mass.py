"""Exact mass properties of a rigid group: solid-cylinder rods plus solid-sphere point masses."""

from __future__ import annotations

import dataclasses

import numpy as np

from tensim.structure._structure import RigidGroup, Structure


@dataclasses.dataclass(frozen=True)
class MassProperties:
    """Mass, centre of mass and inertia of one rigid body, in the world frame of the build pose.

    Attributes:
        mass: total mass [kg].
        com: (3,) centre of mass [m].
        inertia: (3, 3) inertia tensor about the centre of mass [kg m^2].
    """

    mass: float
    com: np.ndarray
    inertia: np.ndarray

    def principal_moments(self) -> np.ndarray:
        """(3,) principal moments of inertia, ascending [kg m^2]."""
        return np.linalg.eigvalsh(self.inertia)


def _shift(inertia: np.ndarray, mass: float, offset: np.ndarray) -> np.ndarray:
    """Parallel-axis theorem: inertia about a point displaced by ``offset`` from the COM."""
    return inertia + mass * (offset @ offset * np.eye(3) - np.outer(offset, offset))


def _rod_inertia(mass: float, length: float, radius: float, axis: np.ndarray,
                 axial: float | None = None) -> np.ndarray:
    """Solid cylinder about its centre: m r^2/2 along the axis (or ``axial`` [kg m^2] where
    the rod gives it), m(3r^2 + L^2)/12 across."""
    axial = 0.5 * mass * radius**2 if axial is None else axial
    transverse = mass * (3 * radius**2 + length**2) / 12.0
    return transverse * np.eye(3) + (axial - transverse) * np.outer(axis, axis)


def mass_properties(structure: Structure, group: RigidGroup) -> MassProperties:
    """Exact mass properties of ``group`` (rods as solid cylinders, point masses as spheres)."""
    parts: list[tuple[float, np.ndarray, np.ndarray]] = []  # (mass, centre, inertia about centre)
    rods = {r.name: r for r in structure.rods}
    for name in group.rods:
        rod = rods[name]
        p0, p1 = structure.position(rod.nodes[0]), structure.position(rod.nodes[1])
        length = float(np.linalg.norm(p1 - p0))
        mass = rod.mass_per_length() * length
        parts.append((mass, 0.5 * (p0 + p1),
                      _rod_inertia(mass, length, rod.radius, (p1 - p0) / length,
                                   rod.axial_inertia)))
    members = set(group.nodes)
    for pm in structure.point_masses:
        if pm.node in members:
            sphere = 0.4 * pm.mass * pm.radius**2 * np.eye(3)
            parts.append((pm.mass, structure.position(pm.node), sphere))
    total = sum(m for m, _, _ in parts)
    com = sum(m * c for m, c, _ in parts) / total
    inertia = sum(_shift(i, m, c - com) for m, c, i in parts)
    return MassProperties(float(total), np.asarray(com), np.asarray(inertia))
