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
from collections.abc import Callable

import numpy as np
from scipy.linalg import eigh, lu_factor, lu_solve

from tensim.design._blas import blas_threads, one_blas_thread
from tensim.design._bodies import BuildPose, build_pose, cable_tensions
from tensim.design.equilibrium import RANK_TOLERANCE, equilibrium
from tensim.model._law_layout import THETA_DISCRETE
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
        modal: (n_dof,) the eigenvalues omega^2 of (K, M) behind ``frequencies`` and
            ``modes``, unclipped [1/s^2] (None: not kept; :func:`step_bound` then solves the
            eigenproblem again).
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
    modal: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)

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
    # a PD motor's servo counts as engaged (it starts at or past its target): the step
    # bound must hold while it pulls
    servo = np.array([(c.motor.pd_stiffness, c.motor.pd_damping)
                      for c in structure.cables]).reshape(-1, 2)
    k = np.array([c.stiffness for c in structure.cables]) * taut + servo[:, 0]
    grads = geometry.gradients
    material = (grads.T * k) @ grads
    geometric = geometry.geometric(tensions)
    mass = body_set.mass_matrix()
    b = np.array([c.damping for c in structure.cables]) * taut + servo[:, 1]
    damping = (grads.T * b) @ grads
    values, modes = eigh(material + geometric, mass)
    frequencies = np.sqrt(np.clip(values, 0.0, None)) / (2 * np.pi)
    counts = (0, 0, 0)
    if count:
        eq = equilibrium(structure, RANK_TOLERANCE, pose=pose)
        counts = (eq.n_rigid, eq.internal_mechanisms,
                  _stiffened(eq.mechanisms, body_set.rigid_motions(), geometric))
    return Stiffness(body_set.names, body_set.dof_body, material, geometric, mass, damping,
                     tensions, frequencies, modes, *counts, modal=values)


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


INTEGRATORS = ("euler", "implicitfast", "discrete")  # how MuJoCo's step sees the cable forces
GROWTH_TOLERANCE = 1e-8  # |eigenvalue| - 1 of the step matrix that counts as growth
STEP_RESOLUTION = 1e-4  # relative width of the bracket the bisection leaves around the bound
# each cable law's MuJoCo integrator, as step_bound names it (tensim.model.INTEGRATORS)
LAW_INTEGRATORS = {"explicit": "euler", "implicitfast": "implicitfast", "implicit": "discrete"}

# the implicit damping of a step of dt [s]: (n, n), in the coordinates of the step matrix
ImplicitDamping = Callable[[float], np.ndarray]


@dataclasses.dataclass(frozen=True)
class StepBound:
    """The longest stable time step of a structure's linearised motion, and what sets it.

    Attributes:
        limit: the step [s] above which the step matrix has an eigenvalue of modulus > 1
            (inf when nothing springs or damps, or the integrator is stable at every step).
        frequency: the natural frequency of the vibration mode that grows first [Hz].
        damping_ratio: that mode's modal damping ratio v^T C v / (2 omega) [-].
        integrator: the integrator the bound is for (see :func:`step_bound`).
    """

    limit: float
    frequency: float
    damping_ratio: float
    integrator: str


def _check_integrator(integrator: str) -> None:
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {', '.join(INTEGRATORS)}, got "
                         f"{integrator!r}")


