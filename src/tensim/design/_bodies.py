"""Rigid-body kinematics of a structure at its build pose, for the design analyses.

Rods that share a node form one rigid body (as when the structure is compiled); a node on no
rod that carries a point mass is a body of its own; fixed nodes (and the bodies they touch)
belong to the world. Each free body b moves by a small twist (v_b, w_b): a translation of its
centre of mass c_b [m] and a rotation vector [rad]. A point at r = p - c_b on it moves by
dp = v_b + w_b x r, so its Jacobian is [I, -[r]x]; to second order in w (the exponential map)
p(w) = c_b + r + w x r + (w (w . r) - r |w|^2) / 2.

Coordinates a body cannot use are left out through a basis ``T`` (orthonormal columns):
a body whose points lie on one line (a single rod) has no spin about that line, a point-mass
body no rotation at all. The reduced coordinates q = T^T x then count the degrees of freedom
of Pellegrino and Calladine's formula.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.linalg import null_space

from tensim.sim._laws import cable_tension
from tensim.structure import Structure, StructureError, mass_properties

GRAVITY = 9.81  # m/s^2


def skew(r: np.ndarray) -> np.ndarray:
    """(3, 3) matrix [r]x with [r]x a = r x a."""
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


@dataclasses.dataclass(frozen=True)
class Bodies:
    """The free rigid bodies of a structure and their reduced coordinates.

    Attributes:
        names: (n_bodies,) body names (rigid groups of the structure).
        node_body: node name -> body index, or -1 for a node held by the world.
        mass: (n_bodies,) masses [kg].
        com: (n_bodies, 3) centres of mass [m].
        inertia: (n_bodies, 3, 3) inertia tensors about the centres of mass [kg m^2].
        basis: (6 n_bodies, n_dof) T, orthonormal columns spanning the usable twists.
        dof_body: (n_dof,) the body each reduced coordinate belongs to.
    """

    names: tuple[str, ...]
    node_body: dict[str, int]
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    basis: np.ndarray
    dof_body: np.ndarray

    @property
    def n_full(self) -> int:
        """Number of full twist coordinates, 6 per free body."""
        return 6 * len(self.names)

    @property
    def n_dof(self) -> int:
        """Number of reduced coordinates (degrees of freedom)."""
        return int(self.basis.shape[1])

    def point_jacobian(self, body: int, point: np.ndarray) -> np.ndarray:
        """(3, 6 n_bodies) d(point)/d(twists) of a point fixed to ``body`` (zero for -1)."""
        jac = np.zeros((3, self.n_full))
        if body >= 0:
            jac[:, 6 * body:6 * body + 3] = np.eye(3)
            jac[:, 6 * body + 3:6 * body + 6] = -skew(point - self.com[body])
        return jac

    def mass_matrix(self) -> np.ndarray:
        """(n_dof, n_dof) reduced mass matrix T^T diag(m I, I_c) T [kg, kg m^2]."""
        full = np.zeros((self.n_full, self.n_full))
        for b in range(len(self.names)):
            full[6 * b:6 * b + 3, 6 * b:6 * b + 3] = self.mass[b] * np.eye(3)
            full[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = self.inertia[b]
        return self.basis.T @ full @ self.basis

    def gravity_force(self, gravity: float = GRAVITY) -> np.ndarray:
        """(n_dof,) generalized weight: -m g along z on each body's translation [N]."""
        full = np.zeros(self.n_full)
        full[2::6] = -self.mass * gravity
        return self.basis.T @ full

    def rigid_motions(self) -> np.ndarray:
        """(n_dof, n_rigid) the whole structure's rigid motions, orthonormal; none if any part
        is held by the world."""
        if any(b < 0 for b in self.node_body.values()) or not self.names:
            return np.zeros((self.n_dof, 0))
        motions = []
        for axis in np.eye(3):
            motions.append(np.tile(np.r_[axis, 0.0, 0.0, 0.0], len(self.names)))
            motions.append(np.concatenate([np.r_[np.cross(axis, c), axis] for c in self.com]))
        reduced = self.basis.T @ np.array(motions).T
        u, sv, _ = np.linalg.svd(reduced, full_matrices=False)
        return u[:, sv > 1e-9 * max(sv.max(), 1.0)]


