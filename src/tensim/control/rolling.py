"""Punctuated rolling from statics: support faces, the tipping edge, and the rest lengths that
carry the centre of mass past it.

A rolling tensegrity (a 3-bar prism, a 6-bar icosahedron, any closed robot) stands on a face
of the convex hull of its nodes. It rolls toward a heading by deforming until the centre of
mass leaves that face's support polygon across the edge the heading points through; it tips
onto the next face, and the step repeats from there. :func:`plan_tip` finds the deformation
with the design tools' statics (:mod:`tensim.design.inverse`): the robot's static pose with its
feet held where they stand, re-linearised at every pose, gives how the centre of mass moves per
metre of each cable's rest length (dc/dl0 = J_c K^-1 A diag(k), the feet's springs in K); each
step moves every motorised cable whose rest length carries the centre of mass forward by a
share of its allowed travel, shortening or paying out as the sensitivity's sign says, until
the static pose's centre of mass lies past the edge by a margin (or the motors' travel is
spent). Sliding feet and the tipping motion itself are outside this model: the gait closes the
loop by watching which face the robot stands on.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.linalg import null_space
from scipy.spatial import ConvexHull

from tensim.design._bodies import GRAVITY
from tensim.design._errors import DesignError
from tensim.design.inverse import settle, with_rest_lengths
from tensim.structure import Structure

FACE_TOLERANCE = 0.02  # share of the robot's size within which a node lies on the support plane
MOVED_M = 0.01  # the net displacement [m] below which a heading error means nothing


@dataclasses.dataclass(frozen=True)
class RollSettings:
    """The punctuated rolling gait's parameters.

    Attributes:
        shorten: largest shortening of a motorised cable's rest length, as a share of its
            built rest length [-].
        lengthen: largest paying-out, as a share of its built rest length [-].
        margin: how far past the tipping edge the planned static centre of mass lies [m].
        steps: linearised statics steps of one plan.
        settle_s: time the robot rests on a new face, cables back at their built rest
            lengths, before the next plan [s].
        push_s: longest time a plan is held waiting for the robot to tip [s].
        period_s: the gait's control period: it looks at the robot this often [s].
        release: on a new face, return the cables to their built rest lengths while the robot
            rests (else hold the commands it tipped with and plan from there).
        pump: a plan whose static centre of mass stays short of the edge (a tip only
            momentum can make) is let go while the robot swings back from the edge and
            commanded again as it swings toward it, building up its rocking.
        sliding: plan with the feet on frictionless ground (held only in height, as
            :func:`tensim.design.inverse.settle` with ``sliding``), so that the planned pose
            needs no friction; else the feet are held where they stand (friction takes any
            sideways force). On a light robot with strong motors (the ``three_bar``
            preset: 2 kN motors, about 40 N on each foot) friction holds far less than the
            cables pull; off by default (docs/rolling.md: it tips the preset over its far
            edge once, but does not roll it faster).
        still_speed: with a value > 0, the rest on a new face lasts (beyond ``settle_s``, at
            most ``push_s`` longer) until the motors have wound the cables back to their
            built rest lengths and the centre of mass moves slower than this [m/s], so that
            each plan starts from the build shape at rest; 0: rest ``settle_s`` only.
        barrier: step the rest lengths down the gradient of the work that tips the rigid
            robot over the edge from the static pose, M g (sqrt(d^2 + h^2) - h) (d short of
            the edge, h up), rather than up the gradient of the margin alone: a pose that
            flattens (h falls) as its centre of mass nears the edge costs more to tip.
        fold_deg: with a value > 0, hull faces that meet the support face at an edge with
            their normals less than this apart [deg] make one *fold* with it (a 3-bar's side
            faces pair up so across a shallow edge, 31 degrees on the ``three_bar`` preset,
            while its other edges are 84-91 degrees): the gait counts a fold as one face
            (a rock between its two faces starts no new plan), and where the edge the
            heading points through is the fold's, it plans the tip over the next edge on the
            pose rolled rigidly onto the fold's other face (:func:`fold_pose`) and commands it
            at once, so that one push carries the robot across the fold and over the edge
            after it. 0: off.
        search: with a value > 0 (and ``cache``), a cached plan whose static centre of mass
            stays short of the margin is replaced by the best of this many constant commands
            tried in simulation from the face's canonical pose
            (:func:`tensim.experiments.roll_search.search_tip`), where one tips the robot.
        cache: make each plan once per support face and edge of the build pose's hull,
            from the face's canonical pose with the built rest lengths, and share it between
            faces the robot's symmetry relates (:mod:`tensim.control.roll_plans`); a plan
            that has not tipped the robot in ``push_s`` is followed by one made afresh. Off
            by default: it changes the runs, not clearly for the better (docs/rolling.md).
            Without it (or without ``release``, whose plans start from the rest lengths
            held) every tip is planned from where the robot stands and the rest lengths it
            holds.
    """

    shorten: float = 0.5
    lengthen: float = 0.3
    margin: float = 0.03
    steps: int = 12
    settle_s: float = 0.3
    push_s: float = 2.0
    period_s: float = 0.05
    release: bool = True
    pump: bool = False
    sliding: bool = False
    cache: bool = False
    still_speed: float = 0.0
    barrier: bool = False
    fold_deg: float = 0.0
    search: int = 0

    def __post_init__(self) -> None:
        for name in ("shorten", "lengthen", "margin", "settle_s", "push_s", "period_s",
                     "still_speed", "fold_deg"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ValueError(f"roll setting {name} must be a finite number >= 0, got "
                                 f"{value!r}")
        if not self.shorten < 1:
            raise ValueError(f"roll setting shorten must be < 1 (a share), got {self.shorten}")
        if not (isinstance(self.search, int) and self.search >= 0):
            raise ValueError(f"roll setting search must be an integer >= 0, got "
                             f"{self.search!r}")
        if not (isinstance(self.steps, int) and self.steps >= 1):
            raise ValueError(f"roll setting steps must be an integer >= 1, got {self.steps!r}")
        if not self.period_s > 0:
            raise ValueError("roll setting period_s must be > 0 s")


# A 3-bar's end cables carry its static centre of mass only a few centimetres past every other
# edge (the prism flattens first): it tips dynamically instead, with a larger travel and no rest
# between tips, so that the momentum of one tip carries into the next.
PRISM_SETTINGS = RollSettings(shorten=0.7, lengthen=0.5, settle_s=0.0, push_s=1.0)


SEARCH_TRIES = 100  # constant commands a searched tip tries (RollSettings.search)
STILL_SPEED = 0.3  # m/s: with searched tips, the rest on a face ends below this speed


def searched(settings: RollSettings) -> RollSettings:
    """``settings`` with tips searched in simulation where statics falls short
    (``search``), plans cached through the symmetry (``cache``, which the search needs) and a
    rest on each new face until the cables are back at their built rest lengths and the
    centre of mass moves slower than :data:`STILL_SPEED` (``still_speed``): a searched tip
    is found from the face's pose at rest with the built rest lengths, and works from
    there."""
    return dataclasses.replace(settings, cache=True, search=SEARCH_TRIES,
                               still_speed=STILL_SPEED)


def default_settings(structure: Structure) -> RollSettings:
    """The gait's settings for ``structure``: :data:`PRISM_SETTINGS` for a robot of three rods
    (a 3-bar prism), the defaults of :class:`RollSettings` otherwise."""
    return PRISM_SETTINGS if len(structure.rods) == 3 else RollSettings()


def heading_vector(heading_deg: float) -> np.ndarray:
    """(2,) unit vector of a heading, counter-clockwise from +x [deg]."""
    angle = math.radians(heading_deg)
    return np.array([math.cos(angle), math.sin(angle)])


def heading_error_deg(moved: np.ndarray, heading: np.ndarray) -> float | None:
    """The angle [deg] from ``heading`` to the net displacement ``moved``, counter-clockwise
    (in (-180, 180]); None where the displacement is shorter than :data:`MOVED_M`.

    Args:
        moved: (2,) net horizontal displacement [m].
        heading: (2,) unit vector of the heading.
    """
    moved, heading = np.asarray(moved, dtype=float), np.asarray(heading, dtype=float)
    if float(np.hypot(*moved)) < MOVED_M:
        return None
    return math.degrees(math.atan2(float(heading[0] * moved[1] - heading[1] * moved[0]),
                                   float(moved @ heading)))


def rocks_back(faces: list[tuple[str, ...]]) -> int:
    """How many changes of face in the sequence ``faces`` (the support faces stood on, in
    order) return to the face stood on before the last: rocks back over the edge just crossed,
    where a roll that gets on moves to a third face."""
    return sum(1 for i in range(2, len(faces)) if faces[i] == faces[i - 2])


def support_face(positions: dict[str, np.ndarray]) -> tuple[str, ...]:
    """The nodes of the convex-hull face the robot stands on (its outward normal nearest
    straight down), with every node within :data:`FACE_TOLERANCE` of its plane; sorted."""
    names = list(positions)
    points = np.array([positions[n] for n in names])
    hull = ConvexHull(points)
    normal_z = hull.equations[:, 2]
    best = int(np.argmin(normal_z))
    normal, offset = hull.equations[best, :3], hull.equations[best, 3]
    size = float(np.ptp(points, axis=0).max())
    near = np.abs(points @ normal + offset) <= FACE_TOLERANCE * size
    return tuple(sorted(n for n, on in zip(names, near, strict=True) if on))


def support_edges(polygon: np.ndarray) -> np.ndarray:
    """(k, 3) the edges of the convex hull of ``polygon`` (m, 2) as lines a x + b y + c = 0
    with (a, b) the unit outward normal (a x + b y + c < 0 inside)."""
    if len(polygon) < 3:  # standing on an edge or a point: no polygon to leave
        return np.zeros((0, 3))
    return ConvexHull(polygon).equations


def tip_rotation(points: np.ndarray, feet: np.ndarray, edge: np.ndarray) -> tuple[np.ndarray,
                                                                                  np.ndarray]:
    """The rigid-hull tip over a support edge: the rotation that rolls ``points`` over the edge
    until the next hull node reaches the ground.

    Args:
        points: (n, 3) the robot's nodes now [m].
        feet: (m, 3) the support face's nodes (on the ground) [m].
        edge: (3,) the support edge as a x + b y + c = 0, (a, b) its unit outward normal.

    Returns:
        (3, 3) rotation and (3,) a point on its axis: a node p lands at R (p - a) + a.
    """
    normal = np.array([edge[0], edge[1], 0.0])
    on_edge = feet[np.argsort(np.abs(feet[:, :2] @ edge[:2] + edge[2]))[:2]]
    anchor = on_edge.mean(axis=0)
    axis = np.cross([0.0, 0.0, 1.0], normal)  # rotating +z toward the outward normal
    rel = points - anchor
    along_n, up = rel @ normal, rel[:, 2]
    angle = np.arctan2(up, along_n)
    lifted = np.hypot(along_n, up) > 1e-6
    landing = angle[lifted & (angle > 1e-3)]
    theta = float(landing.min()) if len(landing) else 0.0
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rotation = np.eye(3) + math.sin(theta) * k + (1 - math.cos(theta)) * k @ k
    return rotation, anchor


def yaw_between(start: np.ndarray, end: np.ndarray) -> float:
    """The yaw [rad] of the best-fitting rotation (Kabsch) taking the point set ``start`` (n, 3)
    to ``end``: the angle of the rotation about z nearest to it (exact when the robot stands
    on the same face again, where the rotation is a pure yaw)."""
    a, b = start - start.mean(axis=0), end - end.mean(axis=0)
    u, _, vt = np.linalg.svd(b.T @ a)
    d = np.sign(np.linalg.det(u @ vt))
    r = u @ np.diag([1.0, 1.0, d]) @ vt
    return math.atan2(r[1, 0] - r[0, 1], r[0, 0] + r[1, 1])


def _com_jacobian(lin: object) -> np.ndarray:
    """(3, n_dof) d(centre of mass)/d(reduced coordinates) of a linearisation."""
    body_set = lin.body_set  # type: ignore[attr-defined]
    total = float(body_set.mass.sum())
    jac = np.zeros((3, body_set.n_full))
    for b, m in enumerate(body_set.mass):
        jac[:, 6 * b:6 * b + 3] = m / total * np.eye(3)
    return jac @ body_set.basis


def _com(lin: object) -> np.ndarray:
    body_set = lin.body_set  # type: ignore[attr-defined]
    return body_set.mass @ body_set.com / body_set.mass.sum()


def _sensitivity(lin: object, structure: Structure, sliding: bool = False) -> np.ndarray:
    """(n_dof, n_cables) dq/dl0 of the static pose with the feet held (as the inverse
    statics); ``sliding``: with the feet held only as ``lin``'s stiffness holds them (feet on
    frictionless ground, :func:`tensim.design.inverse.settle`)."""
    body_set, pose, feet = lin.body_set, lin.pose, lin.feet  # type: ignore[attr-defined]
    k = np.array([c.stiffness for c in structure.cables]) * lin.taut  # type: ignore[attr-defined]
    pull = lin.gradients.T * k  # type: ignore[attr-defined]
    if sliding:  # the feet's springs are in the stiffness: K dq = A diag(k) dl0
        return np.linalg.lstsq(lin.stiffness, pull, rcond=1e-12)[0]  # type: ignore[attr-defined]
    free = null_space(np.vstack([body_set.point_jacobian(body_set.node_body[f],
                                                          pose.position(f)) for f in feet])
                      @ body_set.basis)
    stiff = lin.stiffness  # type: ignore[attr-defined]
    return free @ np.linalg.lstsq(free.T @ stiff @ free, free.T @ pull, rcond=1e-12)[0]


@dataclasses.dataclass(frozen=True)
class TipPlan:
    """Rest lengths that carry the static centre of mass past a tipping edge.

    Attributes:
        rest_lengths: (n_cables,) commanded rest lengths [m].
        feet: the support face's nodes.
        direction: (2,) unit outward normal of the edge it tips over.
        margin: how far past the edge the planned static centre of mass lies [m]
            (negative: short of it, the motors' travel spent).
        height: how high that centre of mass lies above the lowest foot [m] (NaN where
            not known), so that a rigid tip over the edge from there lifts it by
            sqrt(margin^2 + height^2) - height.
    """

    rest_lengths: np.ndarray
    feet: tuple[str, ...]
    direction: np.ndarray
    margin: float
    height: float = math.nan


def plan_tip(structure: Structure, rest: np.ndarray, built: np.ndarray, heading: np.ndarray,
             settings: RollSettings = RollSettings(), gravity: float = GRAVITY) -> TipPlan:
    """The rest lengths that tip ``structure`` (its nodes where the robot stands now) over
    the support polygon's edge that best leads toward ``heading``.

    The edges are tried in order of how well their outward normal points along the heading
    (those pointing ahead of it only); the first whose plan reaches the margin is taken, else
    the one that came nearest.

    Args:
        structure: the robot, its node positions the current pose [m].
        rest: (n_cables,) rest lengths it holds now [m].
        built: (n_cables,) its built rest lengths, the centre of each cable's travel [m].
        heading: (2,) unit vector in the ground plane.
        settings: travel, margin and number of steps.
        gravity: [m/s^2].

    Raises:
        DesignError: no static pose on the current feet, or no edge ahead of the heading.
    """
    positions = {n.name: np.asarray(n.position) for n in structure.nodes}
    feet = support_face(positions)
    ahead = ahead_edges(np.array([positions[f][:2] for f in feet]), feet, heading)
    explicit = with_rest_lengths(structure, rest)
    start = settle(explicit, feet, gravity, sliding=settings.sliding)
    best: TipPlan | None = None
    for edge in ahead:
        plan = plan_edge(structure, explicit, start, rest, built, edge, feet, settings,
                         gravity)
        if plan.margin >= settings.margin:
            return plan
        if best is None or plan.margin > best.margin:
            best = plan
    assert best is not None
    return best


def ahead_edges(polygon: np.ndarray, feet: tuple[str, ...], heading: np.ndarray
                ) -> list[np.ndarray]:
    """The edges (a, b, c) of the support polygon ``polygon`` (m, 2) whose outward normal
    points ahead of ``heading``, best aligned first.

    Raises:
        DesignError: none does (``feet`` name the face in the message).
    """
    ahead = sorted((e for e in support_edges(polygon) if e[:2] @ heading > 0),
                   key=lambda e: -e[:2] @ heading)
    if not ahead:
        raise DesignError(f"no support edge ahead of the heading on feet {', '.join(feet)}")
    return ahead


def plan_edge(structure: Structure, explicit: Structure, lin: object, rest: np.ndarray,
              built: np.ndarray, edge: np.ndarray, feet: tuple[str, ...],
              settings: RollSettings, gravity: float = GRAVITY) -> TipPlan:
    """Steps the motorised rest lengths along the sensitivity that carries the static centre
    of mass across ``edge`` (a, b, c), until it lies ``settings.margin`` past it, or until a
    step leaves no static pose on ``feet`` (the robot tips there): that step is the plan's,
    and its margin and height are those of the last pose solved.

    Args:
        structure: the robot, its nodes where it stands [m].
        explicit: the same with explicit rest lengths ``rest``.
        lin: its static pose on ``feet`` (:func:`tensim.design.inverse.settle`).
        rest: (n_cables,) the rest lengths it starts from [m].
        built: (n_cables,) the built rest lengths (the centre of each cable's travel) [m].
        edge: the support edge, a x + b y + c = 0 with (a, b) its unit outward normal.
        feet: the support face's nodes.
        settings: travel, margin and number of steps.
        gravity: [m/s^2].
    """
    motorised = np.array([not c.motor.passive for c in structure.cables])
    lower = np.where(motorised, built * (1 - settings.shorten), rest)
    upper = np.where(motorised, built * (1 + settings.lengthen), rest)
    step = (upper - lower) / settings.steps
    normal = edge[:2]
    planned = rest.copy()
    pair = sorted(feet, key=lambda f: abs(normal @ np.asarray(structure.position(f))[:2]
                                          + edge[2]))[:2]  # the edge's two feet
    for _ in range(settings.steps):
        if settings.sliding:  # the feet slide: the edge is where its two feet are now
            edge = _edge_through(lin, pair, normal)
            normal = edge[:2]
        if normal @ _com(lin)[:2] + edge[2] >= settings.margin:
            break
        moves = _com_jacobian(lin) @ _sensitivity(lin, structure, settings.sliding)
        rate = normal @ moves[:2]
        if settings.barrier:  # descend the rigid tip's barrier sqrt(d^2 + h^2) - h instead
            short = -(normal @ _com(lin)[:2] + edge[2])
            height = _com(lin)[2] - min(lin.pose.position(f)[2]  # type: ignore[attr-defined]
                                        for f in feet)
            reach = math.hypot(short, height)
            rate = -((-short * rate + height * moves[2]) / reach - moves[2])
        useful = np.abs(rate) >= 0.2 * np.abs(rate).max()
        planned = np.clip(planned + np.where(useful, np.sign(rate) * step, 0.0), lower, upper)
        try:
            lin = settle(with_rest_lengths(explicit, planned), feet, gravity,
                         sliding=settings.sliding)
        except DesignError:  # no static pose on these feet: the step that tips it is kept,
            break  # and margin and height stay those of the last pose solved
    if settings.sliding:
        edge = _edge_through(lin, pair, normal)
        normal = edge[:2]
    com = _com(lin)
    ground = min(lin.pose.position(f)[2] for f in feet)  # type: ignore[attr-defined]
    return TipPlan(planned, feet, normal.copy(), float(normal @ com[:2] + edge[2]),
                   float(com[2] - ground))


def _edge_through(lin: object, pair: list[str], normal: np.ndarray) -> np.ndarray:
    """(3,) the ground line a x + b y + c = 0 through the nodes ``pair`` of the static pose
    ``lin``, (a, b) its unit normal on the side of ``normal``."""
    pose = lin.pose  # type: ignore[attr-defined]
    a, b = (np.asarray(pose.position(n))[:2] for n in pair)
    along = (b - a) / np.linalg.norm(b - a)
    out = np.array([along[1], -along[0]])
    out = out if out @ normal >= 0 else -out
    return np.array([out[0], out[1], -float(out @ a)])



def folds(positions: dict[str, np.ndarray], fold_deg: float
          ) -> dict[tuple[str, ...], tuple[tuple[str, ...], tuple[str, ...]]]:
    """The hull's folds: each face of the convex hull of ``positions`` whose nearest
    neighbour across an edge has its outward normal less than ``fold_deg`` apart, mapped to
    (the nodes of the two faces, the edge they share); faces sorted by node name.

    Args:
        positions: node name -> (3,) position [m] (the build pose).
        fold_deg: [deg].
    """
    names = list(positions)
    hull = ConvexHull(np.array([positions[n] for n in names]))
    faces = [frozenset(names[i] for i in simplex) for simplex in hull.simplices]
    cos = math.cos(math.radians(fold_deg))
    out: dict[tuple[str, ...], tuple[tuple[str, ...], tuple[str, ...]]] = {}
    for k, face in enumerate(faces):
        near = [(float(hull.equations[k, :3] @ hull.equations[j, :3]), j)
                for j, other in enumerate(faces) if j != k and len(face & other) == 2]
        best, j = max(near)
        if best >= cos:
            out[tuple(sorted(face))] = (tuple(sorted(face | faces[j])),
                                        tuple(sorted(face & faces[j])))
    return out


def fold_pose(positions: dict[str, np.ndarray], face: tuple[str, ...], shared: tuple[str, ...],
              heading: np.ndarray) -> dict[str, np.ndarray] | None:
    """Where the edge of the support ``face`` that best leads toward ``heading`` is ``shared``
    (the edge of its fold, :func:`folds`), the node positions rolled rigidly over it onto the
    fold's other face (:func:`tip_rotation`); None where it is not (the robot stands on the
    fold's forward face)."""
    feet = np.array([positions[f] for f in face])
    try:
        edge = ahead_edges(feet[:, :2], face, heading)[0]
    except DesignError:
        return None
    on_edge = {face[i] for i in np.argsort(np.abs(feet[:, :2] @ edge[:2] + edge[2]))[:2]}
    if on_edge != set(shared):
        return None
    names = list(positions)
    points = np.array([positions[n] for n in names])
    rotation, anchor = tip_rotation(points, feet, edge)
    rolled = (points - anchor) @ rotation.T + anchor
    return dict(zip(names, rolled, strict=True))