def step_matrix(stiffness: np.ndarray, damping: np.ndarray, mass: np.ndarray, dt: float,
                integrator: str = "euler", implicit: np.ndarray | None = None) -> np.ndarray:
    """(2 n, 2 n) the map (x, v) -> (x', v') of one step of M x'' = -K x - C v.

    MuJoCo's ``euler`` is semi-implicit: v' = v + dt a, x' = x + dt v'. With ``euler`` the
    forces are explicit, a = M^-1 (-K x - C v), as MuJoCo applies forces that a user callback
    adds (tensim's explicit cable law). With ``implicitfast`` the damping MuJoCo knows is
    implicit, a = (M + dt D)^-1 (-K x - C v), where D is ``implicit`` (default C): MuJoCo keeps
    only the blocks of C inside the sparsity of M, each body's own (see
    :func:`body_blocks`). With ``discrete`` the implicit cable law hands MuJoCo's step a share
    theta = 1/2 of stiffness and damping (``THETA_DISCRETE``; docs/architecture.md), a = (M +
    theta (dt C + dt^2 K))^-1 (-K x - C v - theta dt K v): trapezoidal, stable at every step.

    Args:
        stiffness: (n, n) K.
        damping: (n, n) C.
        mass: (n, n) M.
        dt: the step [s].
        integrator: ``euler``, ``implicitfast`` or ``discrete``.
        implicit: (n, n) the damping ``implicitfast`` takes implicitly (None: all of C).
    """
    _check_integrator(integrator)
    force = np.hstack([stiffness, damping])
    inertia = mass
    if integrator == "implicitfast":
        inertia = mass + dt * (damping if implicit is None else implicit)
    elif integrator == "discrete":  # the implicit law takes a share THETA_DISCRETE of both
        theta = THETA_DISCRETE
        inertia = mass + theta * (dt * damping + dt**2 * stiffness)
        force = np.hstack([stiffness, damping + theta * dt * stiffness])
    gain = np.linalg.solve(inertia, force)  # a = -gain @ (x, v)
    n = len(mass)
    velocity = np.hstack([np.zeros((n, n)), np.eye(n)]) - dt * gain
    return np.vstack([np.hstack([np.eye(n), np.zeros((n, n))]) + dt * velocity, velocity])


def body_blocks(result: Stiffness) -> np.ndarray:
    """(n_dof, n_dof) the damping MuJoCo's ``implicitfast`` takes implicitly: each body's own
    block of C (its sparsity is the mass matrix's, one block per free body), without the
    blocks that couple two bodies through a cable."""
    same = result.dof_body[:, None] == result.dof_body[None, :]
    return np.where(same, result.damping, 0.0)


def step_bound(result: Stiffness, integrator: str = "euler") -> StepBound:
    """The longest time step at which the linearised step of ``integrator`` does not grow.

    The motion about the build pose, M x'' = -K x - C x' with the cables' stiffness and
    damping matrices as they are (each cable its own damping-to-stiffness ratio), is stepped
    by the matrix of :func:`step_matrix`; the bound is the smallest step at which its spectral
    radius exceeds 1. Its eigenvalue leaves the unit circle at -1 (x' = -x, v' = -v), which
    happens where (K + r (C - 2 D) - r^2 M) x = 0 for r = 2 / dt (D: the implicit damping, 0
    with ``euler``): a quadratic eigenvalue problem. Its root is confirmed on the step matrix
    (stable just below, growing just above); where it is not (a pair of complex eigenvalues
    leaves first), a scan and a bisection on the spectral radius find the bound. The analysis
    runs in the coordinates of the vibration modes without the motions nothing springs or
    damps (rigid motions, unstiffened mechanisms: eigenvalue 1 at every step); modes that
    prestress softens (omega^2 < 0) count as unstiffened. Under ``implicitfast`` each body's
    own damping block (:func:`body_blocks`) also weighs on those motions, which the step
    matrix takes into account (their Schur complement). ``discrete`` has no bound (inf).

    Args:
        result: the structure's stiffness (:func:`stiffness`).
        integrator: ``euler`` (cable forces explicit: the explicit cable law),
            ``implicitfast`` (each body's own block of their damping implicit) or
            ``discrete`` (their stiffness and damping implicit: the implicit cable law), see
            :func:`step_matrix`.

    Raises:
        ValueError: an unknown integrator.
    """
    _check_integrator(integrator)
    if integrator == "discrete":  # trapezoidal in K and C: no step grows
        return StepBound(np.inf, 0.0, 0.0, integrator)
    with blas_threads(2 * result.mass.shape[0]):
        return _step_bound(result, integrator)


