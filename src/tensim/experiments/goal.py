"""Goal-directed locomotion: progress toward a target point, across rough ground.

:func:`goal_progress` is the objective (a plain function of a recorded run; ``tensim learn
--target X,Y`` scores trials with the same measure); :func:`run_goal` runs a controller toward a
target on rough terrain and reports how much closer the robot got. Its default gait was learned
that way. It is open loop: it walks where it learned to, so a target in another direction needs
a gait learned for it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from tensim.control import ControllerConfig
from tensim.experiments.scenarios import resolve, run_scenario, write_scenario
from tensim.learn.objective import target_distance, target_progress
from tensim.model import WorldOptions
from tensim.models import load_controller
from tensim.sim import COM, SimulationResult, TimeSeries
from tensim.terrain import Rough, Terrain
from tensim.viz.plots import save_figure

GOAL_TARGET = (1.5, 0.0)  # m; the 12-segment spine's centre of mass starts at x = -1.23
# 2 cm RMS bumps, 20 cm across; friction 1.0 as in the climb (the gait's own ground)
GOAL_TERRAIN = Rough(roughness=0.02, correlation=0.2, seed=1, size=4.0, resolution=0.04,
                     friction=1.0)
GOAL_DURATION = 60.0  # s
GOAL_GAIT = "tetraspine_goal"  # the shipped wave learned toward GOAL_TARGET on GOAL_TERRAIN
REACHED_RADIUS = 0.25  # m, horizontal distance that counts as reaching the target


def goal_distance(trajectory: TimeSeries, target_xy: tuple[float, float],
                  item: str = COM) -> np.ndarray:
    """(T,) horizontal distance from ``item`` (default the robot's centre of mass) to the
    target at every sample [m]."""
    return target_distance(trajectory, target_xy, item)


def goal_progress(trajectory: TimeSeries, target_xy: tuple[float, float]) -> float:
    """How much closer the robot got to a target point [m].

    The reduction of the horizontal (x-y) distance between the robot's centre of mass and
    ``target_xy`` from the first to the last sample: positive when it approached, negative
    when it moved away, 0 for a robot that stayed put or circled at a constant distance. A
    larger score is better, so it serves directly as an optimizer's objective; ``tensim learn
    --target X,Y`` scores trials with it (:class:`tensim.learn.Objective`).

    Args:
        trajectory: a recorded run (needs the ``pos_x/com`` and ``pos_y/com`` channels).
        target_xy: (x, y) of the target in the world frame [m].
    """
    return target_progress(trajectory, target_xy)


def goal_objective(target_xy: tuple[float, float]) -> Callable[[TimeSeries], float]:
    """``goal_progress`` toward a fixed target, as a function of the trajectory alone."""

    def objective(trajectory: TimeSeries) -> float:
        return goal_progress(trajectory, target_xy)

    objective.__name__ = f"goal_progress_to_{target_xy[0]:g}_{target_xy[1]:g}"
    return objective


def goal_summary(trajectory: TimeSeries, target_xy: tuple[float, float]) -> dict[str, Any]:
    """Distances to the target at the start, end and closest, the progress, whether the
    centre of mass came within :data:`REACHED_RADIUS` of it and when it first did [s]."""
    distance = goal_distance(trajectory, target_xy)
    inside = np.flatnonzero(distance <= REACHED_RADIUS)
    return {"target_xy_m": [float(target_xy[0]), float(target_xy[1])],
            "start_distance_m": round(float(distance[0]), 4),
            "final_distance_m": round(float(distance[-1]), 4),
            "closest_distance_m": round(float(distance.min()), 4),
            "goal_progress_m": round(goal_progress(trajectory, target_xy), 4),
            "reached": bool(inside.size),
            "reached_time_s": float(trajectory.time[inside[0]]) if inside.size else None,
            "reached_radius_m": REACHED_RADIUS}


def goal_controller(duration: float = GOAL_DURATION) -> ControllerConfig:
    """The scenario's default controller: the shipped ``tetraspine_goal`` wave, learned with
    ``tensim learn --target`` toward :data:`GOAL_TARGET` on :data:`GOAL_TERRAIN`."""
    return load_controller(GOAL_GAIT).with_duration(duration)


def run_goal(*, target_xy: tuple[float, float] = GOAL_TARGET, terrain: Terrain | None = None,
             controller: str | ControllerConfig | None = None, duration: float | None = None,
             world: WorldOptions | None = None,
             progress: Callable[[float, float], None] | None = None
             ) -> tuple[SimulationResult, dict[str, Any], ControllerConfig, Terrain]:
    """Runs a controller toward ``target_xy`` on rough ground (default :data:`GOAL_TERRAIN`).

    Args:
        target_xy: (x, y) of the target [m].
        terrain: the ground (None: :data:`GOAL_TERRAIN`).
        controller: controller file, shipped name or config (None: :func:`goal_controller`).
        duration: simulated time [s] (None: the controller's gait duration, 60 s by default).
        world: physics step and other world options (its terrain is replaced).
        progress: called as progress(done_s, total_s).

    Returns:
        The result, its summary (with :func:`goal_summary`), the controller and the terrain.
    """
    if not all(math.isfinite(v) for v in target_xy) or len(target_xy) != 2:
        raise ValueError(f"target_xy must be two finite coordinates [m], got {target_xy!r}")
    terrain = terrain or GOAL_TERRAIN
    config = resolve(controller, goal_controller(), duration)
    result, summary = run_scenario("goal", config, terrain, world=world, progress=progress)
    return result, {**summary, **goal_summary(result.trajectory, target_xy)}, config, terrain


def goal_distance_figure(trajectory: TimeSeries, target_xy: tuple[float, float]) -> Figure:
    """Horizontal distance of the centre of mass to the target over time."""
    fig = Figure(figsize=(6, 3))
    ax = fig.subplots()
    ax.plot(trajectory.time, goal_distance(trajectory, target_xy), color="black", lw=1.0)
    ax.axhline(REACHED_RADIUS, color="tab:green", ls="--", lw=0.8, label="reached")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("distance to target [m]")
    ax.set_title(f"target ({target_xy[0]:g}, {target_xy[1]:g}) m", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_goal_distance(trajectory: TimeSeries, target_xy: tuple[float, float],
                       path: Path) -> Path:
    """Writes :func:`goal_distance_figure` as a PNG."""
    return save_figure(goal_distance_figure(trajectory, target_xy), path)


def write_goal(out: Path, result: SimulationResult, summary: dict[str, Any],
               config: ControllerConfig, terrain: Terrain) -> Path:
    """Writes the scenario's run folder plus ``goal_distance.png``."""
    target = (summary["target_xy_m"][0], summary["target_xy_m"][1])
    plot_goal_distance(result.trajectory, target, out / "goal_distance.png")
    return write_scenario(out, result, summary, config, terrain,
                          extra_figures=("goal_distance.png",))