def bodies(structure: Structure) -> Bodies:
    """The free rigid bodies of ``structure`` at its build pose.

    Raises:
        StructureError: a cable wraps around rods (its path is only known once compiled).
    """
    for cable in structure.cables:
        if cable.wrap:
            raise StructureError("the design analyses take straight or routed cables; this one "
                                 "wraps around rods", item=f"cable {cable.name!r}")
    groups = [g for g in structure.rigid_groups() if not g.fixed]
    node_body = {n.name: -1 for n in structure.nodes}
    props = [mass_properties(structure, g) for g in groups]
    blocks = []
    for b, (group, prop) in enumerate(zip(groups, props, strict=True)):
        for node in group.nodes:
            node_body[node] = b
        offsets = np.array([structure.position(n) - prop.com for n in group.nodes])
        blocks.append(_body_basis(offsets))
    n_full = 6 * len(groups)
    n_dof = sum(block.shape[1] for block in blocks)
    basis = np.zeros((n_full, n_dof))
    dof_body = np.zeros(n_dof, dtype=int)
    col = 0
    for b, block in enumerate(blocks):
        basis[6 * b:6 * b + 6, col:col + block.shape[1]] = block
        dof_body[col:col + block.shape[1]] = b
        col += block.shape[1]
    return Bodies(tuple(g.name for g in groups), node_body, np.array([p.mass for p in props]),
                  np.array([p.com for p in props]).reshape(-1, 3),
                  np.array([p.inertia for p in props]).reshape(-1, 3, 3), basis, dof_body)


def _body_basis(offsets: np.ndarray) -> np.ndarray:
    """(6, d) usable twists of a body whose nodes sit at ``offsets`` from its COM.

    All translations; rotations except those that move no node (spin about the line through
    collinear nodes, any rotation of a single point).
    """
    spread = offsets - offsets.mean(axis=0)
    rank = np.linalg.matrix_rank(spread, tol=1e-9) if len(offsets) > 1 else 0
    if rank >= 2:
        rotations = np.eye(3)
    elif rank == 1:
        axis = spread[np.argmax(np.linalg.norm(spread, axis=1))]
        rotations = null_space(axis[None, :] / np.linalg.norm(axis))
    else:
        rotations = np.zeros((3, 0))
    block = np.zeros((6, 3 + rotations.shape[1]))
    block[:3, :3] = np.eye(3)
    block[3:, 3:] = rotations
    return block


@dataclasses.dataclass(frozen=True)
class CableGeometry:
    """Lengths and their first and second derivatives for every cable at the build pose.

    Attributes:
        lengths: (n_cables,) anchor-to-anchor path lengths L [m].
        gradients: (n_cables, n_dof) dL/dq.
        node_forces: node name -> (3, n_cables) force on that node per newton of each cable's
            tension (unit vectors toward the neighbouring points of its path) [-].
        spans: per span (cable index, full-coordinate indices (<= 12,), local d2L/dq2 block).
        basis: (6 n_bodies, n_dof) the bodies' coordinate basis T.
    """

    lengths: np.ndarray
    gradients: np.ndarray
    node_forces: dict[str, np.ndarray]
    spans: tuple[tuple[int, np.ndarray, np.ndarray], ...]
    basis: np.ndarray

    def geometric(self, tensions: np.ndarray) -> np.ndarray:
        """(n_dof, n_dof) sum_c t_c d2L_c/dq2 for tensions (n_cables,) [N]."""
        full = np.zeros((self.basis.shape[0],) * 2)
        for cable, index, block in self.spans:
            # np.add.at: a span with both ends on one body repeats its indices
            np.add.at(full, np.ix_(index, index), tensions[cable] * block)
        return self.basis.T @ full @ self.basis