def _step_bound(result: Stiffness, integrator: str) -> StepBound:
    # the modes stiffness() found (the same eigenproblem, solved once)
    values, modes = (result.modal, result.modes) if result.modal is not None \
        else eigh(result.matrix, result.mass)
    values = np.clip(values, 0.0, None)
    damping = modes.T @ result.damping @ modes
    scale = max(values.max(initial=0.0), np.abs(damping).max(initial=0.0) ** 2)
    keep = (values > 1e-9 * scale) | (np.abs(damping).max(axis=0, initial=0.0) ** 2 > 1e-12 * scale)
    if scale <= 0 or not keep.any():  # nothing springs or damps
        return StepBound(np.inf, 0.0, 0.0, integrator)
    stiff, damp = np.diag(values[keep]), damping[np.ix_(keep, keep)]
    implicit, full = None, None
    if integrator == "implicitfast":
        blocks = modes.T @ body_blocks(result) @ modes
        implicit = _reduced_implicit(blocks, keep)
        full = (np.diag(values), damping, blocks)
    if integrator == "euler":
        proven = _proven_euler_bound(stiff, damp)
        if proven is not None:
            return proven
    limit = _flip_step(stiff, damp, integrator, full)
    # the step matrix just above the root and its eigenvalues, kept for _growing
    above = _spectrum(stiff, damp, limit * (1 + STEP_RESOLUTION), integrator, implicit) \
        if np.isfinite(limit) else None
    if above is None or not (
            _radius(above[1]) > 1 + GROWTH_TOLERANCE
            and not _grows(stiff, damp, limit * (1 - STEP_RESOLUTION), integrator, implicit)):
        limit, above = _scanned_step(stiff, damp, integrator, limit, implicit), None
    if not np.isfinite(limit):
        return StepBound(np.inf, 0.0, 0.0, integrator)
    return _growing(stiff, damp, limit, integrator, implicit, above)


def _proven_euler_bound(stiff: np.ndarray, damp: np.ndarray) -> StepBound | None:
    """The Euler bound where a proof stands in for the step matrix's eigenvalues (None
    elsewhere: the caller computes them).

    With K > 0 (diagonal, mass-normalised modes) and C >= 0 symmetric, an eigenvalue lambda
    of the step matrix with eigenvector (x, v) solves P(lambda) x = 0,
    P(lambda) = (lambda - 1)^2 I + dt (lambda - 1) C + dt^2 lambda K. On the unit circle,
    lambda = e^(i phi), x^H P(lambda) x / lambda = (2 cos phi - 2) |x|^2 + dt (1 - e^(-i phi))
    x^H C x + dt^2 x^H K x, whose imaginary part dt sin(phi) x^H C x vanishes only for
    lambda = +-1 or C x = 0: lambda = 1 needs K x = 0 (none), and the undamped modes (C x = 0,
    an invariant subspace) keep |lambda| = 1 until dt omega = 2, where lambda = -1. So as dt
    grows from 0 (every |lambda| <= 1) an eigenvalue leaves the unit disc first through -1:
    at the flip root, and nothing grows below it (the bisection's check there). Just above it,
    P(-1 - GROWTH_TOLERANCE) with a negative eigenvalue proves a real eigenvalue below
    -1 - GROWTH_TOLERANCE (P(lambda) / lambda^2 -> I as lambda -> -inf): it grows (the check
    above). That eigenvector's x names the mode, as :func:`_growing` does from the step
    matrix's. Two symmetric eigenproblems of n against two nonsymmetric ones of 2 n.
    """
    n = len(stiff)
    if not n or not np.all(np.diag(stiff) > 0) or np.any(stiff - np.diag(np.diag(stiff))):
        return None
    scale = max(float(np.abs(damp).max()), 1e-300)
    try:  # C >= 0 (to round-off): sum_c b_c g_c g_c^T with b_c >= 0 is, by construction
        np.linalg.cholesky(damp + 1e-12 * scale * np.eye(n))
    except np.linalg.LinAlgError:
        return None
    root = _monotone_root(stiff, damp)
    if root is None:
        return None
    limit = 2 / root
    dt, value = limit * (1 + STEP_RESOLUTION), -(1 + GROWTH_TOLERANCE)
    pencil = (value - 1) ** 2 * np.eye(n) + dt * (value - 1) * damp + dt**2 * value * stiff
    lowest, vectors = eigh(pencil, subset_by_index=[0, 0])
    if lowest[0] >= 0:  # not proven to grow just above the root: the step matrix decides
        return None
    return _mode(stiff, damp, limit, vectors[:, 0], "euler")


def _reduced_implicit(blocks: np.ndarray, keep: np.ndarray) -> ImplicitDamping:
    """The implicit damping of the kept modes at a step dt: with (I + dt B) a = f and f zero
    on the dropped modes (nothing springs or damps there), the kept modes' accelerations
    solve (I + dt B_kk - dt^2 B_kd (I + dt B_dd)^-1 B_dk) a_k = f_k."""
    kk, kd = blocks[np.ix_(keep, keep)], blocks[np.ix_(keep, ~keep)]
    dd = blocks[np.ix_(~keep, ~keep)]

    def at(dt: float) -> np.ndarray:
        if not kd.size:
            return kk
        return kk - dt * kd @ np.linalg.solve(np.eye(len(dd)) + dt * dd, kd.T)
    return at


