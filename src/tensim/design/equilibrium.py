"""Equilibrium matrix, states of self-stress and mechanisms, and all-tension prestress.

With the rigid bodies of :mod:`tensim.design._bodies` (rods sharing a node form one body), a
cable of tension t_c pulls on the bodies with the generalized force -t_c dL_c/dq. Static
equilibrium under external generalized forces f is

    A t = f,    A = [dL_1/dq ... dL_n/dq]  (n_dof x n_cables),

the equilibrium matrix (force and moment balance of every free body). Its transpose maps
small motions to cable elongations (kinematic compatibility). With r = rank(A), Pellegrino
and Calladine's counts (Int. J. Solids Struct. 22, 1986) are

    s = n_cables - r    states of self-stress (null space of A),
    m = n_dof - r       mechanisms (null space of A^T), rigid-body motions included.

A tensegrity needs a self-stress t = N x (N a basis of null(A)) with every cable in tension
and every lone rod in compression; it is found by a linear program that maximises the smallest
tension at a fixed scale. Rows of A for rotations are divided by the mean cable length so that
the rank tolerance compares like with like.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.linalg import svd

from tensim.design._blas import one_blas_thread
from tensim.design._bodies import Bodies, BuildPose, CableGeometry, build_pose, cable_tensions
from tensim.design._errors import DesignError
from tensim.structure import Structure

RANK_TOLERANCE = 1e-5  # singular values below this x the largest count as zero: node
# coordinates written with six digits (0.173205) leave ~1e-6 of a self-stress state


@dataclasses.dataclass(frozen=True)
class Equilibrium:
    """The equilibrium matrix of a structure at its build pose and its four subspaces' sizes.

    Attributes:
        cables: (n_cables,) cable names, the columns of ``matrix``.
        matrix: (n_dof, n_cables) A, rotation rows divided by ``length_scale`` [-].
        singular_values: singular values of ``matrix``, descending [-].
        rank: r, the number of singular values above the tolerance.
        n_dof: degrees of freedom of the free bodies.
        n_rigid: rigid-body motions among the mechanisms (6 for a free structure, 0 if held).
        self_stresses: (n_cables, s) orthonormal basis of the states of self-stress [N per
            unit of the basis].
        mechanisms: (n_dof, m) orthonormal basis of the mechanisms, in the bodies' twist
            coordinates [m, rad] (rigid motions included).
        length_scale: mean cable length that scales the rotation rows [m].
    """

    cables: tuple[str, ...]
    matrix: np.ndarray
    singular_values: np.ndarray
    rank: int
    n_dof: int
    n_rigid: int
    self_stresses: np.ndarray
    mechanisms: np.ndarray
    length_scale: float

    @property
    def s(self) -> int:
        """Number of independent states of self-stress."""
        return int(self.self_stresses.shape[1])

    @property
    def m(self) -> int:
        """Number of independent mechanisms, rigid-body motions included."""
        return int(self.mechanisms.shape[1])

    @property
    def internal_mechanisms(self) -> int:
        """Mechanisms that deform the structure (m minus the rigid-body motions)."""
        return self.m - self.n_rigid


def _row_scale(body_set: Bodies, geometry: CableGeometry) -> tuple[np.ndarray, float]:
    """(n_dof,) 1 for translations, 1 / (mean cable length) for rotations; and that length."""
    scale = float(np.mean(geometry.lengths)) if len(geometry.lengths) else 1.0
    rotation = np.abs(body_set.basis[np.arange(body_set.n_full) % 6 >= 3]).sum(axis=0) > 0
    return np.where(rotation, 1.0 / scale, 1.0), scale


@one_blas_thread
def equilibrium(structure: Structure, tolerance: float = RANK_TOLERANCE, *,
                pose: BuildPose | None = None) -> Equilibrium:
    """The equilibrium matrix at the build pose, its rank and the s and m of its null spaces.

    Args:
        structure: the structure; only its geometry and topology matter here.
        tolerance: singular values below ``tolerance`` x the largest count as zero [-].
        pose: its bodies and cable geometry, where already computed.
    """
    pose = pose or build_pose(structure)
    body_set, geometry = pose.bodies, pose.geometry
    rows, scale = _row_scale(body_set, geometry)
    matrix = geometry.gradients.T * rows[:, None]
    # one full SVD, A = U S V^T: the last columns of V span the self-stresses, of U the
    # mechanisms (Pellegrino 1993)
    left, values, right = svd(matrix) if matrix.size else (
        np.eye(matrix.shape[0]), np.zeros(0), np.eye(matrix.shape[1]))
    rank = int(np.sum(values > tolerance * (values.max() if values.size else 1.0)))
    stresses = right[rank:].T
    # a null vector v of (D A)^T is the motion D v of the unscaled coordinates
    mechanisms = left[:, rank:] * rows[:, None]
    mechanisms = np.linalg.qr(mechanisms)[0] if mechanisms.size else mechanisms
    return Equilibrium(tuple(c.name for c in structure.cables), matrix, values, rank,
                       body_set.n_dof, body_set.rigid_motions().shape[1], stresses,
                       mechanisms, scale)


@dataclasses.dataclass(frozen=True)
class SelfStress:
    """An all-tension state of self-stress of a structure at its build pose.

    Attributes:
        cables: (n_cables,) cable names.
        tensions: (n_cables,) cable tensions t [N], all > 0.
        lengths: (n_cables,) anchor-to-anchor lengths L at the build pose [m].
        rod_forces: rod name -> axial force, negative in compression [N], for each rod that is
            a body of its own (in a body of several rods the split is not determined).
        states: s, the number of independent states of self-stress it was chosen from.
    """

    cables: tuple[str, ...]
    tensions: np.ndarray
    lengths: np.ndarray
    rod_forces: dict[str, float]
    states: int

    @property
    def force_densities(self) -> np.ndarray:
        """(n_cables,) force densities q = t / L [N/m]."""
        return self.tensions / self.lengths


def _rod_force_matrix(structure: Structure, geometry: CableGeometry) -> dict[str, np.ndarray]:
    """Rod name -> (n_cables,) axial force per cable tension for rods alone in their body.

    The cables pull end a of a rod with sum_c t_c u_c; the rod pushes back along its axis, so
    its axial force is -(that pull) . e_ab (negative: compression).
    """
    lone = {g.rods[0] for g in structure.rigid_groups() if len(g.rods) == 1 and
            len(g.nodes) == 2}
    out = {}
    for rod in structure.rods:
        if rod.name in lone:
            a, b = rod.nodes
            axis = structure.position(b) - structure.position(a)
            out[rod.name] = -(axis / np.linalg.norm(axis)) @ geometry.node_forces[a]
    return out


@one_blas_thread
def self_stress(structure: Structure, *, min_tension: float | None = None,
                cable: str | None = None, tension: float | None = None,
                force_density: float | None = None,
                tolerance: float = RANK_TOLERANCE) -> SelfStress:
    """The all-tension self-stress of ``structure`` at one chosen level.

    Among the states of self-stress t = N x it takes the one whose smallest cable tension is
    largest for the chosen scale (a linear program; unique up to scale when s = 1), with every
    lone rod in compression. Give exactly one level.

    Args:
        structure: the structure at its build pose.
        min_tension: smallest cable tension [N].
        cable: a cable whose tension is ``tension`` [N].
        tension: that cable's tension [N].
        force_density: mean cable force density t / L [N/m].
        tolerance: the rank tolerance of :func:`equilibrium`.

    Raises:
        DesignError: no level or several, an unknown cable, no state of self-stress, or none
            that puts every cable in tension.
    """
    names = tuple(c.name for c in structure.cables)
    given = [v is not None for v in (min_tension, tension, force_density)]
    if sum(given) != 1 or (cable is None) != (tension is None):
        raise DesignError("give one prestress level: a minimum tension [N], a cable and its "
                          "tension [N], or a mean force density [N/m]")
    level = next(v for v in (min_tension, tension, force_density) if v is not None)
    if level <= 0:
        raise DesignError(f"the prestress level must be > 0, got {level}")
    if cable is not None and cable not in names:
        raise DesignError(f"unknown cable {cable!r}; cables: {', '.join(names)}")
    pose = build_pose(structure)
    eq = equilibrium(structure, tolerance, pose=pose)
    geometry = pose.geometry
    rods = _rod_force_matrix(structure, geometry)
    if eq.s == 0:
        raise DesignError(
            f"{structure.name} has no state of self-stress at its build pose (s = 0, "
            f"{eq.internal_mechanisms} internal mechanisms): no pretension holds it in this "
            "shape; add cables or move nodes to a self-stressed form")
    weights = {"min": np.ones(len(names)), "density": 1.0 / geometry.lengths}
    row = (np.eye(len(names))[names.index(cable)] if cable is not None
           else weights["min" if min_tension is not None else "density"])
    x, best = _maximin(eq.self_stresses, np.array(list(rods.values())).reshape(-1, len(names)),
                       row)
    if best <= 1e-9:
        raise DesignError(_no_tension_message(structure.name, eq.s, names,
                                              eq.self_stresses @ x))
    t = eq.self_stresses @ x
    if min_tension is not None:
        t *= min_tension / t.min()
    elif cable is not None:
        t *= tension / t[names.index(cable)]
    else:
        t *= force_density / np.mean(t / geometry.lengths)
    return SelfStress(names, t, geometry.lengths,
                      {name: float(f @ t) for name, f in rods.items()}, eq.s)


def _maximin(basis: np.ndarray, rods: np.ndarray, row: np.ndarray) -> tuple[np.ndarray, float]:
    """x maximising min_c (N x)_c subject to row . N x = 1 and rods . N x <= 0.

    The scale constraint alone bounds the level tau: ``row`` is non-negative with a positive
    entry (ones, one cable, or 1 / lengths) and tau <= every tension, so tau sum(row) <=
    row . N x = 1; tau needs no bound of its own.

    Returns x and the largest smallest tension (<= 0 when no all-tension state exists).
    """
    from scipy.optimize import linprog  # imported on use: see design/__init__

    n, s = basis.shape
    cost = np.r_[np.zeros(s), -1.0]  # variables (x, tau): maximise tau
    upper = np.block([[-basis, np.ones((n, 1))], [rods @ basis, np.zeros((len(rods), 1))]])
    result = linprog(cost, A_ub=upper, b_ub=np.zeros(len(upper)),
                     A_eq=np.r_[row @ basis, 0.0][None, :], b_eq=[1.0],
                     bounds=[(None, None)] * (s + 1), method="highs")
    if not result.success:
        return np.zeros(s), 0.0
    return result.x[:s], float(result.x[-1])


def _no_tension_message(name: str, s: int, names: tuple[str, ...], t: np.ndarray) -> str:
    slack = [c for c, v in zip(names, t, strict=True) if v <= 1e-9 * max(np.abs(t).max(), 1)]
    return (f"{name} has {s} state(s) of self-stress at its build pose, but none puts every "
            f"cable in tension (with every lone rod in compression); the best leaves "
            f"{', '.join(slack[:6]) or 'some cables'}{' ...' if len(slack) > 6 else ''} slack "
            "or pushed: move nodes toward a tensegrity form or change which pairs are cables")


def prestressed(structure: Structure, stress: SelfStress) -> Structure:
    """A copy whose cables carry the self-stress: pretension t (so rest length L - t / k)."""
    tensions = dict(zip(stress.cables, stress.tensions, strict=True))
    cables = tuple(dataclasses.replace(c, pretension=float(tensions[c.name]), rest_length=None)
                   for c in structure.cables)
    return dataclasses.replace(structure, cables=cables)


def residuals(structure: Structure, *, pose: BuildPose | None = None
              ) -> dict[str, tuple[float, float]]:
    """Body name -> (|net force| [N], |net moment about its COM| [N m]) of the cables at the
    build pose with their given pretensions or rest lengths, gravity left out (``pose``: its
    bodies and cable geometry, where already computed)."""
    pose = pose or build_pose(structure)
    body_set, geometry = pose.bodies, pose.geometry
    full = body_set.basis @ (geometry.gradients.T @ cable_tensions(structure, geometry.lengths))
    return {name: (float(np.linalg.norm(full[6 * b:6 * b + 3])),
                   float(np.linalg.norm(full[6 * b + 3:6 * b + 6])))
            for b, name in enumerate(body_set.names)}
