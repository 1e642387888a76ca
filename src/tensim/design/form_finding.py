"""Form finding: node positions at which a topology's force densities are in equilibrium.

The force density method (Schek 1974; reviewed in Tibert & Pellegrino, "Review of
form-finding methods for tensegrity structures", Int. J. Space Struct. 18, 2003) treats every
rod and cable as a bar with force density q = t / L (> 0 in a cable, < 0 in a rod). With the
incidence matrix C (members x nodes) the nodes are in equilibrium when

    D X = 0,    D = C^T diag(q) C  (the force density matrix, nodes x nodes),

for the (nodes x 3) coordinates X. D always has the all-ones vector in its null space (a
translation); a form that spans three dimensions needs three more, so rank(D) <= n - 4, and
the forms are then the affine images of the null space (Zhang & Ohsaki, "Adaptive force
density method for form-finding problem of tensegrity structures", Int. J. Solids Struct. 43,
2006). With D positive semi-definite of rank exactly n - 4 and the members not on a conic at
infinity the form is super-stable (Connelly, "Rigidity and energy", Invent. Math. 66, 1982):
stable at any level of prestress and any cable stiffness.

Groups of members share one force density (and one length: they are the images of each other
under a symmetry of the form). Where every group's q is given, the form is the null space of
D, and a least-squares fit of the affine map (scipy.optimize.least_squares) makes each group's
members equally long and gives the groups their chosen lengths. Where some q are left free,
one least-squares problem finds the positions and those q together: node equilibrium, the
chosen lengths and equal lengths within each group, from a start in D's softest eigenvectors
(Zhang & Ohsaki's adaptive step). Either way, the answer is checked: equilibrium, a form that
spans 3D, and D's rank.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from tensim.design._errors import DesignError
from tensim.design.topology import Topology
from tensim.structure import Structure, structure_from_dict

RANK_TOLERANCE = 1e-8  # eigenvalues of D below this x the largest count as zero
EQUILIBRIUM_TOLERANCE = 1e-9  # largest node force imbalance / largest member force


@dataclasses.dataclass(frozen=True)
class Form:
    """A formed structure and how it was found.

    Attributes:
        structure: the structure at its form, each cable pretensioned by its force density.
        force_densities: group -> force density q of its members at the written prestress
            [N/m].
        lengths: group -> (shortest, longest) member length [m].
        rank: rank of the force density matrix D.
        nodes: number of nodes n (a 3D form needs rank <= n - 4).
        super_stable: D is positive semi-definite with rank n - 4 (Connelly's conditions on
            D; that the member directions lie on no conic at infinity is not checked).
        imbalance: largest node force imbalance / largest member force [-].
    """

    structure: Structure
    force_densities: dict[str, float]
    lengths: dict[str, tuple[float, float]]
    rank: int
    nodes: int
    super_stable: bool
    imbalance: float


@dataclasses.dataclass(frozen=True)
class _Problem:
    """The topology as arrays: member ends (m, 2), group of each member (m,), per group the
    given q and length (NaN where free), rods (m,) bool."""

    ends: np.ndarray
    group: np.ndarray
    q_given: np.ndarray
    length: np.ndarray
    rod: np.ndarray
    names: tuple[str, ...]
    n: int

    def density_matrix(self, q_groups: np.ndarray) -> np.ndarray:
        """(n, n) D = C^T diag(q) C for group force densities (n_groups,) [N/m]."""
        q = q_groups[self.group]
        d = np.zeros((self.n, self.n))
        i, j = self.ends.T
        np.add.at(d, (i, i), q)
        np.add.at(d, (j, j), q)
        np.add.at(d, (i, j), -q)
        np.add.at(d, (j, i), -q)
        return d

    def member_lengths(self, x: np.ndarray) -> np.ndarray:
        """(m,) member lengths of coordinates (n, 3) [m]."""
        return np.linalg.norm(x[self.ends[:, 0]] - x[self.ends[:, 1]], axis=1)

    def length_residuals(self, x: np.ndarray, scale: float) -> np.ndarray:
        """Relative misses of the chosen lengths, and each member's difference from its
        group's mean length (members of a group are images under a symmetry)."""
        lengths = self.member_lengths(x)
        mean = np.bincount(self.group, lengths) / np.bincount(self.group)
        target = self.length[self.group]
        chosen = np.isfinite(target)
        return np.r_[(lengths[chosen] - target[chosen]) / target[chosen],
                     (lengths - mean[self.group]) / scale]


    def length_jacobian(self, x: np.ndarray, scale: float) -> np.ndarray:
        """(rows of :meth:`length_residuals`, 3 n) their derivatives by the coordinates."""
        diff = x[self.ends[:, 0]] - x[self.ends[:, 1]]
        unit = diff / np.maximum(np.linalg.norm(diff, axis=1), 1e-300)[:, None]
        m = len(self.ends)
        per_node = np.zeros((m, self.n, 3))  # dL_i / dx
        per_node[np.arange(m), self.ends[:, 0]] += unit
        per_node[np.arange(m), self.ends[:, 1]] -= unit
        d_length = per_node.reshape(m, -1)
        sums = np.zeros((self.group.max() + 1, d_length.shape[1]))
        np.add.at(sums, self.group, d_length)
        d_mean = sums / np.bincount(self.group)[:, None]
        target = self.length[self.group]
        chosen = np.isfinite(target)
        return np.vstack([d_length[chosen] / target[chosen, None],
                          (d_length - d_mean[self.group]) / scale])


