"""Rolling toward a heading or a goal: the punctuated statics gait on any closed robot.

The gait (:mod:`tensim.control.rolling`) looks at the robot every control period: on a new
support face it first lets the robot rest with its cables at their built rest lengths, then
plans the rest lengths that carry the centre of mass past the edge toward the heading (toward
the goal, from where the robot stands, when a goal is given) and commands them; the motors wind
there at their max_speed, the robot tips, and the next face starts over. The summary reports
the field's figures: speed in body lengths per second (body length = the longest rod), the
distance made good along the heading, the heading error of the path, the faces visited and the
number of rolls. With ``turn_deg`` the gait turns the robot in place instead (:func:`roll`).
:func:`play` rolls with a controller file instead (a learned ``roll`` gait,
:mod:`tensim.control.roll_parameters`), played open loop, and reports the same speed figures.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tensim.control import ControllerConfig
from tensim.control.roll_plans import PlanCache
from tensim.control.rolling import (
    RollSettings,
    TipPlan,
    default_settings,
    fold_pose,
    folds,
    heading_error_deg,
    heading_vector,
    plan_tip,
    rocks_back,
    support_face,
    yaw_between,
)
from tensim.control.turning import (
    Placement,
    RigidHull,
    edge_heading,
    place,
    plan_turn,
    rigid_hull,
    walk_cost,
)
from tensim.design import DesignError
from tensim.model import WorldOptions, compile_structure
from tensim.runs import world_record, write_run
from tensim.sim import COM, Simulation, SimulationResult, TimeSeries, simulate
from tensim.sim.motion import contact_radii, node_bodies, node_paths, rolled_distance
from tensim.structure import Structure, StructureError, body_length

ROLL_DURATION = 30.0  # s, the default run (the field's speeds are over 30 s)
LOOKAHEAD = 2.0  # body lengths: how far ahead on the heading's line the gait aims
TURN_TOLERANCE = 10.0  # deg: turning in place stops once the yaw is this near the target
TURN_HYSTERESIS = 0.15  # rad of cost a new walk must save to replace the one being followed
PUMP_HOLD_S = 0.2  # s: a pumped plan is held at least this long before it may let go


def node_positions(sim: Simulation) -> dict[str, np.ndarray]:
    """Every node's world position now [m]."""
    d, index = sim.data, sim.index
    return {name: d.xpos[body] + d.xmat[body].reshape(3, 3) @ index.node_local[name]
            for name, body in index.node_body.items()}