def _flip_step(stiff: np.ndarray, damp: np.ndarray, integrator: str,
               full: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> float:
    """The smallest step [s] at which the step matrix has the eigenvalue -1 (inf if none):
    2 / r for the largest real r > 0 with r^2 x = K x + r (C - 2 D) x (D the implicit damping:
    0, C, or ``full``'s body blocks), as the eigenvalues of the companion matrix
    [[0, I], [K, C - 2 D]] (mass-normalised modes; ``full``: (K, C, D) over every mode)."""
    if integrator == "discrete":
        return np.inf
    if full is not None:
        stiff, damp, implicit = full
    else:
        implicit = damp if integrator == "implicitfast" else np.zeros_like(damp)
    n = len(stiff)
    rate = damp - 2 * implicit
    root = _monotone_root(stiff, rate)
    if root is not None:
        return 2 / root
    companion = np.block([[np.zeros((n, n)), np.eye(n)], [stiff, rate]])
    roots = np.linalg.eigvals(companion)
    size = np.abs(roots).max()
    real = roots.real[(np.abs(roots.imag) <= 1e-9 * size) & (roots.real > 1e-9 * size)]
    return 2 / float(real.max()) if real.size else np.inf


def _monotone_root(stiff: np.ndarray, rate: np.ndarray) -> float | None:
    """The largest real r with Q(r) x = (r^2 I - r B - K) x = 0 (``stiff`` K, ``rate`` B, both
    symmetric), where it lies above b/2 (b the largest eigenvalue of B, or 0); None elsewhere.

    For s > r >= b/2, Q(s) - Q(r) = (s - r) ((s + r) I - B) is positive definite: there the
    smallest eigenvalue of Q(r) strictly increases with r, so where it is negative at b/2 it
    has one zero above, the largest root, which a Newton iteration kept inside a shrinking
    bracket finds (the derivative is x^T (2 r I - B) x, x its unit eigenvector). Where Q(b/2)
    is already positive definite the root, if any, lies below, where Q(r) need not be
    monotone: the caller then takes the companion matrix's eigenvalues. That cannot happen
    with K >= 0 (as here: K holds the modes' omega^2): with x B's top eigenvector, x^T Q(b/2) x
    = -b^2/4 - x^T K x < 0 unless b = 0 and K x = 0. One symmetric
    eigenvalue per iteration against the nonsymmetric eigenvalues of a matrix twice the size.
    """
    n = len(stiff)
    if not n:
        return None
    low = max(float(eigh(rate, eigvals_only=True, subset_by_index=[n - 1, n - 1])[0]), 0.0) / 2
    top = max(float(np.abs(np.linalg.eigvalsh(stiff)).max()), 0.0) if np.any(
        stiff - np.diag(np.diag(stiff))) else float(np.abs(np.diag(stiff)).max())
    high = 1.01 * (low + np.sqrt(low**2 + top)) + 1e-300  # r^2 - 2 low r - top > 0 above it

    def smallest(r: float) -> tuple[float, float]:  # Q(r)'s smallest eigenvalue and slope
        values, vectors = eigh(r * r * np.eye(n) - r * rate - stiff, subset_by_index=[0, 0])
        x = vectors[:, 0]
        return float(values[0]), float(2 * r - x @ rate @ x)

    value, _ = smallest(low)
    if value >= 0:
        return None
    r, (value, slope) = high, smallest(high)
    if value <= 0:
        return None
    for _ in range(200):
        if value > 0:
            high = r
        else:
            low = r
        step = value / slope if slope > 0 else np.inf
        guess = r - step
        if not low < guess < high:  # outside the bracket: bisect
            guess = (low + high) / 2
        if abs(guess - r) <= 1e-15 * r or high - low <= 1e-15 * high:
            return guess
        r = guess
        value, slope = smallest(r)
        if value == 0:
            return r
    return None


def _spectrum(stiff: np.ndarray, damp: np.ndarray, dt: float, integrator: str,
              implicit: ImplicitDamping | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The step matrix of a step of ``dt`` [s] (mass-normalised modes) and its eigenvalues."""
    matrix = step_matrix(stiff, damp, np.eye(len(stiff)), dt, integrator,
                         None if implicit is None else implicit(dt))
    return matrix, np.linalg.eigvals(matrix)


def _radius(values: np.ndarray) -> float:
    """The spectral radius of a matrix of eigenvalues ``values``."""
    return float(np.abs(values).max())


def _grows(stiff: np.ndarray, damp: np.ndarray, dt: float, integrator: str,
           implicit: ImplicitDamping | None = None) -> bool:
    """Whether a step of ``dt`` [s] has an eigenvalue of modulus above 1 (+ tolerance)."""
    if not np.isfinite(dt):
        return False
    return _radius(_spectrum(stiff, damp, dt, integrator, implicit)[1]) > 1 + GROWTH_TOLERANCE


def _scanned_step(stiff: np.ndarray, damp: np.ndarray, integrator: str, guess: float,
                  implicit: ImplicitDamping | None = None) -> float:
    """The bound by a scan up from a stable step and a bisection (inf if none grows)."""
    rate = max(float(np.sqrt(stiff.max())), float(np.linalg.eigvalsh(damp).max()))
    low = min(guess, 1.0 / rate) / 2
    while _grows(stiff, damp, low, integrator, implicit) and low * rate > 1e-9:
        low /= 2
    high = low * 1.25
    while not _grows(stiff, damp, high, integrator, implicit):
        low, high = high, high * 1.25
        if high * rate > 1e6:  # no step makes it grow
            return np.inf
    while high - low > STEP_RESOLUTION * low:
        middle = (low + high) / 2
        low, high = (low, middle) if _grows(stiff, damp, middle, integrator, implicit) \
            else (middle, high)
    return low


def _growing(stiff: np.ndarray, damp: np.ndarray, limit: float, integrator: str,
             implicit: ImplicitDamping | None = None,
             above: tuple[np.ndarray, np.ndarray] | None = None) -> StepBound:
    """The bound, with the vibration mode that dominates what grows just above it (``above``:
    the step matrix there and its eigenvalues, where already computed)."""
    dt = limit * (1 + STEP_RESOLUTION)
    matrix, values = above if above is not None else \
        _spectrum(stiff, damp, dt, integrator, implicit)
    shape = _eigenvector(matrix, values[int(np.argmax(np.abs(values)))])[:len(stiff)]
    return _mode(stiff, damp, limit, shape, integrator)


def _mode(stiff: np.ndarray, damp: np.ndarray, limit: float, shape: np.ndarray,
          integrator: str) -> StepBound:
    """The bound with the vibration mode that dominates ``shape`` (the growing eigenvector's
    displacements, in the kept modes' coordinates)."""
    k = int(np.argmax(np.abs(shape) ** 2 * (np.diag(stiff) + np.diag(damp) ** 2)))
    omega = float(np.sqrt(stiff[k, k]))
    zeta = float(damp[k, k] / (2 * omega)) if omega > 0 else np.inf
    return StepBound(float(limit), omega / (2 * np.pi), zeta, integrator)


def _eigenvector(matrix: np.ndarray, value: complex) -> np.ndarray:
    """The eigenvector of ``matrix`` for its eigenvalue ``value``, by inverse iteration: two
    solves with one factorisation of the matrix shifted just off ``value`` (all eigenvectors
    at once, ``numpy.linalg.eig``, cost twice the eigenvalues alone: a third of the centipede's
    step bound). Within eigenvalues equal to ``value``, any vector of theirs."""
    n = len(matrix)
    shift = value + 1e-10 * max(abs(value), 1.0)  # off the eigenvalue: a regular matrix
    factors = lu_factor(matrix - shift * np.eye(n))
    vector = np.random.default_rng(0).standard_normal(n).astype(np.result_type(shift, float))
    for _ in range(2):
        vector = lu_solve(factors, vector)
        vector /= np.linalg.norm(vector)
    return vector


def stable_timestep(result: Stiffness, integrator: str = "euler") -> tuple[float, float, float]:
    """The longest stable time step and the mode that sets it (:func:`step_bound`).

    Returns:
        (dt_max [s], that mode's frequency [Hz], its damping ratio [-]).
    """
    bound = step_bound(result, integrator)
    return bound.limit, bound.frequency, bound.damping_ratio
