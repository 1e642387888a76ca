"""Inverse statics: the rest lengths that hold chosen nodes displaced, standing on the ground.

"Given I want to displace a node in a direction, which cables should I pull?" The robot stands
on its lowest nodes (its feet), which stick where they are (static friction; the result reports
the friction each foot then needs). For rest lengths l0 the static pose q*(l0) minimises

    V(q) = sum_c k_c max(0, L_c(q) - l0_c)^2 / 2 + sum_b m_b g z_b(q)
           + K_pin |feet(q) - feet_0|^2 / 2

(Newton's method on the tangent stiffness of :mod:`tensim.design.stiffness`, re-linearised at
every pose; K_pin a stiff spring that holds each foot). At equilibrium K dq = A diag(k) dl0,
so the chosen nodes move by J K^-1 A diag(k) dl0 (J their Jacobian). Each step then solves a
linear program for the rest-length changes of least total |l0 - l0_start| that bring the nodes
to their targets with every tension (linearised, t + diag(k)(A^T K^-1 A diag(k) - I) dl0)
within [min_tension, max_tension] and every rest length >= min_rest_length (a cable without
a motor keeps its own). When no step exists the displacement is scaled back until one does
(bisection) and the error says how far the motors reach. Slack cables, contact forces other
than at the feet and sliding are outside this model. The robot gets there when its motors wind
from its standing pose to the answer (:class:`RestCommand`); the tests simulate that. (A robot
built with those rest lengths and dropped lands elsewhere: its feet slide while it springs into
shape.)
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.linalg import null_space

from tensim.control.rest import RestCommand
from tensim.design._blas import one_blas_thread
from tensim.design._bodies import GRAVITY, Bodies, bodies, cable_geometry, cable_tensions
from tensim.design._errors import DesignError
from tensim.structure import Structure, StructureError

GROUND_TOLERANCE = 1e-3  # m: nodes this close to the lowest node's height are feet
PIN_STIFFNESS = 1e6  # N/m: the spring that holds each foot (it moves ~ force / 1e6 m)
TOLERANCE = 1e-3  # m: default of how close the static pose must bring each target node
TRUST = 5e-3  # m: largest rest-length change of one linearised step
FRICTION_USE = 0.5  # the statics may use this fraction of the feet's friction (the rest is
# margin for the motion there and MuJoCo's soft, slightly sliding contacts)
MISS_WEIGHT = 1e3  # a metre of target miss costs as much as this many metres of rest change


@dataclasses.dataclass(frozen=True)
class InverseStatics:
    """Rest lengths that make a displaced pose a static equilibrium on the ground.

    Attributes:
        cables: (n_cables,) cable names.
        rest_lengths: (n_cables,) commanded rest lengths [m].
        change: (n_cables,) rest length minus the structure's own [m].
        tensions: (n_cables,) tensions at the target pose [N].
        target: the structure in its static pose under those rest lengths.
        feet: foot node -> (3,) ground force on it at the target [N].
        friction_needed: foot node -> tangential / normal force there [-].
    """

    def command(self, speed: float | None = None) -> RestCommand:
        """The controller that winds the motors to these rest lengths, at ``speed`` [m/s]
        (None: at their max_speed)."""
        return RestCommand(self.cables, tuple(float(r) for r in self.rest_lengths), speed)

    cables: tuple[str, ...]
    rest_lengths: np.ndarray
    change: np.ndarray
    tensions: np.ndarray
    target: Structure
    feet: dict[str, np.ndarray]
    friction_needed: dict[str, float]


def feet(structure: Structure) -> tuple[str, ...]:
    """The nodes within :data:`GROUND_TOLERANCE` of the lowest node's height."""
    lowest = min(n.position[2] for n in structure.nodes)
    return tuple(n.name for n in structure.nodes if n.position[2] <= lowest + GROUND_TOLERANCE)