@dataclasses.dataclass
class _Gait:
    """The gait's state between control periods."""

    structure: Structure
    built: np.ndarray
    motorised: np.ndarray
    settings: RollSettings
    heading_deg: float
    goal: tuple[float, float] | None
    origin: np.ndarray
    length: float
    face: tuple[str, ...] = ()  # the face (or with settings.fold_deg, the fold) planned on
    stood: tuple[str, ...] = ()  # the support face stood on
    seen: tuple[str, ...] = ()
    since: float = 0.0
    pushing: bool = False
    faces: list[tuple[str, ...]] = dataclasses.field(default_factory=list)
    first_roll_s: float | None = None  # when the robot first left its first face [s]
    plans: int = 0
    turn: float | None = None  # rad: the yaw to turn by in place (None: roll on the heading)
    hull: RigidHull | None = None  # turning: the hull as it stands on its first face
    first: Placement | None = None  # turning: the hull's placement there
    com_now: np.ndarray | None = None  # (3,) the centre of mass at the last look [m]
    walk: tuple[tuple[int, int, int], ...] = ()  # turning: the tips still to make
    tipping_from: int | None = None  # turning: the face the last tip was commanded on
    turned: bool = False
    plan: TipPlan | None = None  # the tip commanded now
    com_before: np.ndarray | None = None  # (2,) the centre of mass a control period ago [m]
    released: bool = False  # pumping: the plan let go while the robot swings back
    cache: PlanCache | None = None  # the plans made so far (None: plan every tip afresh)
    stuck: bool = False  # a plan on this face timed out: plan afresh from where it stands
    folds: dict[tuple[str, ...], tuple[tuple[str, ...], tuple[str, ...]]] = \
        dataclasses.field(default_factory=dict)  # settings.fold_deg: the build hull's folds

    def _turn_heading(self, positions: dict[str, np.ndarray]) -> np.ndarray | None:
        """Turning in place: the outward normal of the next edge of the walk of rigid-hull
        tips back to the first face (:func:`~tensim.control.turning.plan_turn`), planned again
        wherever a tip lands off the walk; None once the robot stands on its first face with
        its yaw within :data:`TURN_TOLERANCE` of the target, or where standing costs least."""
        assert self.turn is not None and self.com_now is not None
        if self.hull is None or self.first is None:  # the reference: the first face, settled
            self.hull = rigid_hull(positions, self.com_now)
            self.first = place(self.hull, positions)
        now = place(self.hull, positions)
        home = now.face == self.first.face
        yaw = math.remainder(now.yaw - self.first.yaw, 2 * math.pi)
        if home and abs(math.remainder(self.turn - yaw, 2 * math.pi)) \
                <= math.radians(TURN_TOLERANCE):
            self.turned = True
            return None
        if self.walk and now.face == self.walk[0][2]:
            self.walk = self.walk[1:]  # landed where the walk said
        elif not (self.walk and now.face == self.tipping_from):
            self.walk = ()  # landed off the walk (or none yet)
        # plan again from where the hull lies now (its feet may have slid), keeping the walk
        # unless the new one is better by TURN_HYSTERESIS
        plan = plan_turn(self.hull, now, self.first, self.turn, self.length)
        kept = walk_cost(self.hull, now, self.first, self.turn, self.length, self.walk) \
            if self.walk else math.inf
        if plan is None or plan.cost < kept - TURN_HYSTERESIS:
            self.walk = () if plan is None else plan.walk
        if not self.walk:
            self.turned = home
            return None
        self.tipping_from = now.face
        a, b, _ = self.walk[0]
        return edge_heading(self.hull, now, a, b)

    def heading(self, com: np.ndarray) -> np.ndarray:
        """Toward the goal; without one toward a point on the heading's line through the
        start, :data:`LOOKAHEAD` body lengths ahead (so a robot pushed aside steers back)."""
        goal = self.goal
        if goal is None:
            h = heading_vector(self.heading_deg)
            ahead = (com[:2] - self.origin) @ h + LOOKAHEAD * self.length
            goal = tuple(self.origin + ahead * h)
        to_goal = np.asarray(goal) - com[:2]
        norm = float(np.linalg.norm(to_goal))
        return to_goal / norm if norm > 1e-9 else heading_vector(self.heading_deg)

    def control(self, sim: Simulation) -> None:
        """Looks at the robot and updates the rest-length commands."""
        positions = node_positions(sim)
        face = support_face(positions)
        held, self.seen = face == self.seen, face  # a new face counts once seen twice running
        self.com_now = sim.data.subtree_com[0].copy()
        com = self.com_now[:2].copy()
        before, self.com_before = self.com_before, com
        if face != self.stood:
            if not (held or not self.faces):
                return
            self.stood = face
            self.faces.append(face)
            if len(self.faces) == 2:
                self.first_roll_s = sim.time
            key = self.folds[face][0] if face in self.folds else face
            if key == self.face:  # a rock within the fold: the push goes on
                return
            self.face, self.since, self.pushing = key, sim.time, False
            self.stuck = False
            self.released = False
            if self.settings.release:
                sim.drive.rest_command[self.motorised] = self.built[self.motorised]
            return
        waited = sim.time - self.since
        if not self.pushing and waited >= self.settings.settle_s and (
                waited >= self.settings.settle_s + self.settings.push_s
                or self._still(sim, com, before)):
            self._push(sim, positions)
        elif self.pushing and waited >= self.settings.settle_s + self.settings.push_s:
            self.since, self.pushing = sim.time, False  # stuck: rest and plan again
            self.stuck = True  # (afresh: the cached plan did not tip it)
            sim.drive.rest_command[self.motorised] = self.built[self.motorised]
        elif (self.settings.pump and self.pushing and self.plan is not None
              and self.plan.margin < self.settings.margin
              and before is not None):
            self._pump(sim, float(self.plan.direction @ (com - before)), waited)

    def _still(self, sim: Simulation, com: np.ndarray, before: np.ndarray | None) -> bool:
        """Whether the rest on this face is over (``settings.still_speed``): the cables back
        at their built rest lengths, the centre of mass slower than ``still_speed``."""
        limit = self.settings.still_speed
        if limit <= 0:
            return True
        if before is None:
            return False
        wound = np.abs(sim.drive.rest[self.motorised] - self.built[self.motorised])
        speed = float(np.linalg.norm(com - before)) / self.settings.period_s
        return bool(wound.max(initial=0.0) < 1e-3 and speed < limit)

    def _pump(self, sim: Simulation, rate: float, waited: float) -> None:
        """A tip that statics cannot make: let go while the robot swings back from the edge,
        pull again as it swings toward it, in phase with its rocking."""
        assert self.plan is not None
        if not self.released and rate < 0 and waited >= self.settings.settle_s + PUMP_HOLD_S:
            sim.drive.rest_command[self.motorised] = self.built[self.motorised]
            self.released = True
        elif self.released and rate > 0:
            sim.drive.rest_command[self.motorised] = self.plan.rest_lengths[self.motorised]
            self.released = False

    def _pose(self, positions: dict[str, np.ndarray]) -> Structure:
        return dataclasses.replace(self.structure, nodes=tuple(
            dataclasses.replace(n, position=tuple(positions[n.name]))
            for n in self.structure.nodes))

    def _push(self, sim: Simulation, positions: dict[str, np.ndarray]) -> None:
        try:
            pose = self._pose(positions)
        except StructureError:  # a cable's anchors met (anchor_offset): no pose to plan from
            return
        com = sim.data.subtree_com[0]
        heading = self.heading(com) if self.turn is None else self._turn_heading(positions)
        if heading is None or self.turned:
            sim.drive.rest_command[self.motorised] = self.built[self.motorised]
            return
        face = support_face(positions)
        if face in self.folds:
            rolled = fold_pose(positions, face, self.folds[face][1], heading)
            if rolled is not None:  # plan from the fold's forward face, push across both
                pose = self._pose(rolled)
        rest = sim.drive.rest.copy()
        try:
            plan = (plan_tip(pose, rest, self.built, heading, self.settings)
                    if self.cache is None or self.stuck else
                    # without the release, the cables a cached plan does not move go back
                    # to their built rest lengths as the next plan winds the others
                    self.cache.plan(pose, rest if self.settings.release else self.built,
                                    heading))
        except DesignError:
            return
        self.plans += 1
        if self.cache is not None and self.stuck:
            self.cache.fresh += 1
        sim.drive.rest_command[self.motorised] = plan.rest_lengths[self.motorised]
        self.pushing, self.plan, self.released = True, plan, False


