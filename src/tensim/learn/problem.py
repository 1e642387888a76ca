"""Learning problems: a point of the unit cube in, a scored trial out.

:class:`TrialProblem` is the real one: build the robot, put the gait the point describes on
the base controller's impedance laws, simulate one trial and score it (see
:mod:`tensim.learn.objective`). A trial whose gait cannot be generated (:class:`GaitError`),
whose simulation runs away (:class:`SimulationError`) or that flips over gets the problem's
``penalty`` score and a reason. :class:`SphereProblem` is a cheap analytic stand-in with the
same interface, for testing optimizers and executors.

Problems travel to worker processes by pickling; each worker compiles a robot once and keeps
the MuJoCo model for every later trial of the same problem.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import math
import pickle
import time
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from tensim.control import ControllerConfig, GaitError, ParameterLayout
from tensim.learn.families import check_family, gait_layout
from tensim.learn.objective import Objective
from tensim.model import CompiledModel, WorldOptions, compile_structure
from tensim.sim import (
    Controller,
    PhysicsScale,
    SimulationError,
    Trial,
    TrialResult,
    run_batch,
    simulate,
)
from tensim.sim.motion import contact_radii, node_bodies, node_paths
from tensim.structure import Structure
from tensim.terrain import format_terrain

# trial status: "ok" is scored; the others get the penalty score
OK, FLIPPED, UNSTABLE, GAIT, ERROR, LOST = "ok", "flipped", "unstable", "gait", "error", "lost"
_DC_ONLY = ("motor_stall", "motor_inertia", "motor_friction")  # act on DC motors alone


@dataclasses.dataclass(frozen=True)
class Outcome:
    """What one trial gave.

    Attributes:
        score: higher is better (the penalty for a failed trial).
        status: ``ok``, ``flipped``, ``unstable``, ``gait``, ``error`` or ``lost``.
        reason: why a trial failed ("" when ok).
        metrics: named figures of the trial (e.g. ``distance_m``, ``work_J``).
    """

    score: float
    status: str = OK
    reason: str = ""
    metrics: dict[str, float] = dataclasses.field(default_factory=dict)


class Problem(Protocol):
    """What an optimizer's executor needs from a problem."""

    @property
    def penalty(self) -> float:
        """Score given to a trial that raises."""

    @property
    def dimension(self) -> int:
        """Length of a parameter vector."""

    def start(self) -> np.ndarray:
        """(dimension,) starting point in the unit cube."""

    def values(self, unit: np.ndarray) -> np.ndarray:
        """The physical parameter values of a unit-cube point."""

    def evaluate(self, unit: np.ndarray) -> Outcome:
        """Runs and scores one trial."""

    def to_dict(self) -> dict[str, Any]:
        """The problem's resolved configuration, JSON-ready."""


@dataclasses.dataclass(frozen=True)
class SphereProblem:
    """A shifted sphere in the unit cube, score −Σ(u − centre)² (best 0 at ``centre``).

    A cheap, analytic stand-in for a trial, so optimizers and executors can be checked in
    milliseconds through the same path as a real problem.

    Attributes:
        dimension: number of parameters.
        center: location of the optimum, in every coordinate.
        penalty: score given to a trial that raises.
    """

    dimension: int
    center: float = 0.3
    penalty: float = -100.0

    def start(self) -> np.ndarray:
        """The cube's centre."""
        return np.full(self.dimension, 0.5)

    def values(self, unit: np.ndarray) -> np.ndarray:
        """The point itself (the unit cube is the parameter space)."""
        return np.asarray(unit, dtype=float)

    def evaluate(self, unit: np.ndarray) -> Outcome:
        """Scores a point."""
        u = np.asarray(unit, dtype=float)
        return Outcome(-float(np.sum((u - self.center) ** 2)))

    def to_dict(self) -> dict[str, Any]:
        """The configuration."""
        return {"kind": "sphere", **dataclasses.asdict(self)}


