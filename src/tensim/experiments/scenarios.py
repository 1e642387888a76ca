"""The 12-segment Tetraspine scenarios (paper Fig. 1): their wave gaits, run and report.

The scenarios drive the impedance laws' target velocity V* with travelling waves of joint
bending (:class:`~tensim.control.wave.SpineWave`) or with learned gaits.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from tensim.control import ControllerConfig
from tensim.control.wave import SpineWave
from tensim.experiments.gait import locomotion
from tensim.model import WorldOptions, compile_structure
from tensim.models import load_controller, preset
from tensim.runs import world_record, write_run
from tensim.sim import COM, SimulationResult, TimeSeries, simulate
from tensim.terrain import Terrain, format_terrain
from tensim.viz import plot_cable_tensions, plot_path
from tensim.viz.plots import save_figure

MODEL = "tetraspine"  # the 12-segment preset
COMMAND_PERIOD = 0.01  # s between V* commands, as the hardware's packets
_CABLE_KINDS = ("outer_top", "outer_left", "outer_right", "inner_top", "inner_left",
                "inner_right")


def wave_controller(wave: SpineWave, duration: float, model: str = MODEL,
                    description: str = "") -> ControllerConfig:
    """The preset's impedance laws driven by ``wave`` for ``duration`` seconds."""
    p = preset(model)
    impedance = p.controller()
    if impedance is None:
        raise ValueError(f"preset {model!r} has no impedance controller to drive")
    return ControllerConfig(impedance, wave.gait(p.build()), duration=duration,
                            command_period=COMMAND_PERIOD, model=model,
                            description=description)


def resolve(controller: str | ControllerConfig | None, default: ControllerConfig,
            duration: float | None) -> ControllerConfig:
    """The scenario's controller: a file or shipped name (for the preset it names), a config,
    or the scenario's own, covering ``duration`` seconds (None: its own duration)."""
    if controller is None:
        config = default
    elif isinstance(controller, ControllerConfig):
        config = controller
    else:
        config = load_controller(controller)
    if config.gait is None:
        raise ValueError("the scenario needs a controller with a gait")
    return config.with_duration(duration) if duration else config


def run_scenario(name: str, config: ControllerConfig, terrain: Terrain, *,
                 world: WorldOptions | None = None,
                 progress: Callable[[float, float], None] | None = None
                 ) -> tuple[SimulationResult, dict[str, Any]]:
    """Runs ``config`` on its preset on ``terrain`` for the gait's duration.

    Returns:
        The result and the summary every scenario shares: headline figures of
        :meth:`SimulationResult.summary`, how far and where the robot moved
        (:func:`~tensim.experiments.gait.locomotion`) and the highest rise of any segment.
    """
    model = config.model or MODEL
    world = dataclasses.replace(world or WorldOptions(), terrain=terrain)
    compiled = compile_structure(preset(model).build(), world)
    result = simulate(compiled, config.duration,
                      controller=config.build(compiled.model.opt.timestep), progress=progress)
    rise = segment_rise(result.trajectory)
    summary: dict[str, Any] = {
        "experiment": name, "model": model, "terrain": format_terrain(terrain),
        "controller": config.description or "(in memory)", **result.summary(),
        **world_record(compiled.world),
        **locomotion(result.trajectory),
        "height_reached_m": round(max(rise.values()), 4),
        "segment_rise_m": {b: round(v, 4) for b, v in rise.items()}}
    return result, summary


def segments(series: TimeSeries) -> list[str]:
    """The recorded rigid bodies (segments), front first."""
    return [b for b in series.items("pos_x") if b != COM]


def segment_rise(series: TimeSeries) -> dict[str, float]:
    """Each segment's highest rise of its centre of mass above where it started [m]."""
    return {b: float(np.max(series[f"pos_z/{b}"] - series[f"pos_z/{b}"][0]))
            for b in segments(series)}


def write_scenario(out: Path, result: SimulationResult, summary: dict[str, Any],
                   config: ControllerConfig, terrain: Terrain, *,
                   extra_figures: tuple[str, ...] = ()) -> Path:
    """Writes the run folder: tensions of the first, middle and last joints, the top view of
    the path, a side view over the terrain, the controller file, trajectory and summary.

    ``extra_figures`` names figures the scenario wrote into ``out`` itself.
    """
    series = result.trajectory
    plot_cable_tensions(series, out / "tensions.png", cables=_shown_cables(result.cables),
                        columns=6,
                        title=f"{summary['experiment']}: measured tension (black), commanded "
                              "(dashed)")
    bodies = segments(series)
    plot_path(series, out / "path.png", [bodies[0], bodies[-1], COM],
              title=f"moved {summary['planar_displacement_m']:.2f} m, {summary['direction']}")
    plot_side_view(series, terrain, out / "side_view.png")
    figures = ["tensions.png", "path.png", "side_view.png", *extra_figures]
    return write_run(out, result, {**summary, "figures": figures}, controller=config)


def _shown_cables(cables: tuple[str, ...]) -> list[str] | None:
    """The cables of the first, middle and last joints of a Tetraspine (None: all cables)."""
    joints = sorted({int(c.rsplit("_", 1)[1]) for c in cables if c.rsplit("_", 1)[-1].isdigit()})
    if not joints:
        return None
    chosen = dict.fromkeys((joints[0], joints[len(joints) // 2], joints[-1]))
    shown = [f"{kind}_{j}" for j in chosen for kind in _CABLE_KINDS if f"{kind}_{j}" in cables]
    return shown or None


def side_view_figure(series: TimeSeries, terrain: Terrain) -> Figure:
    """Side view (x, z) of every segment's centre of mass over the terrain's profile at y = 0."""
    fig = Figure(figsize=(9, 3.2))
    ax = fig.subplots()
    viridis = matplotlib.colormaps["viridis"]
    x_all = np.concatenate([series[f"pos_x/{b}"] for b in segments(series)])
    x = np.linspace(x_all.min() - 0.3, x_all.max() + 0.3, 800)
    ground = terrain.geometry().height(x, np.zeros_like(x))
    ax.fill_between(x, np.where(np.isfinite(ground), ground, np.nan), ground[np.isfinite(
        ground)].min(initial=0.0) - 0.05, color="0.8", lw=0, label="terrain (y = 0)")
    for k, body in enumerate(segments(series)):
        ax.plot(series[f"pos_x/{body}"], series[f"pos_z/{body}"], lw=0.8,
                color=viridis(k / max(1, len(segments(series)) - 1)),
                label=body if k in (0, len(segments(series)) - 1) else None)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m] (not to scale with x)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    return fig


def plot_side_view(series: TimeSeries, terrain: Terrain, path: Path) -> Path:
    """Writes :func:`side_view_figure` as a PNG."""
    return save_figure(side_view_figure(series, terrain), path)
