"""Gait experiments (paper Figs. 4 and 5): a controller file's gait on Tetraspine3.

``sine`` runs the hand-tuned style sine gait, ``cpg`` the simulator-tuned CPG gait that moves
the robot sideways. Both report every cable's tensions (measured and commanded), the V* each
cable was given, the robot's path and how far and in which direction it moved.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tensim.control import ControllerConfig, VelocityTable
from tensim.model import WorldOptions, compile_structure
from tensim.models import load_controller, preset
from tensim.runs import world_record, write_run
from tensim.sim import COM, SimulationResult, TimeSeries, simulate
from tensim.structure import Structure
from tensim.viz.drawing import FigureDrawer, FigurePlan

CABLE_ORDER = tuple(f"{kind}_{j}" for j in (1, 2) for kind in (
    "outer_top", "outer_left", "outer_right", "inner_top", "inner_left", "inner_right"))
SETTLE_S = 1.0  # the robot settles under gravity first; displacement counts from here
_DIRECTIONS = ((0.0, "forward (+x)"), (90.0, "left (+y)"), (180.0, "backward (-x)"),
               (-90.0, "right (-y)"), (-180.0, "backward (-x)"))


def locomotion(series: TimeSeries, start: float = SETTLE_S, item: str = COM) -> dict[str, Any]:
    """How far and where ``item`` (default the centre of mass) moved in the ground plane.

    Args:
        series: a recorded run.
        start: time the displacement counts from [s] (after settling).
        item: a recorded body name, or ``com``.

    Returns:
        ``planar_displacement_m`` (x-y distance), ``world_dx_m`` and ``world_dy_m`` (along the
        world's x and y; +y is the robot's left at the start), ``direction_deg``
        (of the x-y displacement from +x, counter-clockwise), ``direction`` (the nearest of
        forward, left, backward, right) and ``average_speed_m_per_s``, all in the world
        frame; and ``body_forward_m``, ``body_sideways_m`` (+ = the robot's left) and
        ``heading_change_deg`` along the robot's own turning axes (see :func:`_body_frame`).
    """
    t = series.time
    k0 = int(np.searchsorted(t, min(start, t[-1]) - 1e-9))
    dx = float(series[f"pos_x/{item}"][-1] - series[f"pos_x/{item}"][k0])
    dy = float(series[f"pos_y/{item}"][-1] - series[f"pos_y/{item}"][k0])
    angle = math.degrees(math.atan2(dy, dx))
    label = min(_DIRECTIONS, key=lambda d: abs(d[0] - angle))[1]
    span = float(t[-1] - t[k0])
    distance = math.hypot(dx, dy)
    return {**_body_frame(series, k0, item),
            "planar_displacement_m": round(distance, 6),
            "world_dx_m": round(dx, 6),
            "world_dy_m": round(dy, 6),
            "direction_deg": round(angle, 2),
            "direction": label,
            "average_speed_m_per_s": round(distance / span, 6) if span > 0 else 0.0,
            "displacement_from_s": float(t[k0])}


def _body_frame(series: TimeSeries, k0: int, item: str) -> dict[str, Any]:
    """Displacement along the robot's own axes, which turn with it.

    The heading is the spine axis in the ground plane, from the last recorded body to the first
    (for a spine preset: rear segment to front segment). Each step of ``item``'s path is split
    into its components along the heading (forward) and 90° to its left (sideways) at that time,
    so a robot that walks sideways while turning still counts as walking sideways.
    """
    bodies = [b for b in series.items("pos_x") if b != COM]
    if len(bodies) < 2:
        return {}
    front, rear = bodies[0], bodies[-1]
    hx = series[f"pos_x/{front}"][k0:] - series[f"pos_x/{rear}"][k0:]
    hy = series[f"pos_y/{front}"][k0:] - series[f"pos_y/{rear}"][k0:]
    heading = np.unwrap(np.arctan2(hy, hx))
    mid = 0.5 * (heading[1:] + heading[:-1])
    step_x = np.diff(series[f"pos_x/{item}"][k0:])
    step_y = np.diff(series[f"pos_y/{item}"][k0:])
    forward = float(np.sum(step_x * np.cos(mid) + step_y * np.sin(mid)))
    sideways = float(np.sum(-step_x * np.sin(mid) + step_y * np.cos(mid)))
    angle = math.degrees(math.atan2(sideways, forward))
    label = min(_DIRECTIONS, key=lambda d: abs(d[0] - angle))[1].split(" ")[0]
    return {"body_forward_m": round(forward, 6), "body_sideways_m": round(sideways, 6),
            "body_direction": f"{label} (robot frame)",
            "heading_change_deg": round(math.degrees(heading[-1] - heading[0]), 2)}


def run_gait(name: str, controller: str | ControllerConfig, *, model: str = "tetraspine3",
             structure: Structure | None = None,
             duration: float | None = None, world: WorldOptions | None = None,
             progress: Callable[[float, float], None] | None = None,
             before: Callable[[ControllerConfig, float, float], None] | None = None
             ) -> tuple[SimulationResult, dict[str, Any], ControllerConfig]:
    """Runs a gait from a controller file (or config) on a preset.

    Args:
        name: experiment name for the summary (``sine``, ``cpg``).
        controller: controller file path, shipped name, or a loaded config.
        model: the preset, or a label for ``structure``.
        structure: the robot (None: the preset ``model``), e.g. a fitted variant.
        duration: simulated time [s] (None: the gait's duration).
        world: physics step, ground, ...
        progress: called as progress(done_s, total_s).

    Returns:
        The result, its summary and the controller config used.
    """
    structure = structure or preset(model).build()
    config = controller if isinstance(controller, ControllerConfig) else \
        load_controller(controller, structure)
    if config.gait is None:
        raise ValueError(f"controller {controller!r} has no gait: the {name} experiment needs "
                         "one (see `tensim models` for the shipped gait files)")
    if duration and not isinstance(config.gait, VelocityTable):
        config = config.with_duration(duration)  # the gait runs as long as asked
    duration = duration or config.duration
    compiled = compile_structure(structure, world or WorldOptions())
    dt = compiled.model.opt.timestep
    if before is not None:
        before(config, duration, dt)
    result = simulate(compiled, duration, controller=config.build(dt), progress=progress)
    summary: dict[str, Any] = {
        "experiment": name, "model": model,
        "controller": controller if isinstance(controller, str) else "(in memory)",
        "gait": type(config.gait).__name__,
        "command_period_s": config.command_period,
        **result.summary(), **world_record(compiled.world), **locomotion(result.trajectory)}
    return result, summary, config


def gait_figures(name: str, cables: Sequence[str]) -> list[FigurePlan]:
    """The figures of a gait run folder (tensions, V* inputs, lengths, path), before it runs.

    Args:
        name: the experiment (``cpg``, ``sine``), for the titles.
        cables: the robot's cable names.
    """
    shown = [c for c in CABLE_ORDER if c in cables] or list(cables)
    return [FigurePlan("tensions.png", "tensions", {
                "cables": shown, "columns": 3,
                "title": f"Tetraspine3 {name} gait: measured tension (black), commanded "
                         "(dashed)"}),
            FigurePlan("velocity_input.png", "velocity_input", {"cables": shown}),
            FigurePlan("lengths.png", "lengths", {"cables": shown}),
            FigurePlan("path.png", "path")]


def draw_velocity_input(drawer: FigureDrawer, config: ControllerConfig, duration: float,
                        dt: float, out: Path) -> None:
    """Hands the gait's V* inputs (known before it runs) to ``drawer`` for velocity_input.png,
    if it has a V* table."""
    table = config.velocity_table(dt)
    if table is not None:
        drawer.draw("velocity_input.png", table, out, until=duration)


def write_gait(out: Path, result: SimulationResult, summary: dict[str, Any],
               config: ControllerConfig, structure: Structure | None = None,
               drawer: FigureDrawer | None = None) -> Path:
    """Writes tensions (Fig. 4/5 style), V* inputs, lengths, path, trajectory, the robot
    (``structure``, None: the preset) and controller, and the summary.

    ``drawer``: a drawer of :func:`gait_figures` opened before the run (it may have laid them
    out meanwhile); None: drawn here.
    """
    drawer = drawer or FigureDrawer(gait_figures(summary.get("experiment", "gait"),
                                                 result.cables))
    drawer.draw("tensions.png", result.trajectory, out)
    figures = ["tensions.png", "velocity_input.png", "lengths.png", "path.png"]
    if "velocity_input.png" not in drawer.handed:
        draw_velocity_input(drawer, config, result.duration_s, result.dt_s, out)
    drawer.draw("lengths.png", result.trajectory, out)
    drawer.draw("path.png", result.trajectory, out,
                items=[*(b for b in result.trajectory.items("pos_x") if b != COM), COM],
                title=f"moved {summary['planar_displacement_m']:.3f} m, "
                      f"{summary['direction']}")
    return write_run(out, result, {**summary, "figures": figures}, structure=structure,
                     controller=config, drawer=drawer)
