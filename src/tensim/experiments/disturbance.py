"""The paper's steady-disturbance test (Fig. 3), on Tetraspine3 or any robot.

A forward force on the front segment's tip ramps 0 -> 22.56 N (2.3 kg-force) over 30-35 s,
holds until 40 s and ramps back to 0 by 45 s; restoring forces of 0.45 and 0.55 of it act
backwards at the middle and rear tips, so the robot is held in place. The impedance
controllers run from t = 0 with the reference gains.

On another robot a :class:`Push` names the pushed node, the direction and the nodes that
take the force back (with their shares), and the controller is the one given, else the
robot's laws that hold its build pose (:func:`~tensim.control.default_impedance`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tensim.control import ControllerConfig, default_impedance
from tensim.experiments.stance import MAX_MOVE_SIZES, robot_size, rod_axes, stance_problems
from tensim.model import WorldOptions, compile_structure
from tensim.models import preset
from tensim.models.tetraspine import node_name
from tensim.runs import world_record, write_run
from tensim.sim import NodeLoad, SimulationResult, ramp_hold_release, simulate
from tensim.structure import Structure
from tensim.viz.drawing import FigureDrawer, FigurePlan, Span

PEAK_FORCE = 22.56  # N
START, RISE, HOLD, FALL = 30.0, 5.0, 5.0, 5.0  # s
DURATION = 60.0  # s
RESTORING_SHARE = {1: 0.45, 2: 0.55}  # segment -> share of the force it takes back
DEFAULT_CONTROLLER = "the preset's impedance laws (as tetraspine3_impedance: V* = 0)"
BEFORE = (25.0, 30.0)  # s, window before the push
DURING = (35.0, 40.0)  # s, the hold phase


@dataclasses.dataclass(frozen=True)
class Push:
    """Where the disturbance test pushes and which nodes hold the robot in place.

    Attributes:
        node: the pushed node.
        holds: (node, share) pairs: each node takes ``share`` of the force back (shares
            summing to 1 hold the robot in place; none: the robot is free to slide).
        direction: (3,) push direction, normalised (world frame).
        peak: force at the plateau [N].
    """

    node: str = node_name(0, "tip")
    holds: tuple[tuple[str, float], ...] = tuple(
        (node_name(seg, "tip"), share) for seg, share in RESTORING_SHARE.items())
    direction: tuple[float, float, float] = (1.0, 0.0, 0.0)
    peak: float = PEAK_FORCE

    def __post_init__(self) -> None:
        if not (math.isfinite(self.peak) and self.peak >= 0):
            raise ValueError(f"peak force must be >= 0 N, got {self.peak}")
        if not np.linalg.norm(self.direction) > 0:
            raise ValueError(f"push direction must be non-zero, got {self.direction}")
        for node, share in self.holds:
            if not (math.isfinite(share) and share > 0):
                raise ValueError(f"hold at {node!r}: share must be > 0, got {share}")

    def nodes(self) -> tuple[str, ...]:
        """The pushed node, then the holding ones."""
        return (self.node, *(n for n, _ in self.holds))


def disturbance_loads(peak: float = PEAK_FORCE, push: Push | None = None,
                      start: float = START) -> list[NodeLoad]:
    """The push (default: on segment 0's tip) and the restoring forces (the other tips), the
    push's rise starting at ``start`` [s]."""
    push = push or Push(peak=peak)
    load = ramp_hold_release(push.node, push.direction, push.peak, start, RISE, HOLD, FALL)
    return [load] + [load.scaled(-share).at(node) for node, share in push.holds]


def check_disturbance(structure: Structure, push: Push, duration: float) -> list[str]:
    """Checks the test fits the robot and run before it simulates.

    Returns:
        Notes for a run that ends before the push or its hold window.

    Raises:
        ValueError: a pushed or holding node the robot lacks, naming its nodes.
    """
    nodes = [n.name for n in structure.nodes]
    missing = [n for n in push.nodes() if n not in nodes]
    if missing:
        raise ValueError(f"the disturbance test pushes or holds {missing}, which "
                         f"{structure.name!r} lacks; name its nodes with --push and --hold "
                         f"(nodes: {', '.join(nodes)})")
    if duration <= START:
        return [f"the run ends at {duration:g} s, before the push starts at {START:g} s: "
                f"nothing is pushed (the whole test takes {DURATION:g} s)"]
    if duration < DURING[1]:
        return [f"the run ends at {duration:g} s, before the hold window {DURING[0]:g}-"
                f"{DURING[1]:g} s ends: no hold tensions are reported"]
    return []


def record_period(dt: float, target: float = 0.01) -> float:
    """A recording period near ``target`` that is a whole number of steps of ``dt`` [s]."""
    return dt * max(1, math.ceil(target / dt - 1e-9))


def robot_controller(structure: Structure | None, config: ControllerConfig | None = None,
                     label: str | None = None) -> tuple[ControllerConfig | None, str]:
    """The controller an experiment runs a robot under, and its label for the summary.

    ``config`` if given; else Tetraspine3's impedance laws for Tetraspine3 or a variant with its
    cable names; else laws that hold the build pose; None for a robot without motors.
    """
    if config is not None:
        return config, label or "the controller given"
    reference = preset("tetraspine3")
    if structure is None or {c.name for c in structure.cables} == {
            c.name for c in reference.build().cables}:
        impedance = reference.controller()
        return (ControllerConfig(impedance, model="tetraspine3") if impedance else None,
                DEFAULT_CONTROLLER)
    if not any(not c.motor.passive for c in structure.cables):
        return None, "none (no motorised cable)"
    return (ControllerConfig(default_impedance(structure)),
            "default_impedance: holds the build pose (as tensim controller init)")


def run_disturbance(dt: float = 1e-3, duration: float = DURATION, backend: str = "auto",
                    progress: Callable[[float, float], None] | None = None,
                    world: WorldOptions | None = None, structure: Structure | None = None, *,
                    push: Push | None = None, controller: ControllerConfig | None = None,
                    model: str | None = None, controller_label: str | None = None
                    ) -> tuple[SimulationResult, dict[str, Any]]:
    """Runs the test and returns the result and its summary.

    Args:
        structure: the robot (None: the ``tetraspine3`` preset).
        push: the pushed and holding nodes (None: Tetraspine3's tips, as in the paper).
        controller: the controller (None: see :func:`robot_controller`).
        model: the robot's name for the summary (None: the preset's, or the structure's).
        controller_label: the controller's name for the summary.

    Raises:
        ValueError: a pushed or holding node the robot lacks.
    """
    push = push or Push()
    robot = structure or preset("tetraspine3").build()
    check_disturbance(robot, push, duration)
    config, label = robot_controller(structure, controller, controller_label)
    world = world or WorldOptions()
    compiled = compile_structure(robot, dataclasses.replace(world, timestep=dt))
    result = simulate(compiled, duration,
                      controller=config.build(dt) if config is not None else None,
                      loads=disturbance_loads(push=push), record_dt=record_period(dt),
                      backend=backend, progress=progress)
    name = model or ("tetraspine3" if structure is None else structure.name)
    summary = summarize(result, name, label, push, size=robot_size(robot), axes=rod_axes(robot))
    return result, {**summary, **world_record(compiled.world)}


def summarize(result: SimulationResult, model: str = "tetraspine3",
              controller: str = DEFAULT_CONTROLLER, push: Push | None = None,
              size: float | None = None,
              axes: dict[str, np.ndarray] | None = None) -> dict[str, Any]:
    """Headline figures plus each cable's mean tension before and during the hold phase, and
    whether the robot kept its stance (``stance_problems``, ``valid``: a robot that tipped
    over, or whose centre of mass moved more than a quarter of its ``size`` [m], took no
    steady push and its tension figures mean nothing; ``axes``: see
    :func:`tensim.experiments.stance.rod_axes`)."""
    series = result.trajectory
    summary: dict[str, Any] = {"model": model, "experiment": "disturbance",
                               "controller": controller, **result.summary()}
    problems = stance_problems(series, axes=axes, max_move_m=None if size is None
                               else MAX_MOVE_SIZES * size)
    summary["valid"] = not problems
    summary["stance_problems"] = problems
    if series.time[-1] >= DURING[1]:
        before = series.between(*BEFORE).matrix("tension", result.cables).mean(axis=0)
        during = series.between(*DURING).matrix("tension", result.cables).mean(axis=0)
        summary["mean_tension_before_N"] = _named(result.cables, before)
        summary["mean_tension_hold_N"] = _named(result.cables, during)
        summary["tension_change_hold_N"] = _named(result.cables, during - before)
    push = push or Push()
    summary["peak_force_N"] = push.peak
    if push != Push():
        summary["push"] = {"node": push.node, "direction": list(push.direction),
                           "holds": {n: share for n, share in push.holds}}
    return summary


def _named(names: tuple[str, ...], values: np.ndarray) -> dict[str, float]:
    return {n: round(float(v), 4) for n, v in zip(names, values, strict=True)}


CABLE_PANELS = tuple(f"{kind}_{j}" for j in (1, 2) for kind in (
    "outer_top", "outer_left", "outer_right", "inner_top", "inner_left", "inner_right"))


def disturbance_figures(cables: tuple[str, ...] = CABLE_PANELS, robot: str = "Tetraspine3"
                        ) -> list[FigurePlan]:
    """The figures of a disturbance run folder (tensions, lengths, path), before it runs.

    Args:
        cables: the cables drawn, one panel each (default: Tetraspine3's).
        robot: the robot's name in the titles.
    """
    spans = (Span(START, START + RISE + HOLD + FALL, "force ramps / holds", 0.10),
             Span(*DURING, "hold (averaged)", 0.25),
             Span(*BEFORE, "before (averaged)", 0.12, "tab:green"))
    return [FigurePlan("tensions.png", "tensions", {
                "cables": cables, "columns": 3, "spans": spans,
                "title": f"{robot} disturbance test: measured tension (black), commanded "
                         "(blue dashed);\norange: external force on, darker while held "
                         f"({DURING[0]:g}-{DURING[1]:g} s); green: the window before"}),
            FigurePlan("lengths.png", "lengths", {
                "cables": cables, "columns": 3,
                "title": f"{robot} disturbance test: cable length and motor rest length"}),
            FigurePlan("path.png", "path")]


def write_disturbance(out: Path, result: SimulationResult, summary: dict[str, Any],
                      structure: Structure | None = None,
                      drawer: FigureDrawer | None = None,
                      controller: ControllerConfig | None = None) -> Path:
    """Writes the run folder: trajectory, tension and length figures, the robot (``structure``,
    None: the preset) and its controller, summary.

    ``drawer``: a drawer of :func:`disturbance_figures` opened before the run (it may have
    laid them out meanwhile); None: drawn here. ``controller``: the one it ran under (None:
    see :func:`robot_controller`).
    """
    drawer = drawer or FigureDrawer(disturbance_figures())
    for plan in drawer.plans.values():
        drawer.draw(plan.file, result.trajectory, out)
    summary = {**summary, "figures": ["tensions.png", "lengths.png"]}
    config = controller or robot_controller(structure)[0]
    return write_run(out, result, summary, structure=structure, controller=config,
                     drawer=drawer)