def _size_jacobian(x: np.ndarray, rough: np.ndarray | None) -> np.ndarray:
    """(0 or 1, 3 n) the derivative of :func:`_size_residual`."""
    if rough is None:
        return np.zeros((0, x.size))
    size = np.sqrt(((rough - rough.mean(axis=0)) ** 2).sum(axis=1).mean())
    centred = x - x.mean(axis=0)
    spread = np.sqrt((centred**2).sum(axis=1).mean())
    return (centred / (len(x) * spread * size)).reshape(1, -1)


def _problem(topology: Topology) -> _Problem:
    index = {name: i for i, name in enumerate(topology.nodes)}
    groups = tuple(topology.groups)
    ends = np.array([[index[a], index[b]] for a, b in (m.nodes for m in topology.members)])
    group = np.array([groups.index(m.group) for m in topology.members])
    q = np.array([np.nan if g.force_density is None else g.force_density
                  for g in topology.groups.values()])
    length = np.array([np.nan if g.length is None else g.length
                       for g in topology.groups.values()])
    rod = np.array([m.rod for m in topology.members])
    return _Problem(ends.reshape(-1, 2), group, q, length, rod, groups, len(topology.nodes))


def _null_space(d: np.ndarray) -> np.ndarray:
    """An orthonormal basis of D's null space with the all-ones direction (a translation)
    taken out."""
    values, vectors = np.linalg.eigh(d)
    zero = np.abs(values) <= RANK_TOLERANCE * max(np.abs(values).max(), 1e-300)
    null = vectors[:, zero]
    null = null - null.mean(axis=0)  # project out the translation
    u, sv, _ = np.linalg.svd(null, full_matrices=False)
    return u[:, sv > 1e-6]


def _size_residual(x: np.ndarray, rough: np.ndarray | None) -> np.ndarray:
    """Without a chosen length, the form keeps the rough positions' size."""
    if rough is None:
        return np.zeros(0)
    size = np.sqrt(((rough - rough.mean(axis=0)) ** 2).sum(axis=1).mean())
    return np.array([np.sqrt(((x - x.mean(axis=0)) ** 2).sum(axis=1).mean()) / size - 1.0])


def _given_densities(problem: _Problem, rough: np.ndarray | None) -> tuple[np.ndarray,
                                                                             np.ndarray]:
    """Every group's q given: the affine image of D's null space that best meets the groups'
    lengths. Returns (coordinates (n, 3) [m], q (n_groups,))."""
    q = problem.q_given
    sized = None if np.isfinite(problem.length).any() else rough  # lengths set the size
    null = _null_space(problem.density_matrix(q))
    if null.shape[1] < 3:
        rank = problem.n - 1 - null.shape[1]
        raise DesignError(
            f"no three-dimensional form has these force densities: their force density matrix "
            f"D has rank {rank} for {problem.n} nodes, and a form in 3D needs rank "
            f"<= {problem.n - 4} (its equilibrium positions span "
            f"{null.shape[1]} dimension(s) besides translation); leave the force_density of "
            "one or more groups out (the form finding then chooses it) or change them")
    start = (np.linalg.lstsq(null, rough - rough.mean(axis=0), rcond=None)[0]
             if rough is not None else np.eye(null.shape[1], 3))
    scale = float(np.nanmean(problem.length)) if np.isfinite(problem.length).any() else 1.0

    def residuals(y: np.ndarray) -> np.ndarray:
        x = null @ y.reshape(-1, 3)
        return np.r_[problem.length_residuals(x, scale), _size_residual(x, sized)]

    from scipy.optimize import least_squares  # imported on use: see design/__init__
    fit = least_squares(residuals, start.ravel(), method="trf", xtol=1e-15, ftol=1e-15,
                        gtol=1e-15, max_nfev=2000)
    return null @ fit.x.reshape(-1, 3), q