def roll(structure: Structure, duration: float, *, heading_deg: float = 0.0,
         goal: tuple[float, float] | None = None, world: WorldOptions | None = None,
         settings: RollSettings | None = None, record_dt: float = 0.01,
         turn_deg: float | None = None, plans: PlanCache | None = None,
         progress: Callable[[float, float], None] | None = None
         ) -> tuple[SimulationResult, dict[str, Any]]:
    """Rolls ``structure`` for ``duration`` seconds toward a heading or a goal point, or turns
    it in place by ``turn_deg``.

    Turning in place rolls the hull around its vertices (:mod:`tensim.control.turning`): at
    each plan it tips over the first edge of the walk of rigid-hull tips, from the face it
    stands on back to the face it started on, that best turns it by ``turn_deg`` while its
    centre of mass stays near the start; it stops once it stands on its first face with its
    yaw within :data:`TURN_TOLERANCE` of the target, and the run ends there (``duration`` is
    then the longest it may take).

    Args:
        structure: a closed robot (its nodes' convex hull is what it rolls on).
        duration: simulated time [s].
        heading_deg: heading, counter-clockwise from +x [deg] (used without a goal).
        goal: (x, y) of a goal point [m]; the gait heads toward it from where the robot is.
        world: physics step, terrain and other world options.
        settings: the gait's parameters (None: :func:`~tensim.control.rolling.default_settings`).
        record_dt: recording period [s]; a whole number of physics steps.
        turn_deg: turn in place by this yaw, counter-clockwise [deg] (the heading and goal
            are then unused); the summary adds ``turn_deg``, ``yaw_deg`` and
            ``displacement_m`` (:func:`turn_summary`).
        plans: the plan cache to use (one made for the same robot, built rest lengths and
            settings, kept between runs); None: a new one (with ``settings.cache``).
        progress: called as progress(done_s, total_s).

    Returns:
        The result and its summary (:func:`roll_summary` plus the run's headline figures).
    """
    if turn_deg is not None and not math.isfinite(turn_deg):
        raise ValueError(f"turn_deg must be a finite angle in degrees, got {turn_deg!r}")
    settings = settings or default_settings(structure)
    world = world or WorldOptions()
    compiled = compile_structure(structure, world)
    sim = Simulation(compiled, record_dt=record_dt)
    built = compiled.rest_length.copy()
    motorised = np.array([not c.motor.passive for c in compiled.structure.cables])
    gait = _Gait(compiled.structure, built, motorised, settings, heading_deg, goal,
                 sim.data.subtree_com[0][:2].copy(), body_length(structure))
    if settings.fold_deg > 0:
        gait.folds = folds({n.name: np.asarray(n.position) for n in compiled.structure.nodes},
                           settings.fold_deg)
    if settings.cache and (settings.release or settings.fold_deg > 0):
        dynamic = None
        if settings.search > 0:
            from functools import partial

            from tensim.experiments.roll_search import search_tip

            dynamic = partial(search_tip, built=built, settings=settings, world=world)
        gait.cache = plans or PlanCache(compiled.structure, built, settings,
                                        -float(compiled.model.opt.gravity[2]), dynamic=dynamic)
    if turn_deg is not None:
        gait.turn = math.radians(turn_deg)
    chunks: list[TimeSeries] = []
    period = max(record_dt, round(settings.period_s / record_dt) * record_dt)
    done, start = 0.0, time.perf_counter()
    with sim:
        while done < duration - 1e-9 and not gait.turned:
            gait.control(sim)
            span = min(period, duration - done)
            series = sim.run(span)
            chunks.append(series if not chunks else _tail(series))
            done += span
            if progress is not None:
                progress(done, duration)
        trajectory = _join(chunks)
        result = SimulationResult(trajectory, sim.drive.peak.copy(), time.perf_counter() - start,
                                  round(done, 9) if gait.turned else duration, sim.dt,
                                  sim.index.cables, sim.drive.peak_speed.copy(),
                                  sim.drive.peak_power.copy())
    direction = heading_vector(heading_deg) if goal is None else None
    summary = {**result.summary(), **world_record(compiled.world),
               **roll_summary(trajectory, body_length(structure), direction, goal),
               "heading_deg": heading_deg if goal is None else None,
               "goal_xy_m": list(goal) if goal is not None else None,
               "faces_visited": len(set(gait.faces)), "rolls": max(0, len(gait.faces) - 1),
               "plans": gait.plans,
               "plans_made": gait.plans if gait.cache is None
               else gait.cache.made + gait.cache.fresh,
               "rocks_back": rocks_back(gait.faces),
               "first_roll_s": None if gait.first_roll_s is None
               else round(gait.first_roll_s, 6)}
    nodes = node_bodies(compiled.index)
    summary.update(ground_summary(trajectory, nodes))
    summary.update(rolled_summary(trajectory, nodes, contact_radii(structure, nodes),
                                  direction, goal))
    if turn_deg is not None:
        summary.update(turn_summary(trajectory, turn_deg, body_length(structure), nodes))
    return result, summary