def on_ground(structure: Structure) -> Structure:
    """The structure lowered (or raised) until its lowest node's sphere or rod touches z = 0.

    Rest lengths are kept (pretensions become rest lengths first), so only the pose moves.
    """
    radius = {n.name: 0.0 for n in structure.nodes}
    for rod in structure.rods:
        for node in rod.nodes:
            radius[node] = max(radius[node], rod.radius)
    for mass in structure.point_masses:
        radius[mass.node] = max(radius[mass.node], mass.radius)
    lift = -min(n.position[2] - radius[n.name] for n in structure.nodes)
    explicit = with_rest_lengths(structure, np.array([structure.rest_length(c)
                                                      for c in structure.cables]))
    return dataclasses.replace(explicit, nodes=tuple(
        dataclasses.replace(n, position=(n.position[0], n.position[1], n.position[2] + lift))
        for n in structure.nodes))


def with_rest_lengths(structure: Structure, rest: np.ndarray) -> Structure:
    """A copy whose cables have the given rest lengths [m] (no pretension)."""
    return dataclasses.replace(structure, cables=tuple(
        dataclasses.replace(c, rest_length=float(r), pretension=None)
        for c, r in zip(structure.cables, rest, strict=True)))


def _move(structure: Structure, body_set: Bodies, twist: np.ndarray) -> Structure:
    """The structure with every free body moved by its full twist (exact rotation)."""
    from scipy.spatial.transform import Rotation  # imported on use: see design/__init__

    nodes = []
    for node in structure.nodes:
        b = body_set.node_body[node.name]
        p = np.asarray(node.position)
        if b >= 0:
            c = body_set.com[b]
            p = c + twist[6 * b:6 * b + 3] + Rotation.from_rotvec(
                twist[6 * b + 3:6 * b + 6]).apply(p - c)
        nodes.append(dataclasses.replace(node, position=tuple(p)))
    try:
        return dataclasses.replace(structure, nodes=tuple(nodes))
    except StructureError as err:  # the step crossed a cable's anchors (anchor_offset)
        raise DesignError(f"the static solve stepped to a pose the structure cannot take: "
                          f"{err}; no static pose near this one") from None


@dataclasses.dataclass(frozen=True)
class _Linear:
    """The static pose's linearisation: stiffness, length gradients, tensions."""

    pose: Structure
    body_set: Bodies
    stiffness: np.ndarray  # (n_dof, n_dof)
    gradients: np.ndarray  # (n_cables, n_dof) dL/dq
    tensions: np.ndarray  # (n_cables,) [N]
    taut: np.ndarray  # (n_cables,) bool
    force: np.ndarray  # (n_dof,) dV/dq [N]
    anchors: dict[str, np.ndarray]  # pinned node -> where it is held [m]

    @property
    def feet(self) -> tuple[str, ...]:
        """The pinned nodes."""
        return tuple(self.anchors)


def _linearise(pose: Structure, anchors: dict[str, np.ndarray], gravity: float,
               loads: dict[str, np.ndarray] | None = None,
               held: dict[str, np.ndarray] | None = None) -> _Linear:
    body_set = bodies(pose)
    geometry = cable_geometry(pose, body_set)
    rest = np.array([pose.rest_length(c) for c in pose.cables])
    k = np.array([c.stiffness for c in pose.cables])
    taut = geometry.lengths > rest
    tensions = cable_tensions(pose, geometry.lengths)
    grads = geometry.gradients
    stiffness = (grads.T * (k * taut)) @ grads + geometry.geometric(tensions)
    force = grads.T @ tensions - body_set.gravity_force(gravity)
    for name, load in (loads or {}).items():  # external node forces: -J^T F
        force -= (body_set.point_jacobian(body_set.node_body[name], pose.position(name))
                  @ body_set.basis).T @ load
    for name, anchor in anchors.items():
        jac = body_set.point_jacobian(body_set.node_body[name], pose.position(name)) \
            @ body_set.basis
        # a pin holds its node along the directions ``held`` gives (all three by default)
        along = np.eye(3) if held is None else held[name].T @ held[name]
        stiffness += PIN_STIFFNESS * jac.T @ along @ jac
        force += PIN_STIFFNESS * jac.T @ along @ (pose.position(name) - anchor)
    return _Linear(pose, body_set, stiffness, grads, tensions, taut, force, anchors)


