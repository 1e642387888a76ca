"""Tangent stiffness, its modes and the natural frequencies of a structure at its build pose.

The potential energy of the taut cables, V(q) = sum_c k_c (L_c(q) - l0_c)^2 / 2, has the
Hessian (the tangent stiffness) in the rigid-body coordinates of :mod:`tensim.design._bodies`

    K = K_m + K_g,   K_m = sum_c k_c g_c g_c^T,   K_g = sum_c t_c d2L_c/dq2,

with g_c = dL_c/dq and t_c = k_c (L_c - l0_c). For a cable between a fixed point and a free
point this is k e e^T + (t / L)(I - e e^T): stiffness k along the cable and the geometric
stiffness t / L across it. Gravity adds nothing about the centres of mass (the coordinates'
origin). The natural frequencies solve K v = omega^2 M v with the bodies' real mass and
inertia (rods as rigid bodies, not lumped pin-jointed bars). A mechanism (A^T v = 0, so
K_m v = 0) that is no rigid motion is stiffened by prestress where v^T K_g v > 0.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.linalg import eigh

from tensim.design._blas import blas_threads, one_blas_thread
from tensim.design._bodies import BuildPose, build_pose, cable_tensions
from tensim.design.equilibrium import RANK_TOLERANCE, equilibrium
from tensim.structure import Structure

STIFF_TOLERANCE = 1e-7  # eigenvalues below this x the largest count as zero stiffness


@dataclasses.dataclass(frozen=True)
class Stiffness:
    """The tangent stiffness of a structure at its build pose and its vibration modes.

    Attributes:
        bodies: (n_bodies,) names of the free bodies.
        dof_body: (n_dof,) the body each coordinate moves.
        material: (n_dof, n_dof) K_m [N/m, N, N m].
        geometric: (n_dof, n_dof) K_g from the cable tensions.
        mass: (n_dof, n_dof) M [kg, kg m^2].
        damping: (n_dof, n_dof) C = sum_c b_c g_c g_c^T of the taut cables' damping.
        tensions: (n_cables,) static tensions at the build pose [N].
        frequencies: (n_dof,) natural frequencies omega / (2 pi), ascending [Hz]; zero for
            modes without stiffness.
        modes: (n_dof, n_dof) mass-normalised mode shapes, one per column.
        rigid: rigid-body motions (6 for a free structure, 0 when held by the world).
        mechanisms: internal mechanisms of the equilibrium matrix (m - rigid).
        stiffened: internal mechanisms that prestress stiffens (v^T K_g v > 0 on them).
    """

    bodies: tuple[str, ...]
    dof_body: np.ndarray
    material: np.ndarray
    geometric: np.ndarray
    mass: np.ndarray
    damping: np.ndarray
    tensions: np.ndarray
    frequencies: np.ndarray
    modes: np.ndarray
    rigid: int
    mechanisms: int
    stiffened: int

    @property
    def matrix(self) -> np.ndarray:
        """(n_dof, n_dof) tangent stiffness K = K_m + K_g."""
        return self.material + self.geometric

    def eigenvalues(self) -> np.ndarray:
        """(n_dof,) eigenvalues of K, ascending (mixed units where rotations are involved)."""
        return np.linalg.eigvalsh(self.matrix)


@one_blas_thread
def stiffness(structure: Structure, count: bool = True, *,
              pose: BuildPose | None = None) -> Stiffness:
    """K_m, K_g, M and the natural frequencies at the build pose (slack cables carry nothing).

    Args:
        structure: the structure at its build pose.
        count: also count rigid motions and (stiffened) mechanisms (an SVD more); else they
            are reported as 0.
        pose: its bodies and cable geometry, where already computed.
    """
    pose = pose or build_pose(structure)
    body_set, geometry = pose.bodies, pose.geometry
    tensions = cable_tensions(structure, geometry.lengths)
    taut = np.array([structure.rest_length(c) <= L + 1e-12
                     for c, L in zip(structure.cables, geometry.lengths, strict=True)], dtype=bool)
    k = np.array([c.stiffness for c in structure.cables]) * taut
    grads = geometry.gradients
    material = (grads.T * k) @ grads
    geometric = geometry.geometric(tensions)
    mass = body_set.mass_matrix()
    damping = (grads.T * np.array([c.damping for c in structure.cables]) * taut) @ grads
    values, modes = eigh(material + geometric, mass)
    frequencies = np.sqrt(np.clip(values, 0.0, None)) / (2 * np.pi)
    counts = (0, 0, 0)
    if count:
        eq = equilibrium(structure, RANK_TOLERANCE, pose=pose)
        counts = (eq.n_rigid, eq.internal_mechanisms,
                  _stiffened(eq.mechanisms, body_set.rigid_motions(), geometric))
    return Stiffness(body_set.names, body_set.dof_body, material, geometric, mass, damping,
                     tensions, frequencies, modes, *counts)


def _stiffened(mechanisms: np.ndarray, rigid: np.ndarray, geometric: np.ndarray) -> int:
    """Internal mechanisms on which K_g is positive definite: the eigenvalues of K_g restricted
    to the mechanisms' complement of the rigid motions that are > 0."""
    if not mechanisms.shape[1]:
        return 0
    internal = mechanisms - rigid @ (rigid.T @ mechanisms) if rigid.shape[1] else mechanisms
    u, sv, _ = np.linalg.svd(internal, full_matrices=False)
    space = u[:, sv > 1e-6]
    if not space.shape[1]:
        return 0
    values = np.linalg.eigvalsh(space.T @ geometric @ space)
    scale = max(np.abs(np.linalg.eigvalsh(geometric)).max(), 1e-300)
    return int(np.sum(values > STIFF_TOLERANCE * scale))


def stable_timestep(result: Stiffness) -> tuple[float, float, float]:
    """The largest explicit (Euler) time step that integrates every mode, and the binding mode.

    For a mode x'' = -omega^2 x - 2 zeta omega x' (zeta = v^T C v / (2 omega), v
    mass-normalised) the semi-implicit Euler step is stable for
    omega dt < 2 (sqrt(1 + zeta^2) - zeta) (2 undamped); the damping alone needs
    dt < 2 / lambda_max(C, M).

    Returns:
        (dt_max [s], that mode's frequency [Hz], its damping ratio [-]).
    """
    omega = 2 * np.pi * result.frequencies
    if not omega.size or omega.max() <= 0:  # nothing moves, or nothing springs
        return np.inf, 0.0, 0.0
    modal = np.einsum("ik,ij,jk->k", result.modes, result.damping, result.modes)
    live = omega > 1e-9 * max(omega.max(), 1.0)
    zeta = np.where(live, modal / (2 * np.where(live, omega, 1.0)), 0.0)
    limits = np.where(live, 2 * (np.sqrt(1 + zeta**2) - zeta) / np.where(live, omega, 1.0),
                      np.inf)
    with blas_threads(result.mass.shape[0]):
        rate = float(eigh(result.damping, result.mass, eigvals_only=True).max())
    k = int(np.argmin(limits))
    if rate > 0 and 2 / rate < limits[k]:
        return 2 / rate, float(result.frequencies[k]), float(zeta[k])
    return float(limits[k]), float(result.frequencies[k]), float(zeta[k])