def held_faces(faces: list[tuple[str, ...]], hold: int = 2) -> tuple[list[tuple[str, ...]],
                                                                         int | None]:
    """The support faces stood on, in order, from one face per look (``faces``): a new face
    counts once seen on ``hold`` looks running, as the statics gait counts it.

    Returns:
        The faces stood on, and the index of the look at which the second was first counted
        (None where the robot never left its first face).
    """
    out: list[tuple[str, ...]] = []
    first: int | None = None
    for i, face in enumerate(faces):
        if not out:
            out.append(face)
        elif face != out[-1] and i + 1 >= hold and all(f == face
                                                      for f in faces[i + 1 - hold:i + 1]):
            out.append(face)
            if first is None:
                first = i
    return out, first


def ground_summary(trajectory: TimeSeries, nodes: dict[str, tuple[str, np.ndarray]]
                   ) -> dict[str, Any]:
    """Whether a run rolled, from its recorded rod poses, as ``tensim rl evaluate`` says it:
    the support face (:func:`tensim.rl.evaluate.support_faces`) at every recorded sample.

    Returns:
        ``support_changes`` (samples whose support face differs from the sample before),
        ``ends_on_ground`` (the nodes that were ever in the support face) and ``ends`` (the
        nodes).
    """
    from tensim.rl.evaluate import support_faces

    faces = support_faces(node_paths(trajectory, nodes))
    return {"support_changes": int(sum(a != b for a, b in itertools.pairwise(faces))),
            "ends_on_ground": len(set().union(*faces)), "ends": len(nodes)}