def _jsonable(value: Any) -> Any:
    """Dataclasses, tuples and arrays as plain JSON values (anything else as its repr)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, bool | int | float | str):
        return value
    return repr(value)


# compiled models of this process, by TrialProblem.key (compiling costs more than a short trial)
_COMPILED: dict[str, CompiledModel] = {}


# builds the gaits of many points at once: each point's controller, or why it has none
GaitBuilder = Callable[[Sequence[np.ndarray]], "list[Controller | str]"]


@dataclasses.dataclass(frozen=True)
class TrialProblem:
    """Learn a gait of a controller family for a robot: one simulated trial per point.

    Attributes:
        structure: the robot.
        base: impedance laws and command period the gaits are put on (its gait is replaced).
        family: ``cpg``, ``sine``, ``sine-pattern`` or ``wave`` (see
            :mod:`tensim.learn.families`).
        duration_s: simulated time of one trial [s].
        objective: how a trial is scored.
        world: physics step, gravity and ground.
        record_dt: recording period of a trial [s].
        penalty: score of a trial that failed (gait error, unstable, flipped, raised); keep it
            below any real score.
        model: the preset name or structure file it was made from (a label).
        randomize: physical parameters drawn per robot, as (name, low, high) multipliers of
            :class:`~tensim.sim.PhysicsScale` fields (friction, stiffness, damping, mass,
            motor_speed); empty: one nominal robot.
        robots: randomised robots each candidate is scored on (the same draws for every
            candidate, so candidates compare fairly).
        robust: ``"mean"`` (the average score over the robots) or ``"worst"`` (the lowest);
            a robot whose trial fails counts with the penalty.
        randomize_seed: seed of the robots' draws.
        start_from: (name, value) pairs that replace the starting point's values of those
            parameters (the search starts from the base gait or the family's nominal values
            otherwise), e.g. a slow, full-amplitude wave where the nominal one leaves every
            nearby trial at the same score.
    """

    structure: Structure
    base: ControllerConfig
    family: str
    duration_s: float
    objective: Objective = dataclasses.field(default_factory=Objective)
    world: WorldOptions = dataclasses.field(default_factory=WorldOptions)
    record_dt: float = 0.01
    penalty: float = -1.0
    model: str = ""
    randomize: tuple[tuple[str, float, float], ...] = ()
    robots: int = 1
    robust: str = "mean"
    randomize_seed: int = 0
    start_from: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        check_family(self.family)
        names = {f.name for f in dataclasses.fields(PhysicsScale)}
        given = [name for name, _, _ in self.randomize]
        repeated = sorted({name for name in given if given.count(name) > 1})
        if repeated:
            raise ValueError(f"randomize {', '.join(repeated)}: given more than once; give each "
                             "parameter one LOW:HIGH range")
        for name, low, high in self.randomize:
            if name not in names:
                raise ValueError(f"cannot randomize {name!r}; choose from {sorted(names)}")
            if not (math.isfinite(low) and math.isfinite(high) and 0 < low <= high):
                raise ValueError(f"randomize {name}={low}:{high}: need 0 < low <= high")
            if name in _DC_ONLY and all(c.motor.dc is None for c in self.structure.cables):
                raise ValueError(f"randomize {name}: robot {self.structure.name!r} has no DC "
                                 "motors (a cable's motor: dc), so it would change nothing")
        if not (isinstance(self.robots, int) and 1 <= self.robots <= 1000):
            raise ValueError(f"robots must be an integer in [1, 1000], got {self.robots!r}")
        if self.robust not in ("mean", "worst"):
            raise ValueError(f"robust must be 'mean' or 'worst', got {self.robust!r}")
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise ValueError(f"trial duration must be > 0 s, got {self.duration_s}")
        if self.objective.settle_s >= self.duration_s:
            raise ValueError(f"settle time {self.objective.settle_s} s leaves nothing of a "
                             f"{self.duration_s} s trial to score")
        bodies = self.bodies
        if self.objective.segment not in (*bodies, "com"):
            raise ValueError(f"unknown segment {self.objective.segment!r}; expected 'com' or "
                             f"one of {list(bodies)}")
        if not math.isfinite(self.penalty):
            raise ValueError(f"penalty must be a finite score, got {self.penalty}")
        if self.start_from:
            self._check_start()

    def _check_start(self) -> None:
        """Raises ValueError for an unknown, repeated or out-of-bounds starting value."""
        names = self.layout.names
        given = [name for name, _ in self.start_from]
        for name, value in self.start_from:
            if name not in names:
                raise ValueError(f"start {name}: not a parameter of the {self.family} gait; "
                                 f"expected one of {list(names)}")
            if given.count(name) > 1:
                raise ValueError(f"start {name}: given more than once")
            i = names.index(name)
            low, high = self.layout.low[i], self.layout.high[i]
            if not (math.isfinite(value) and low <= value <= high):
                raise ValueError(f"start {name}={value}: expected a value in [{low:g}, "
                                 f"{high:g}]")

    # -- the parameter space ---------------------------------------------------------------

    @functools.cached_property
    def _layout_and_start(self) -> tuple[ParameterLayout, np.ndarray]:
        return gait_layout(self.family, self.structure, self.base)

    @property
    def layout(self) -> ParameterLayout:
        """The gait family's parameter layout."""
        return self._layout_and_start[0]

    @property
    def dimension(self) -> int:
        """Number of learned parameters."""
        return self.layout.size

    @property
    def bodies(self) -> tuple[str, ...]:
        """The robot's rigid bodies (segments)."""
        return tuple(g.name for g in self.structure.rigid_groups())

    @functools.cached_property
    def rod_ends(self) -> tuple[dict[str, tuple[str, np.ndarray]], np.ndarray]:
        """The nodes on the robot's rigid bodies (:func:`~tensim.sim.motion.node_bodies`) and
        (p,) each one's contact radius [m]: the largest radius of the rods ending there (0 for
        a node on no rod)."""
        nodes = node_bodies(self.compiled().index)
        return nodes, contact_radii(self.structure, nodes)

    def start(self) -> np.ndarray:
        """The base controller's gait (or the family's nominal values), with the values of
        ``start_from``, in the unit cube."""
        values = np.array(self._layout_and_start[1], dtype=float)
        for name, value in self.start_from:
            values[self.layout.names.index(name)] = value
        return self.layout.to_unit(self.layout.clip(values))

    def values(self, unit: np.ndarray) -> np.ndarray:
        """Gait parameters of a unit-cube point."""
        return self.layout.from_unit(np.clip(np.asarray(unit, dtype=float), 0.0, 1.0))

    def controller(self, unit: np.ndarray, description: str = "") -> ControllerConfig:
        """The base controller with the gait of a point, covering one trial."""
        gait = self.layout.gait(self.values(unit))
        config = self.base.with_gait(gait).with_duration(self.duration_s)
        return dataclasses.replace(config, description=description or config.description)

    # -- a trial ---------------------------------------------------------------------------

    @functools.cached_property
    def key(self) -> str:
        """Identifies the compiled robot (structure and world) within a process."""
        return hashlib.sha256(pickle.dumps((self.structure, self.world))).hexdigest()[:16]

    def compiled(self) -> CompiledModel:
        """The compiled robot, built once per process."""
        if self.key not in _COMPILED:
            _COMPILED.clear()  # one problem per worker at a time
            _COMPILED[self.key] = compile_structure(self.structure, self.world)
        return _COMPILED[self.key]

    @functools.cached_property
    def physics(self) -> tuple[PhysicsScale, ...]:
        """The robots every candidate runs on: one nominal, or ``robots`` random draws."""
        if not self.randomize:
            return (PhysicsScale(),) * self.robots
        rng = np.random.default_rng(self.randomize_seed)
        draws = []
        for _ in range(self.robots):
            draws.append(PhysicsScale(**{name: float(rng.uniform(low, high))
                                         for name, low, high in self.randomize}))
        return tuple(draws)

    def evaluate(self, unit: np.ndarray) -> Outcome:
        """Simulates one trial with the gait of ``unit`` and scores it."""
        if self.randomize or self.robots > 1:
            return self.evaluate_batch([unit], threads=1)[0]
        compiled = self.compiled()
        try:
            controller = self.controller(unit).build(compiled.model.opt.timestep)
        except GaitError as err:
            return Outcome(self.penalty, GAIT, f"gait: {err}")
        try:
            result = simulate(compiled, self.duration_s, controller=controller,
                              record_dt=self.record_dt)
        except SimulationError as err:
            return Outcome(self.penalty, UNSTABLE, f"unstable: {err}")
        return self._score(TrialResult(result))

    def evaluate_batch(self, units: Sequence[np.ndarray], threads: int,
                       backend: str = "cpu", builder: GaitBuilder | None = None
                       ) -> list[Outcome]:
        """Simulates the trials of ``units`` as one batch on ``threads`` threads and scores
        them; on the ``"cpu"`` backend each outcome equals :meth:`evaluate`'s for the same
        point (``"warp"``: one MuJoCo Warp world per trial, to float32 tolerance).

        Args:
            builder: builds the gaits of many points at once (e.g. on worker processes, since
                each is a CPG integration in Python); None builds them here, one by one.
        """
        compiled = self.compiled()
        gaits = (builder or self.build_gaits)(units)
        outcomes: list[Outcome | None] = [None] * len(units)
        trials: list[Trial] = []
        where: list[int] = []
        for i, gait in enumerate(gaits):
            if isinstance(gait, str):
                outcomes[i] = Outcome(self.penalty, GAIT, f"gait: {gait}")
                continue
            trials.extend(Trial(gait, physics=ps) for ps in self.physics)
            where.append(i)
        if trials:
            results = run_batch(compiled, trials, self.duration_s, threads=threads,
                                record_dt=self.record_dt, backend=backend)
            k = len(self.physics)
            for j, i in enumerate(where):
                outcomes[i] = self._combine([self._score(t) for t in results[j * k:(j + 1) * k]])
        return [o for o in outcomes if o is not None]

    def build_gaits(self, units: Sequence[np.ndarray]) -> list[Controller | str]:
        """Each point's controller, or the reason (a ``GaitError``'s message) it has none."""
        dt = self.compiled().model.opt.timestep
        out: list[Controller | str] = []
        for unit in units:
            try:
                out.append(self.controller(unit).build(dt))
            except GaitError as err:
                out.append(str(err))
        return out

    def _combine(self, robots: list[Outcome]) -> Outcome:
        """One candidate's outcome over its robots (itself for a single robot)."""
        if len(robots) == 1:
            return robots[0]
        scores = np.array([o.score for o in robots])
        failed = [o for o in robots if o.status != OK]
        if len(failed) == len(robots):
            return failed[0]
        score = float(scores.mean() if self.robust == "mean" else scores.min())
        ok = [o.metrics for o in robots if o.status == OK]
        metrics = {key: float(np.mean([m[key] for m in ok])) for key in ok[0]
                   if all(key in m for m in ok)}
        metrics.update(score_mean=float(scores.mean()), score_worst=float(scores.min()),
                       score_std=float(scores.std()), robots_failed=float(len(failed)))
        reason = f"{len(failed)} of {len(robots)} robots failed ({failed[0].reason})" \
            if failed else ""
        return Outcome(score, OK, reason, metrics)

    def _score(self, trial: TrialResult) -> Outcome:
        if trial.result is None:
            status = UNSTABLE if "unstable" in str(trial.error) else ERROR
            return Outcome(self.penalty, status, f"{status}: {trial.error}")
        trajectory = trial.result.trajectory
        points: np.ndarray | None = None
        radii: np.ndarray | float = 0.0
        if self.objective.rolling:
            nodes, radii = self.rod_ends
            points = node_paths(trajectory, nodes)
        score, metrics, flipped = self.objective.score(trajectory, self.bodies, points, radii)
        if flipped:
            return Outcome(self.penalty, FLIPPED, flipped, metrics)
        return Outcome(score, OK, "", metrics)

    def to_dict(self) -> dict[str, Any]:
        """The resolved configuration (structure and base controller are saved as files)."""
        return {"kind": "trial", "model": self.model, "family": self.family,
                "duration_s": self.duration_s, "record_dt_s": self.record_dt,
                "penalty": self.penalty, "objective": dataclasses.asdict(self.objective),
                "objective_text": self.objective.describe(),
                "world": _jsonable(self.world), "terrain": format_terrain(self.world.terrain),
                "dimension": self.dimension,
                "parameter_names": list(self.layout.names),
                "randomize": {name: [low, high] for name, low, high in self.randomize},
                "robots": self.robots, "robust": self.robust,
                "randomize_seed": self.randomize_seed,
                "start_from": dict(self.start_from)}