def cable_geometry(structure: Structure, body_set: Bodies) -> CableGeometry:
    """Lengths, dL/dq and d2L/dq2 of every cable (each span summed) at the build pose."""
    n = len(structure.cables)
    grads = np.zeros((n, body_set.n_full))
    lengths = np.zeros(n)
    node_forces = {name: np.zeros((3, n)) for name in body_set.node_body}
    spans = []
    for c, cable in enumerate(structure.cables):
        points = structure.cable_points(cable)
        owners = [body_set.node_body[name] for name in cable.path]
        for j in range(len(points) - 1):
            index, g, h, length, unit = _span(body_set, owners[j], points[j], owners[j + 1],
                                              points[j + 1])
            np.add.at(grads[c], index, g)  # both ends on one body repeat indices
            spans.append((c, index, h))
            lengths[c] += length
            node_forces[cable.path[j]][:, c] += unit
            node_forces[cable.path[j + 1]][:, c] -= unit
    return CableGeometry(lengths, grads @ body_set.basis, node_forces, tuple(spans),
                         body_set.basis)


def _span(body_set: Bodies, body_a: int, a: np.ndarray, body_b: int, b: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, np.ndarray]:
    """Gradient and Hessian of one span's length |b - a| on the twists of its (<= 2) bodies.

    dL = e . dd with d = b - a; d2L = dd^T (I - e e^T) dd / L + sum_k e_k d2(d_k), where a
    point at r on body i contributes d2(e . p) = (e r^T + r e^T) / 2 - (e . r) I to body i's
    rotation block (the exponential map's second-order term).

    Returns:
        (full-coordinate indices, gradient, Hessian block, length [m], unit vector a -> b).
    """
    diff = b - a
    length = float(np.linalg.norm(diff))
    unit = diff / length
    ends = [(body, point, sign) for body, point, sign in ((body_a, a, -1.0), (body_b, b, 1.0))
            if body >= 0]
    index = np.concatenate([np.arange(6 * body, 6 * body + 6) for body, _, _ in ends]) \
        if ends else np.zeros(0, dtype=int)
    jac = np.zeros((3, len(index)))
    hess_points = np.zeros((len(index), len(index)))
    for k, (body, point, sign) in enumerate(ends):
        r = point - body_set.com[body]
        jac[:, 6 * k:6 * k + 3] = sign * np.eye(3)
        jac[:, 6 * k + 3:6 * k + 6] = -sign * skew(r)
        block = 0.5 * (np.outer(unit, r) + np.outer(r, unit)) - (unit @ r) * np.eye(3)
        hess_points[6 * k + 3:6 * k + 6, 6 * k + 3:6 * k + 6] = sign * block
    hess = jac.T @ (np.eye(3) - np.outer(unit, unit)) @ jac / length + hess_points
    return index, unit @ jac, hess, length, unit


@dataclasses.dataclass(frozen=True)
class BuildPose:
    """A structure's free rigid bodies and cable geometry at its build pose, computed once per
    analysis and handed to each of its parts.

    Attributes:
        bodies: the free rigid bodies.
        geometry: the cables' lengths and derivatives on those bodies' coordinates.
    """

    bodies: Bodies
    geometry: CableGeometry


def build_pose(structure: Structure) -> BuildPose:
    """The rigid bodies and cable geometry of ``structure`` at its build pose.

    Raises:
        StructureError: a cable wraps around rods (see :func:`bodies`).
    """
    body_set = bodies(structure)
    return BuildPose(body_set, cable_geometry(structure, body_set))


def cable_tensions(structure: Structure, lengths: np.ndarray | None = None) -> np.ndarray:
    """(n_cables,) static tensions k max(0, L - l0) [N] (the cable law at rest, paper eq. 1-2),
    at the given lengths [m] or the build pose's."""
    if lengths is None:
        lengths = np.array([structure.cable_length(c) for c in structure.cables])
    rest = np.array([structure.rest_length(c) for c in structure.cables])
    stiffness = np.array([c.stiffness for c in structure.cables])
    zeros = np.zeros(len(rest))
    return cable_tension(np.asarray(lengths, dtype=float), zeros, rest, stiffness, zeros)[0]