def rolled_summary(trajectory: TimeSeries, nodes: dict[str, tuple[str, np.ndarray]],
                   radii: np.ndarray, heading: np.ndarray | None,
                   goal: tuple[float, float] | None = None) -> dict[str, Any]:
    """How far a run rolled, as ``tensim learn --rolling`` counts it.

    Args:
        trajectory: the recorded run.
        nodes: node name -> (its body's name, its position in the body's frame [m]).
        radii: (n,) each node's contact radius [m].
        heading: (2,) unit vector of the heading; None with a goal (the heading is then from
            the start toward the goal, as :func:`roll_summary`'s).
        goal: (x, y) of the goal [m].

    Returns:
        ``rolled_m`` and ``roll_rad``: :func:`tensim.sim.motion.rolled_distance` toward the
        heading, from the recorded rod poses.
    """
    heading = _scored_heading(trajectory, heading, goal)
    rolled, turn = rolled_distance(node_paths(trajectory, nodes), trajectory[f"pos_z/{COM}"],
                                   heading, radii)
    return {"rolled_m": round(rolled, 6), "roll_rad": round(turn, 6)}


def _scored_heading(trajectory: TimeSeries, heading: np.ndarray | None,
                    goal: tuple[float, float] | None) -> np.ndarray:
    """The heading a run is scored along: ``heading``, or from the start toward ``goal``."""
    if heading is not None:
        return heading
    assert goal is not None
    start = np.array([trajectory[f"pos_x/{COM}"][0], trajectory[f"pos_y/{COM}"][0]])
    toward = np.asarray(goal, dtype=float) - start
    return toward / max(float(np.linalg.norm(toward)), 1e-12)


def turn_summary(trajectory: TimeSeries, turn_deg: float, length: float,
                 nodes: dict[str, tuple[str, np.ndarray]]) -> dict[str, Any]:
    """A turn in place's figures, from the recorded bodies' paths.

    Args:
        trajectory: the recorded run (its bodies' ``pos_*`` and ``quat_*`` channels).
        turn_deg: the target yaw [deg].
        length: the body length [m].
        nodes: node name -> (its body's name, its position in the body's frame [m]).

    Returns:
        ``turn_deg`` (the target), ``yaw_deg`` (the yaw of the best-fitting rotation,
        :func:`yaw_between`, taking the nodes at the start to the nodes at the end; nodes, not
        body frames, since a rod's spin about its own axis moves no node),
        ``displacement_m`` (the centre of mass's horizontal displacement) and
        ``displacement_body_lengths``.
    """

    paths = node_paths(trajectory, nodes)
    yaw = yaw_between(paths[0], paths[-1])
    moved = float(np.hypot(trajectory[f"pos_x/{COM}"][-1] - trajectory[f"pos_x/{COM}"][0],
                           trajectory[f"pos_y/{COM}"][-1] - trajectory[f"pos_y/{COM}"][0]))
    return {"turn_deg": turn_deg, "yaw_deg": round(math.degrees(yaw), 3),
            "displacement_m": round(moved, 6),
            "displacement_body_lengths": round(moved / length, 6)}