def _sliding_feet(anchors: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The held directions ((k, 3) rows) of feet on frictionless ground (see :func:`settle`).

    Raises:
        DesignError: fewer than two feet apart on the ground (its turn is not held).
    """
    names = list(anchors)
    across = np.zeros(3)
    if len(names) >= 2:
        line = anchors[names[1]] - anchors[names[0]]
        across = np.array([-line[1], line[0], 0.0])
    if np.linalg.norm(across) < 1e-9:
        raise DesignError(f"feet {names} on frictionless ground: two feet apart on the "
                          "ground are needed to hold its turn")
    up = np.array([[0.0, 0.0, 1.0]])
    held = {n: up for n in names}
    held[names[0]] = np.eye(3)
    held[names[1]] = np.vstack([up, across / np.linalg.norm(across)])
    return held


def _newton_step(lin: _Linear) -> np.ndarray:
    """-K^-1 dV/dq; a free structure (nothing pinned) takes no rigid-body motion (its load
    balances itself, and K is singular along those motions)."""
    rigid = lin.body_set.rigid_motions() if not lin.anchors else np.zeros((len(lin.force), 0))
    if not rigid.shape[1]:
        return -np.linalg.lstsq(lin.stiffness, lin.force, rcond=1e-12)[0]
    keep = np.eye(len(lin.force)) - rigid @ rigid.T
    scale = np.abs(lin.stiffness).max()
    return -np.linalg.solve(keep @ lin.stiffness @ keep + scale * rigid @ rigid.T,
                            keep @ lin.force)


def _posed(structure: Structure, start: Structure) -> Structure:
    """``structure`` (its cables and rest lengths) with the node positions of ``start``."""
    names = [n.name for n in structure.nodes]
    if [n.name for n in start.nodes] != names:
        raise DesignError(f"{structure.name}: the start pose {start.name!r} has other nodes "
                          "than the structure; expected the same nodes in the same order")
    return dataclasses.replace(structure, nodes=start.nodes)


@one_blas_thread
def settle(structure: Structure, pinned: tuple[str, ...], gravity: float = GRAVITY,
           iterations: int = 100, loads: dict[str, np.ndarray] | None = None,
           start: Structure | None = None, sliding: bool = False) -> _Linear:
    """The static pose of ``structure`` (explicit rest lengths) with ``pinned`` nodes held
    where ``structure`` has them, under gravity and external node ``loads`` (node -> (3,)
    world-frame force [N]); Newton's method from the node positions of ``start`` (default:
    ``structure``'s). The rest lengths are always ``structure``'s: ``start`` lends its pose only.

    With ``sliding``, the pinned nodes are feet on frictionless ground: each is held only in
    height, except that the first is also held across the ground and the second across the
    line from the first (the three rigid motions in the ground's plane, which friction needs
    not resist). The pose is then the one in which the ground pushes only straight up, so the
    robot stands without leaning on friction (no creep of soft contacts).

    Raises:
        DesignError: no static pose found (the structure folds or falls).
    """
    anchors = {n: structure.position(n) for n in pinned}
    held = _sliding_feet(anchors) if sliding else None
    pose = structure if start is None else _posed(structure, start)
    size = float(np.ptp([n.position for n in structure.nodes], axis=0).max())
    for _ in range(iterations):
        lin = _linearise(pose, anchors, gravity, loads, held)
        step = _newton_step(lin)
        longest = np.abs(step).max()
        if longest > 0.05 * size:  # keep each step where the linearisation holds
            step *= 0.05 * size / longest
        pose = _move(pose, lin.body_set, lin.body_set.basis @ step)
        if longest < 1e-12 * max(size, 1.0):
            return _linearise(pose, anchors, gravity, loads, held)
    lin = _linearise(pose, anchors, gravity, loads, held)
    if np.abs(lin.force).max() > 1e-6 * max(np.abs(lin.tensions).max(), 1.0):
        raise DesignError(f"{structure.name}: no static pose found on its feet "
                          f"({', '.join(pinned)}): it folds or falls under gravity")
    return lin


def _step(lin: _Linear, structure: Structure, targets: dict[str, np.ndarray],
          rest: np.ndarray, start: np.ndarray, min_tension: float) -> np.ndarray:
    """Rest-length changes toward the targets (linearised): least target miss first, then least
    total change; every tension stays within its limits."""
    n = len(rest)
    k = np.array([c.stiffness for c in structure.cables]) * lin.taut
    pull = lin.gradients.T * k  # generalized force per metre of rest-length shortening
    # dq / dl0 with the feet held exactly: motions in the null space of the feet's Jacobian
    free = null_space(np.vstack([lin.body_set.point_jacobian(
        lin.body_set.node_body[f], lin.pose.position(f)) for f in lin.feet])
        @ lin.body_set.basis) if lin.feet else np.eye(lin.body_set.n_dof)
    sens = free @ np.linalg.lstsq(free.T @ lin.stiffness @ free, free.T @ pull,
                                  rcond=1e-12)[0]
    jac = np.vstack([lin.body_set.point_jacobian(lin.body_set.node_body[t], lin.pose.position(t))
                     for t in targets]) @ lin.body_set.basis
    error = np.concatenate([g - lin.pose.position(t) for t, g in targets.items()])
    e = len(error)
    tension = k[:, None] * (lin.gradients @ sens - np.eye(n))  # dt / dl0
    upper = np.array([c.motor.max_tension for c in structure.cables])
    floor = np.array([c.motor.min_rest_length for c in structure.cables])
    slide, slack = _friction_rows(lin, structure, pull)
    # variables (dl0, u, miss+, miss-): minimise MISS_WEIGHT |miss| + sum u, u >= |l0 - start|
    eye, zeros = np.eye(n), np.zeros((n, 2 * e))
    a_ub = np.vstack([np.block([[tension, np.zeros((n, n)), zeros],
                                [-tension, np.zeros((n, n)), zeros],
                                [eye, -eye, zeros], [-eye, -eye, zeros]]),
                      np.hstack([slide, np.zeros((len(slide), n + 2 * e))])])
    b_ub = np.r_[upper - lin.tensions, lin.tensions - min_tension, start - rest, rest - start,
                 slack]
    a_eq = np.hstack([jac @ sens, np.zeros((e, n)), -np.eye(e), np.eye(e)])
    cost = np.r_[np.zeros(n), np.ones(n), np.full(2 * e, MISS_WEIGHT)]
    from scipy.optimize import linprog  # imported on use: see design/__init__
    result = linprog(cost, A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=error,
                     bounds=[(0.0, 0.0) if c.motor.passive else (max(f - r, -TRUST), TRUST)
                             for c, f, r in zip(structure.cables, floor, rest, strict=True)]
                     + [(0, None)] * (n + 2 * e), method="highs")
    return result.x[:n] if result.success else np.zeros(n)


def _friction_rows(lin: _Linear, structure: Structure,
                   pull: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Linearised friction pyramid at the feet, |f_x|, |f_y| <= FRICTION_USE mu f_z / sqrt(2),
    as rows
    ``rows @ dl0 <= slack`` (the ground force f = -K_pin (foot - anchor) moves with dl0 as
    -K_pin J_foot K^-1 A diag(k) dl0, the feet's springs included in K)."""
    if not lin.feet:
        return np.zeros((0, len(pull[0]))), np.zeros(0)
    sens = np.linalg.lstsq(lin.stiffness, pull, rcond=1e-14)[0]
    rows, slack = [], []
    for foot in lin.feet:
        jac = lin.body_set.point_jacobian(lin.body_set.node_body[foot], lin.pose.position(foot)) \
            @ lin.body_set.basis
        force = -PIN_STIFFNESS * (lin.pose.position(foot) - lin.anchors[foot])
        rate = -PIN_STIFFNESS * jac @ sens  # (3, n_cables) d force / d l0
        mu = FRICTION_USE * _friction(structure, foot) / np.sqrt(2)
        for axis in (0, 1):
            for sign in (1.0, -1.0):
                rows.append(sign * rate[axis] - mu * rate[2])
                slack.append(mu * force[2] - sign * force[axis])
    return np.array(rows), np.array(slack)


def _friction(structure: Structure, node: str) -> float:
    """Friction coefficient at a foot: the least of the rods' that end there (1 if none)."""
    values = [r.friction for r in structure.rods if node in r.nodes]
    return min(values) if values else 1.0


def _solve(structure: Structure, targets: dict[str, np.ndarray], pinned: tuple[str, ...],
           min_tension: float, gravity: float) -> tuple[np.ndarray, _Linear]:
    """Rest lengths whose static pose brings the targets nearest, with that pose."""
    start = np.array([structure.rest_length(c) for c in structure.cables])
    rest = start.copy()
    explicit = with_rest_lengths(structure, rest)
    lin = settle(explicit, pinned, gravity)
    for _ in range(60):
        step = _step(lin, structure, targets, rest, start, min_tension)
        rest = rest + step
        lin = settle(with_rest_lengths(explicit, rest), pinned, gravity)
        if np.abs(step).max() < 1e-10:
            break
    return rest, lin


@one_blas_thread
def inverse_statics(structure: Structure, displacements: dict[str, tuple[float, float, float]],
                    *, min_tension: float = 1.0, tolerance: float = TOLERANCE,
                    gravity: float = GRAVITY) -> InverseStatics:
    """Rest lengths that hold the nodes of ``displacements`` moved by them, on the ground.

    Args:
        structure: the robot in its build pose; it stands on its lowest nodes, lowered onto
            the ground (:func:`on_ground`).
        displacements: node name -> (3,) displacement from its static pose under the
            structure's own rest lengths [m].
        min_tension: every cable stays taut with at least this tension [N].
        tolerance: largest distance of a node from its target that counts as reached [m].
        gravity: gravitational acceleration [m/s^2].

    Raises:
        DesignError: an unknown node or a foot as target, or a target the motors cannot reach
            (the message gives the fraction of the displacement they reach).
    """
    structure = on_ground(structure)
    pinned = feet(structure)
    known = {n.name for n in structure.nodes}
    for name in displacements:
        if name not in known:
            raise DesignError(f"unknown node {name!r} in the target; nodes: {sorted(known)}")
        if name in pinned:
            raise DesignError(f"node {name!r} is a foot (on the ground), which stays put; "
                              f"feet: {', '.join(pinned)}")
    explicit = with_rest_lengths(structure, np.array([structure.rest_length(c)
                                                      for c in structure.cables]))
    home = settle(explicit, pinned, gravity).pose

    def goals(fraction: float) -> dict[str, np.ndarray]:
        return {n: home.position(n) + fraction * np.asarray(d, dtype=float)
                for n, d in displacements.items()}

    asked = goals(1.0)
    rest, lin = _solve(structure, asked, pinned, min_tension, gravity)
    miss = max(np.linalg.norm(lin.pose.position(n) - g) for n, g in asked.items())
    if miss > tolerance:
        reached = ", ".join(f"{n} by {_vector(lin.pose.position(n) - home.position(n))}"
                            for n in asked)
        wanted = ", ".join(f"{n} by {_vector(np.asarray(d, dtype=float))}"
                           for n, d in displacements.items())
        raise DesignError(
            f"unreachable: asked to move {wanted} m; within the motors' max_tension, the "
            f"minimum tension {min_tension:g} N and min_rest_length the nearest static pose "
            f"moves {reached} m (missing by {1e3 * miss:.3g} mm). The feet stay put, so a node "
            "on a rod that stands on a foot moves only across that rod")
    forces = {n: -PIN_STIFFNESS * (lin.pose.position(n) - structure.position(n))
              for n in pinned}
    return InverseStatics(
        tuple(c.name for c in structure.cables), rest,
        rest - np.array([structure.rest_length(c) for c in structure.cables]), lin.tensions,
        lin.pose, forces,
        {n: float(np.hypot(f[0], f[1]) / f[2]) if f[2] > 0 else np.inf
         for n, f in forces.items()})


def _vector(value: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.4g}" if abs(v) >= 5e-5 else "0" for v in value) + ")"