def _free_densities(problem: _Problem, rough: np.ndarray | None) -> tuple[np.ndarray,
                                                                            np.ndarray]:
    """Some groups' q free: positions and those q by least squares (equilibrium, lengths),
    from D's softest eigenvectors at a guessed q. Returns (coordinates, q)."""
    free = np.isnan(problem.q_given)
    rods = np.zeros(len(problem.q_given), dtype=bool)
    rods[problem.group[problem.rod]] = True
    guess = np.where(free, np.where(rods, -1.0, 1.0), problem.q_given)
    if rough is None:
        d = problem.density_matrix(guess)
        ones = np.full(problem.n, 1.0 / np.sqrt(problem.n))
        shifted = d + (np.abs(d).max() + 1.0) * 10 * np.outer(ones, ones)
        x0 = np.linalg.eigh(shifted)[1][:, :3]  # the softest shapes other than translation
    else:
        x0 = rough - rough.mean(axis=0)
    target = problem.length[problem.group]
    if np.isfinite(target).any():
        chosen = np.isfinite(target)
        x0 = x0 * np.mean(target[chosen] / problem.member_lengths(x0)[chosen])
    scale = float(np.mean(problem.member_lengths(x0)))
    q_scale = float(np.abs(guess).max())
    normalise = not np.isfinite(problem.q_given).any()
    cables = ~rods & free
    sized = None if np.isfinite(problem.length).any() else rough  # lengths set the size

    def unpack(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = guess.copy()
        q[free] = z[3 * problem.n:]
        return z[:3 * problem.n].reshape(-1, 3), q

    def residuals(z: np.ndarray) -> np.ndarray:
        x, q = unpack(z)
        force = problem.density_matrix(q) @ x / (q_scale * scale)
        extra = [np.mean(q[cables]) / q_scale - 1.0] if normalise and cables.any() else []
        return np.r_[force.ravel(), problem.length_residuals(x, scale), _size_residual(
            x, sized), extra]

    units = [problem.density_matrix(np.eye(len(guess))[g]) for g in np.flatnonzero(free)]

    def jacobian(z: np.ndarray) -> np.ndarray:
        x, q = unpack(z)
        force_x = np.kron(problem.density_matrix(q), np.eye(3)) / (q_scale * scale)
        force_q = np.array([(u @ x).ravel() for u in units]).T / (q_scale * scale)
        n_free = len(units)
        lengths = problem.length_jacobian(x, scale)
        size = _size_jacobian(x, sized)
        rows = [np.hstack([force_x, force_q.reshape(-1, n_free)]),
                np.hstack([lengths, np.zeros((len(lengths), n_free))]),
                np.hstack([size, np.zeros((len(size), n_free))])]
        if normalise and cables.any():
            rows.append(np.r_[np.zeros(3 * problem.n),
                              cables[free] / (cables.sum() * q_scale)][None, :])
        return np.vstack(rows)

    lower = np.r_[np.full(3 * problem.n, -np.inf), np.where(rods[free], -np.inf, 0.0)]
    upper = np.r_[np.full(3 * problem.n, np.inf), np.where(rods[free], 0.0, np.inf)]
    start = np.r_[x0.ravel(), np.clip(guess[free], lower[3 * problem.n:] + 1e-12,
                                      upper[3 * problem.n:] - 1e-12)]
    from scipy.optimize import least_squares
    fit = least_squares(residuals, start, jac=jacobian, bounds=(lower, upper), method="trf",
                        xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000, x_scale="jac")
    return unpack(fit.x)


def _orient(x: np.ndarray, topology: Topology) -> np.ndarray:
    """Places the form: onto the rough positions where three or more are given (best proper
    rotation and translation), else its symmetric axis (the principal axis unlike the other
    two) along z, centred on the z axis, the file's first node on the lower side in the
    x-z half-plane of x > 0 and the lowest node at the topology's elevation."""
    given = [i for i, n in enumerate(topology.nodes) if n in topology.positions]
    if len(given) >= 3:
        target = np.array([topology.positions[topology.nodes[i]] for i in given])
        a, b = x[given] - x[given].mean(axis=0), target - target.mean(axis=0)
        if np.linalg.matrix_rank(b, tol=1e-9 * max(np.abs(b).max(), 1e-300)) >= 2:
            u, _, vt = np.linalg.svd(a.T @ b)  # Kabsch
            flip = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
            turn = u @ flip @ vt
            return (x - x[given].mean(axis=0)) @ turn + target.mean(axis=0)
    centred = x - x.mean(axis=0)
    values, axes = np.linalg.eigh(centred.T @ centred)
    if values[1] - values[0] > values[2] - values[1]:  # the smallest is the odd one out
        axes = axes[:, [1, 2, 0]]
    axes[:, 2] *= np.sign(np.linalg.det(axes))  # a proper rotation keeps the handedness
    placed = centred @ axes
    if placed[0, 2] > 0:  # the file's first node on the lower side: half a turn about x
        placed[:, 1:] *= -1.0
    angle = np.arctan2(placed[0, 1], placed[0, 0])  # and on the +x side of the z axis
    turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    placed[:, :2] = placed[:, :2] @ turn
    placed[:, 2] += topology.elevation - placed[:, 2].min()
    return placed


def _structure(topology: Topology, x: np.ndarray, tensions: dict[str, float]) -> Structure:
    """The topology's file with the form's positions and the cables' pretensions."""
    data: dict[str, Any] = {k: v for k, v in topology.data.items()
                            if k not in ("groups", "min_tension", "elevation")}
    data["nodes"] = [{**raw, "position": [float(v) for v in x[i]]}
                     for i, raw in enumerate(topology.data["nodes"])]
    data["cables"] = [{**raw, "pretension": tensions[raw["name"]]}
                      for raw in topology.data.get("cables") or []]
    return structure_from_dict(data)


def form(topology: Topology) -> Form:
    """The form of ``topology``: node positions in equilibrium, its cables pretensioned.

    Raises:
        DesignError: the force densities have no 3D form (D's rank too high), or no form in
            equilibrium was found with the groups' values.
        StructureError: the formed structure is invalid (e.g. a pretension above k L).
    """
    problem = _problem(topology)
    complete = len(topology.positions) == problem.n
    rough = np.array([topology.positions[n] for n in topology.nodes]) if complete else None
    if not np.isfinite(problem.length).any() and rough is None:
        raise DesignError(f"{topology.name}: nothing sets the form's size; give one group a "
                          "length (e.g. the rods') or every node a rough position")
    if not np.isfinite(problem.q_given).all():
        x, q = _free_densities(problem, rough)
    else:
        x, q = _given_densities(problem, rough)
    x = _orient(x, topology)
    lengths = problem.member_lengths(x)
    forces = q[problem.group] * lengths
    imbalance = float(np.abs(problem.density_matrix(q) @ x).max() / np.abs(forces).max())
    centred = x - x.mean(axis=0)
    spread = np.linalg.svd(centred, compute_uv=False)
    idle = [g for k, g in enumerate(problem.names) if abs(q[k]) < 1e-6 * np.abs(q).max()]
    worst = ("is flat" if spread[2] < 1e-6 * spread[0] else
             f"leaves {imbalance:.2g} of the largest member force unbalanced"
             if imbalance > EQUILIBRIUM_TOLERANCE else
             f"needs no force in group {idle[0]!r}" if idle else
             "collapses a member" if lengths.min() < 1e-6 * lengths.max() else None)
    if worst is not None:
        raise DesignError(
            f"{topology.name}: no form in equilibrium found with these groups (the nearest "
            f"{worst}); give more groups a force_density, or fewer a length, or rough "
            "positions nearer a tensegrity form")
    cable = ~problem.rod
    level = 1.0
    if topology.min_tension is not None:
        level = topology.min_tension / forces[cable].min()
    elif not np.isfinite(problem.q_given).any():
        raise DesignError(f"{topology.name}: no group gives a force density, so nothing sets "
                          "the prestress level; give min_tension [N] (or --min-tension)")
    values = np.linalg.eigvalsh(problem.density_matrix(q))
    tol = RANK_TOLERANCE * np.abs(values).max()
    rank = int((np.abs(values) > tol).sum())
    tensions = {m.name: float(level * f) for m, f in zip(topology.members, forces, strict=True)
                if not m.rod}
    by_group = {g: lengths[problem.group == k] for k, g in enumerate(problem.names)}
    return Form(_structure(topology, x, tensions),
                {g: float(level * q[k]) for k, g in enumerate(problem.names)},
                {g: (float(v.min()), float(v.max())) for g, v in by_group.items()},
                rank, problem.n, bool(values.min() > -tol and rank == problem.n - 4), imbalance)
