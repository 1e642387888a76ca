"""Static response to external loads, and the load factors at which a member gives way.

The robot stands on its feet (its lowest nodes, held as pins, as in
:mod:`tensim.design.inverse`) under gravity and its prestress, or floats free at zero gravity
under a load that balances itself. A load F (forces at nodes) moves it by

    dq = K^-1 J^T F      (linear: the tangent stiffness K at the unloaded static pose),

and, exactly, to the static pose of V(q) - F . x(q) (Newton's method on the same stiffness,
re-linearised, continued from smaller loads). Scaling F by a load factor lambda, the first
cable slackens where the smallest cable stretch k (L - l0) reaches zero, and the first rod
buckles where the largest ratio of compression to Euler load reaches one (rod forces by
pin-jointed node equilibrium, :mod:`tensim.design.members`, with the nodes' weights and the
loads). Both are found by root bracketing on the exact static poses
(scipy.optimize.brentq); the slackening factor's linear estimate, min over cables of
t / (-dt/dlambda), is given beside it. Where static poses end first (the robot folds or
tips), that load factor is given instead.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from tensim.design._bodies import GRAVITY
from tensim.design._errors import DesignError
from tensim.design.inverse import (
    PIN_STIFFNESS,
    _friction,
    _Linear,
    feet,
    on_ground,
    settle,
    with_rest_lengths,
)
from tensim.design.members import bar_forces, node_weights
from tensim.structure import Structure

MAX_FACTOR = 1e4  # load factors beyond this count as never
STEP_FLOOR = 1e-3  # continuation gives up on a load step smaller than this x the load
LEFT = 0.01  # a margin still above this share of its unloaded value is not spent


@dataclasses.dataclass(frozen=True)
class LoadResponse:
    """A structure's static response to a load.

    Attributes:
        supports: the pinned feet (empty: free, at zero gravity).
        linear: node -> (3,) displacement from the tangent stiffness [m].
        exact: node -> (3,) displacement of the exact static pose under the load [m].
        tensions: (n_cables,) tensions before and (row 1) under the load [N].
        slack_factor: load factor at which the first cable slackens, or None (beyond
            :data:`MAX_FACTOR`).
        slack_cable: that cable.
        slack_linear: the linear estimate of the slackening factor (None: no cable eases).
        lost_factor: load factor past which no static pose exists (it folds or falls),
            where that comes before any cable slackens; else None.
        buckle_factor: load factor at which the first rod reaches its Euler load, or where
            static poses end first (then ``buckle_rod`` is None); None: no section, or
            beyond :data:`MAX_FACTOR`.
        buckle_rod: that rod.
        ground: foot -> (2, 3) ground force on it before and (row 1) under the load [N].
        friction: foot -> the friction coefficient there (the least of its rods') [-].
        lift_factor: load factor at which a foot's normal force reaches zero (the ground
            cannot pull: the foot lifts), or None.
        slip_factor: load factor at which a foot needs all its friction, or None.
    """

    supports: tuple[str, ...]
    linear: dict[str, np.ndarray]
    exact: dict[str, np.ndarray]
    tensions: np.ndarray
    slack_factor: float | None
    slack_cable: str | None
    slack_linear: float | None
    lost_factor: float | None
    buckle_factor: float | None
    buckle_rod: str | None
    ground: dict[str, np.ndarray]
    friction: dict[str, float]
    lift_factor: float | None
    slip_factor: float | None


def _jacobian(lin: _Linear, node: str) -> np.ndarray:
    body_set = lin.body_set
    return body_set.point_jacobian(body_set.node_body[node], lin.pose.position(node)) \
        @ body_set.basis


def _check_balanced(structure: Structure, loads: dict[str, np.ndarray]) -> None:
    force = sum(loads.values())
    moment = sum(np.cross(structure.position(n), f) for n, f in loads.items())
    scale = max(np.abs(f).max() for f in loads.values()) * max(
        np.ptp([n.position for n in structure.nodes], axis=0).max(), 1e-9)
    if np.abs(force).max() > 1e-9 * scale / max(scale, 1e-300) * np.abs(
            list(loads.values())).max() or np.abs(moment).max() > 1e-9 * scale:
        raise DesignError(f"a free structure (no supports) needs a load that balances itself; "
                          f"this one has a net force {np.round(force, 6).tolist()} N and moment "
                          f"{np.round(moment, 6).tolist()} N m (give opposite forces along the "
                          "line between two nodes, or stand it on its feet)")


def load_response(structure: Structure, loads: dict[str, tuple[float, float, float]], *,
                  supports: bool = True, gravity: float = GRAVITY) -> LoadResponse:
    """The static response of ``structure`` to node ``loads`` and its failure load factors.

    Args:
        structure: the robot at its build pose (with pretensions or rest lengths).
        loads: node -> (3,) world-frame force [N].
        supports: stand on the feet (lowest nodes, lowered onto the ground, pinned); False:
            at zero gravity, held only by the structure's own fixed nodes (with none, the
            load must balance itself).
        gravity: gravitational acceleration with supports [m/s^2].

    Raises:
        DesignError: an unknown node, a load on a foot, an unbalanced load on a free structure,
            or no static pose.
    """
    forces = {n: np.asarray(f, dtype=float) for n, f in loads.items()}
    known = {n.name for n in structure.nodes}
    for name in forces:
        if name not in known:
            raise DesignError(f"unknown node {name!r} in the load; nodes: {sorted(known)}")
    if supports:
        explicit = on_ground(structure)
        pinned = feet(explicit)
        for name in forces:
            if name in pinned:
                raise DesignError(f"node {name!r} is a foot, held by the ground; load another "
                                  f"node (feet: {', '.join(pinned)})")
    else:
        explicit = with_rest_lengths(structure, np.array([structure.rest_length(c)
                                                          for c in structure.cables]))
        pinned, gravity = (), 0.0
        if not any(n.fixed for n in explicit.nodes):
            _check_balanced(explicit, forces)
    base = settle(explicit, pinned, gravity)
    rest = np.array([explicit.rest_length(c) for c in explicit.cables])
    k = np.array([c.stiffness for c in explicit.cables])

    solved = {0.0: base}

    def pose(factor: float) -> _Linear:
        """The static pose under ``factor`` x the load, by continuation: Newton from the
        nearest solved pose below it, halving the step where it fails."""
        if factor in solved:
            return solved[factor]
        below = max(f for f in solved if f <= factor)
        try:
            lin = settle(explicit, pinned, gravity, iterations=40, start=solved[below].pose,
                         loads={n: factor * f for n, f in forces.items()})
        except DesignError:
            if factor - below < STEP_FLOOR * max(factor, 1.0):
                raise
            pose((below + factor) / 2)
            return pose(factor)
        solved[factor] = lin
        return lin

    # linear: K dq = J^T F (least squares: a free structure's rigid motions take no load)
    generalized = sum(_jacobian(base, n).T @ f for n, f in forces.items())
    dq = np.linalg.lstsq(base.stiffness, generalized, rcond=1e-10)[0]
    linear = {n.name: _jacobian(base, n.name) @ dq for n in explicit.nodes
              if base.body_set.node_body[n.name] >= 0}
    loaded = pose(1.0)
    exact = {n: loaded.pose.position(n) - base.pose.position(n) for n in linear}
    rate = k * base.taut * (base.gradients @ dq)  # dt / dlambda
    easing = rate < 0
    slack_linear = float((base.tensions[easing] / -rate[easing]).min()) if easing.any() \
        else None

    def stretch(factor: float) -> np.ndarray:
        lin = pose(factor)
        return k * (np.array([lin.pose.cable_length(c) for c in lin.pose.cables]) - rest)

    slack_factor, collapse = _first(lambda f: float(stretch(f).min()), slack_linear)
    lost_factor = slack_factor if collapse else None
    if collapse:
        slack_factor = None
    slack_cable = None if slack_factor is None else \
        explicit.cables[int(np.argmin(stretch(slack_factor)))].name
    weights = node_weights(explicit, gravity)
    sections = {r.name: r.section for r in explicit.rods if r.section is not None}

    ends = {r.name: r.nodes for r in explicit.rods}

    def buckling(factor: float) -> dict[str, float]:
        lin = pose(factor)
        at = {n.name: lin.pose.position(n.name) for n in lin.pose.nodes}
        external = {n: weights[n] + factor * forces.get(n, np.zeros(3)) for n in weights}
        rods = bar_forces(lin.pose, lin.tensions, at, external, pinned)
        return {name: -(rods[name] or 0.0) / section.buckling_load(
            lin.pose.distance(*ends[name])) - 1.0 for name, section in sections.items()}

    buckle_factor, lost = _first(lambda f: -max(buckling(f).values()),
                                 slack_factor or lost_factor) \
        if sections else (None, False)
    buckle_rod = None if buckle_factor is None or lost else max(
        buckling(buckle_factor).items(), key=lambda kv: kv[1])[0]
    anchors = {n: explicit.position(n) for n in pinned}
    mu = {n: _friction(explicit, n) for n in pinned}

    def ground(lin: _Linear) -> dict[str, np.ndarray]:
        return {n: -PIN_STIFFNESS * (lin.pose.position(n) - anchors[n]) for n in pinned}

    def lift(factor: float) -> float:  # the smallest normal force [N]
        return min(f[2] for f in ground(pose(factor)).values())

    def slip(factor: float) -> float:  # the smallest friction reserve mu f_z - |f_t| [N]
        return min(mu[n] * f[2] - np.hypot(f[0], f[1]) for n, f in ground(pose(factor)).items())

    guess = slack_factor or lost_factor
    lift_factor = _first(lift, guess)[0] if pinned else None
    slip_factor = _first(slip, guess)[0] if pinned else None
    before, after = ground(base), ground(loaded)
    return LoadResponse(pinned, linear, exact, np.vstack([base.tensions, loaded.tensions]),
                        slack_factor, slack_cable, slack_linear, lost_factor, buckle_factor,
                        buckle_rod, {n: np.vstack([before[n], after[n]]) for n in pinned},
                        mu, lift_factor, slip_factor)


def _first(margin: Callable[[float], float], guess: float | None
           ) -> tuple[float | None, bool]:
    """The smallest load factor > 0 at which ``margin(factor)`` (> 0 at 0) reaches zero, or
    past which no static pose exists; bracketed from ``guess`` outward by doubling, then
    refined by Brent's method. Returns (factor or None beyond :data:`MAX_FACTOR`, whether the
    factor is where static poses end rather than where the margin is spent)."""

    def f(factor: float) -> float:
        try:
            return margin(factor)
        except DesignError:  # no static pose at this load: past the failure
            return -1.0

    if f(0.0) <= 0:
        return 0.0, False
    low, high = 0.0, guess if guess and guess > 0 else 1.0
    while f(high) > 0:
        low, high = high, 2 * high
        if high > MAX_FACTOR:
            return None, False
    from scipy.optimize import brentq  # imported on use: see design/__init__
    root = float(brentq(f, low, high, xtol=1e-9 * high, rtol=1e-10))
    try:  # a root where poses end, not where the margin is spent (1 % of it left)
        ends = margin(root) > LEFT * f(0.0)
    except DesignError:
        ends = True
    return root, ends
