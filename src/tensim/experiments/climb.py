"""Wall climb (paper Fig. 1, top): the 12-segment Tetraspine crawls at a wall and over it.

The gait is a caterpillar wave: pitch bending with some axial stretching that travels from the
tail to the head (each joint 0.8 rad *ahead* of the one behind it), found by a short search in
simulation (Gaussian hill climbing from random samples, objective: segments past a 5 cm wall in
40 s). The summary says how high the segments rose, how many got onto and past the wall, and
how far and where the robot moved.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from tensim.control import ControllerConfig, SpineWave
from tensim.experiments.scenarios import (
    resolve,
    run_scenario,
    segments,
    wave_controller,
    write_scenario,
)
from tensim.model import WorldOptions
from tensim.sim import SimulationResult, TimeSeries
from tensim.terrain import Terrain, Wall

CLIMB_DURATION = 75.0  # s
# a wall as high as the segments' tips, 10 cm ahead of the front tip; the robot's own friction
# (0.075, a smooth lab floor) gives no grip to climb with, so the ground and wall set 1.0
CLIMB_TERRAIN = Wall(height=0.1, distance=0.35, thickness=0.05, width=4.0, friction=1.0)
CLIMB_WAVE = SpineWave(frequency=0.165, joint_lag=-0.8, axial=(-0.13, 0.0), pitch=(0.15, -1.0))


def climb_controller(duration: float = CLIMB_DURATION) -> ControllerConfig:
    """The scenario's default controller: the preset's impedance laws under :data:`CLIMB_WAVE`."""
    return wave_controller(CLIMB_WAVE, duration, description="caterpillar wave (climb gait)")


def wall_progress(series: TimeSeries, wall: Wall) -> dict[str, Any]:
    """How far the segments got over ``wall`` by the end of the run.

    Returns:
        ``segments_on_wall`` (centre of mass above the wall's top, between its faces),
        ``segments_past_wall`` (beyond its far face), and ``front_height_reached_m``, the
        front segment's highest rise [m].
    """
    near, far = wall.distance, wall.distance + wall.thickness
    bodies = segments(series)
    x_end = [float(series[f"pos_x/{b}"][-1]) for b in bodies]
    front = bodies[0]
    return {"wall_height_m": wall.height,
            "segments_on_wall": sum(near <= x <= far for x in x_end),
            "segments_past_wall": sum(x > far for x in x_end),
            "front_height_reached_m": round(float(
                (series[f"pos_z/{front}"] - series[f"pos_z/{front}"][0]).max()), 4)}


def run_climb(*, terrain: Terrain | None = None,
              controller: str | ControllerConfig | None = None, duration: float | None = None,
              world: WorldOptions | None = None,
              progress: Callable[[float, float], None] | None = None
              ) -> tuple[SimulationResult, dict[str, Any], ControllerConfig, Terrain]:
    """Runs the wall climb.

    Args:
        terrain: the ground (None: :data:`CLIMB_TERRAIN`); a wall adds the wall figures.
        controller: controller file, shipped name or config (None: :func:`climb_controller`).
        duration: simulated time [s] (None: the controller's gait duration, 60 s by default).
        world: physics step and other world options (its terrain is replaced).
        progress: called as progress(done_s, total_s).

    Returns:
        The result, its summary, the controller and the terrain.
    """
    terrain = terrain or CLIMB_TERRAIN
    config = resolve(controller, climb_controller(), duration)
    result, summary = run_scenario("climb", config, terrain, world=world, progress=progress)
    if isinstance(terrain, Wall):
        summary.update(wall_progress(result.trajectory, terrain))
    return result, summary, config, terrain


def write_climb(out: Path, result: SimulationResult, summary: dict[str, Any],
                config: ControllerConfig, terrain: Terrain) -> Path:
    """Writes the run folder (see :func:`~tensim.experiments.scenarios.write_scenario`)."""
    return write_scenario(out, result, summary, config, terrain)