@dataclasses.dataclass(frozen=True)
class Evaluation:
    """One finished trial as the run folder records it.

    Attributes:
        index: position in the run's sequence of evaluations (ask order).
        unit: the point in the unit cube.
        values: the physical parameter values.
        score: the trial's score (the penalty if it failed).
        status: see :class:`Outcome`.
        reason: why it failed ("" when ok).
        wall_s: wall-clock time of the trial [s].
        metrics: named figures of the trial.
    """

    index: int
    unit: tuple[float, ...]
    values: tuple[float, ...]
    score: float
    status: str
    reason: str
    wall_s: float
    metrics: dict[str, float] = dataclasses.field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready mapping (floats round-trip exactly): ``dataclasses.asdict``'s, without
        its deep copy of every number."""
        return {**{f.name: getattr(self, f.name) for f in dataclasses.fields(self)},
                "metrics": dict(self.metrics)}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Evaluation:
        """Reads :meth:`to_json`'s mapping."""
        return cls(int(data["index"]), tuple(data["unit"]), tuple(data["values"]),
                   float(data["score"]), str(data["status"]), str(data["reason"]),
                   float(data["wall_s"]), dict(data.get("metrics", {})))


def evaluate_task(problem: Problem, index: int, unit: Sequence[float] | np.ndarray
                  ) -> Evaluation:
    """Runs one trial; an exception becomes a failed evaluation, never a lost one."""
    u = np.asarray(unit, dtype=float)
    start = time.perf_counter()
    try:
        outcome = problem.evaluate(u)
    except Exception as err:  # a trial that raises is recorded as failed
        outcome = Outcome(problem.penalty, ERROR, f"error: {type(err).__name__}: {err}")
    return evaluation_of(problem, index, u, outcome, time.perf_counter() - start)


def evaluation_of(problem: Problem, index: int, unit: Sequence[float] | np.ndarray,
                  outcome: Outcome, wall: float) -> Evaluation:
    """The record of a finished trial (a score that is not finite fails it: the optimizer
    and summary.json take finite numbers only)."""
    u = np.asarray(unit, dtype=float)
    if not math.isfinite(outcome.score):
        outcome = Outcome(problem.penalty, ERROR, f"score {outcome.score} is not finite",
                          {k: v for k, v in outcome.metrics.items()
                           if not isinstance(v, float) or math.isfinite(v)})
    return Evaluation(index, tuple(float(x) for x in u),
                      tuple(float(x) for x in problem.values(u)), float(outcome.score),
                      outcome.status, outcome.reason, wall, outcome.metrics)


def lost_evaluation(problem: Problem, index: int, unit: Sequence[float] | np.ndarray, reason: str
                    ) -> Evaluation:
    """The record of a trial whose worker died every time it was tried."""
    u = np.asarray(unit, dtype=float)
    return Evaluation(index, tuple(float(x) for x in u),
                      tuple(float(x) for x in problem.values(u)), float(problem.penalty),
                      LOST, reason, 0.0, {})