def play(structure: Structure, config: ControllerConfig, duration: float, *,
         heading_deg: float = 0.0, goal: tuple[float, float] | None = None,
         world: WorldOptions | None = None, record_dt: float = 0.01,
         progress: Callable[[float, float], None] | None = None
         ) -> tuple[SimulationResult, dict[str, Any]]:
    """Rolls ``structure`` under a controller file's gait for ``duration`` seconds and scores
    the run along a heading (or toward a goal point) as :func:`roll` does.

    The gait plays open loop (it does not look where it goes); the heading only scores the
    run. ``faces_visited``, ``rolls``, ``rocks_back`` and ``first_roll_s`` are counted as the
    statics gait counts them, from the support faces of the recorded rod poses
    (:func:`tensim.rl.evaluate.support_faces`) looked at every control period of the statics
    gait (:func:`held_faces`); ``plans`` and ``plans_made`` are None.

    Args:
        structure: the robot.
        config: the controller (its gait is stretched or cut to ``duration``).
        duration: simulated time [s].
        heading_deg: heading the distance is measured along, counter-clockwise from +x [deg].
        goal: (x, y) of a goal point [m], measured toward instead of a heading.
        world: physics step, terrain and other world options.
        record_dt: recording period [s]; a whole number of physics steps.
        progress: called as progress(done_s, total_s).

    Returns:
        The result and its summary (:func:`roll_summary` plus the run's headline figures).
    """
    world = world or WorldOptions()
    compiled = compile_structure(structure, world)
    controller = config.with_duration(duration).build(compiled.model.opt.timestep)
    result = simulate(compiled, duration, controller=controller, record_dt=record_dt,
                      progress=progress)
    direction = heading_vector(heading_deg) if goal is None else None
    nodes = node_bodies(compiled.index)
    ts = result.trajectory
    every = max(1, round(RollSettings().period_s / record_dt))  # the statics gait's looks
    looks = np.arange(0, len(ts.time), every)
    from tensim.rl.evaluate import support_faces

    faces, first = held_faces(support_faces(node_paths(ts, nodes)[looks]))
    summary = {**result.summary(), **world_record(compiled.world),
               **roll_summary(ts, body_length(structure), direction, goal),
               "heading_deg": heading_deg if goal is None else None,
               "goal_xy_m": list(goal) if goal is not None else None,
               "faces_visited": len(set(faces)), "rolls": len(faces) - 1,
               "plans": None, "plans_made": None, "rocks_back": rocks_back(faces),
               "first_roll_s": None if first is None
               else round(float(ts.time[looks[first]] - ts.time[0]), 6),
               **ground_summary(ts, nodes),
               **rolled_summary(ts, nodes, contact_radii(structure, nodes), direction, goal)}
    return result, summary


def _tail(series: TimeSeries) -> TimeSeries:
    """The samples after the first (a run's first sample repeats the last of the one before)."""
    return TimeSeries(series.time[1:], {k: v[1:] for k, v in series.channels.items()})


def _join(chunks: list[TimeSeries]) -> TimeSeries:
    return TimeSeries(np.concatenate([c.time for c in chunks]),
                      {k: np.concatenate([c.channels[k] for c in chunks])
                       for k in chunks[0].channels})


def roll_summary(trajectory: TimeSeries, length: float, heading: np.ndarray | None,
                 goal: tuple[float, float] | None = None) -> dict[str, Any]:
    """The rolling figures of a run, from its centre-of-mass path.

    Args:
        trajectory: the recorded run.
        length: the body length [m].
        heading: (2,) unit vector of the heading; None with a goal (the heading is then from
            the start toward the goal).
        goal: (x, y) of the goal [m].

    Returns:
        ``distance_m`` (net displacement of the centre of mass along the heading),
        ``body_lengths_per_s`` (that distance per body length per second of run),
        ``heading_error_deg`` (angle between the net displacement and the heading: the size
        of :func:`~tensim.control.rolling.heading_error_deg`, None below its
        :data:`~tensim.control.rolling.MOVED_M`),
        ``body_length_m``; with a goal also ``goal_distance_m`` at the start and the end.
    """
    x, y = trajectory[f"pos_x/{COM}"], trajectory[f"pos_y/{COM}"]
    start, end = np.array([x[0], y[0]]), np.array([x[-1], y[-1]])
    heading = _scored_heading(trajectory, heading, goal)
    moved = end - start
    distance = float(moved @ heading)
    span = float(trajectory.time[-1] - trajectory.time[0])
    error = heading_error_deg(moved, heading)
    out: dict[str, Any] = {"body_length_m": round(length, 6), "distance_m": round(distance, 6),
                           "body_lengths_per_s": round(distance / length / span, 6) if span > 0
                           else 0.0,
                           "heading_error_deg": None if error is None
                           else round(abs(error), 3)}
    if goal is not None:
        out["goal_distance_m"] = [round(float(np.linalg.norm(np.asarray(goal) - p)), 6)
                                  for p in (start, end)]
    return out


def write_roll(out: Path, result: SimulationResult, summary: dict[str, Any],
               structure: Structure) -> Path:
    """Writes the run folder: trajectory, robot, report and summary."""
    return write_run(out, result, summary, structure=structure)
