"""The quasi-static drag test (paper section IV-A): the force to drag the robot at a steady speed.

A tow point moves along the ground plane at constant speed and pulls a node of the robot
through a horizontal spring-damper line (a string only pulls, so the force is never negative).
Once the robot slides steadily, the line force equals the ground's total sliding friction; with
the pull horizontal, the normal forces add up to m g, so Coulomb friction predicts
F = μ m g whatever the robot's pose. The ratio F / (m g) is the effective friction coefficient
to match against the hardware's drag force.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from matplotlib.figure import Figure

from tensim.control import ControllerConfig
from tensim.experiments.stance import rod_axes, stance_problems
from tensim.model import WorldOptions, compile_structure
from tensim.models import preset
from tensim.runs import world_record, write_run
from tensim.sim import Controller, Simulation, SimulationResult, TimeSeries, cable_tension
from tensim.structure import Structure
from tensim.viz import plot_cable_tensions
from tensim.viz.plots import save_figure, thin

DEFAULT_CONTROLLER = "the preset's impedance laws (V* = 0)"
TOW_CHANNEL = "tow_force/line"  # the tow line's force [N], recorded with the trajectory


@dataclasses.dataclass(frozen=True)
class DragSettings:
    """How the robot is towed.

    Attributes:
        node: the node the tow line pulls.
        direction: unit pull direction in the ground plane (x, y).
        speed: tow-point speed [m/s].
        settle: time before the tow starts [s] (the robot settles on the ground).
        duration: total simulated time [s].
        stiffness: tow-line stiffness [N/m].
        damping: tow-line damping [N s/m].
        steady_from: start of the averaging window, as a time after the tow starts [s].
        record_dt: recording period, also the period the line force is updated at [s].
    """

    node: str = "s0_tip"
    direction: tuple[float, float] = (1.0, 0.0)
    speed: float = 0.05
    settle: float = 2.0
    duration: float = 14.0
    stiffness: float = 200.0
    damping: float = 40.0
    steady_from: float = 4.0
    record_dt: float = 0.002

    def __post_init__(self) -> None:
        norm = math.hypot(*self.direction)
        if not norm > 0:
            raise ValueError(f"direction must be a non-zero (x, y) vector, got {self.direction}")
        object.__setattr__(self, "direction", (self.direction[0] / norm,
                                               self.direction[1] / norm))
        for field in ("speed", "stiffness", "record_dt", "duration"):
            if not getattr(self, field) > 0:
                raise ValueError(f"{field} must be > 0, got {getattr(self, field)}")
        if not self.settle + self.steady_from < self.duration:
            raise ValueError(f"duration {self.duration:g} s is too short for the drag test: it "
                             f"must be more than {self.settle + self.steady_from:g} s (the tow "
                             f"starts at {self.settle:g} s and the force is averaged from "
                             f"{self.steady_from:g} s after that); the default is "
                             f"{DragSettings.duration:g} s")


class _Tow:
    """Updates the tow-line force on the pulled body after every recorded sample."""

    def __init__(self, sim: Simulation, settings: DragSettings):
        index = sim.index
        self.settings = settings
        self.body = index.node_body[settings.node]
        self.local = index.node_local[settings.node]
        self.d = np.array([*settings.direction, 0.0])
        self.start: np.ndarray | None = None
        self.times: list[float] = []
        self.forces: list[float] = []
        self.point = np.zeros(3)
        self.velocity = np.zeros(6)

    def _node(self, sim: Simulation) -> tuple[np.ndarray, float]:
        d = sim.data
        point = d.xpos[self.body] + d.xmat[self.body].reshape(3, 3) @ self.local
        mujoco.mj_objectVelocity(sim.model, d, mujoco.mjtObj.mjOBJ_BODY, self.body,
                                 self.velocity, 0)
        omega, v_origin = self.velocity[:3], self.velocity[3:]
        v_point = v_origin + np.cross(omega, point - d.xpos[self.body])
        return point, float(v_point @ self.d)

    def __call__(self, sim: Simulation) -> None:
        s, t = self.settings, sim.time
        point, speed = self._node(sim)
        force = 0.0
        if t >= s.settle:
            if self.start is None:
                self.start = point.copy()
            travelled = s.speed * (t - s.settle)
            stretch = travelled - float((point - self.start) @ self.d)
            # the tow line is a cable: the one tension-only spring-damper law (rest length 0)
            force = float(cable_tension(stretch, s.speed - speed, 0.0, s.stiffness,
                                        s.damping)[1])
        f = force * self.d
        xfrc = sim.data.xfrc_applied[self.body]
        xfrc[:3] = f
        xfrc[3:] = np.cross(point - sim.data.xipos[self.body], f)
        self.times.append(t)
        self.forces.append(force)


def check_drag(structure: Structure, settings: DragSettings) -> None:
    """Checks the towed node is the robot's, before anything runs.

    Raises:
        ValueError: naming the robot's nodes.
    """
    nodes = [n.name for n in structure.nodes]
    if settings.node not in nodes:
        raise ValueError(f"the drag test tows node {settings.node!r}, which {structure.name!r} "
                         f"lacks; name one with --tow (nodes: {', '.join(nodes)})")


def run_drag(model: str = "tetraspine3", settings: DragSettings | None = None, *,
             structure: Structure | None = None,
             world: WorldOptions | None = None, duration: float | None = None,
             progress: Callable[[float, float], None] | None = None,
             controller: ControllerConfig | None = None, name: str | None = None,
             controller_label: str | None = None
             ) -> tuple[SimulationResult, dict[str, Any]]:
    """Drags ``model`` (under its own impedance controller, V* = 0) and measures the force.

    Args:
        model: the preset.
        settings: how it is towed.
        structure: the robot instead of the preset's (any robot: tow one of its nodes).
        controller: its controller (None: the preset's impedance laws).
        name: the robot's name in the summary (None: ``model``, or the structure's name).
        controller_label: the controller's name in the summary.

    Raises:
        ValueError: a towed node the robot lacks.
    """
    settings = settings or DragSettings()
    if duration is not None:
        settings = dataclasses.replace(settings, duration=duration)
    p = preset(model)
    label = name or (model if structure is None else structure.name)
    structure = structure or p.build()
    check_drag(structure, settings)
    compiled = compile_structure(structure, world or WorldOptions())
    laws: Controller | None = p.controller()
    if controller is not None:
        laws = controller.build(compiled.model.opt.timestep)
    else:
        controller_label = None
    with Simulation(compiled, controller=laws, record_dt=settings.record_dt) as sim:
        tow = _Tow(sim, settings)
        tow(sim)
        start = time.perf_counter()
        trajectory = sim.run(settings.duration, progress, on_record=tow)
        wall = time.perf_counter() - start
        result = SimulationResult(trajectory, sim.drive.peak.copy(), wall, settings.duration,
                                  sim.dt, sim.index.cables, sim.drive.peak_speed.copy(),
                                  sim.drive.peak_power.copy())
    times, forces = np.array(tow.times), np.array(tow.forces)
    window = times >= settings.settle + settings.steady_from
    m = compiled.model
    weight = mujoco.mj_getTotalmass(m) * float(np.linalg.norm(m.opt.gravity))
    friction = float(np.mean([r.friction for r in structure.rods]))
    drag = float(forces[window].mean())
    com_x = trajectory["pos_x/com"]
    steady_speed = float(np.polyfit(times[window], com_x[window], 1)[0]) if window.sum() > 2 \
        else math.nan
    summary = {
        "experiment": "drag", "model": label,
        "controller": controller_label or DEFAULT_CONTROLLER,
        **result.summary(),
        "drag_force_N": round(drag, 5),
        "drag_force_std_N": round(float(forces[window].std()), 5),
        "coulomb_force_N": round(friction * weight, 5),
        "effective_friction": round(drag / weight, 5),
        "rod_friction": friction,
        "weight_N": round(weight, 5),
        "tow_speed_m_per_s": settings.speed,
        "com_speed_m_per_s": round(steady_speed, 5),
        "settings": dataclasses.asdict(settings), **world_record(compiled.world),
    }
    problems = stance_problems(trajectory, axes=rod_axes(structure)) \
        + _unsteady(forces[window], steady_speed, settings.speed)
    summary["valid"], summary["stance_problems"] = not problems, problems
    if times.size == trajectory.time.size and np.allclose(times, trajectory.time):
        # the line force, sampled with everything else, goes into trajectory.parquet
        trajectory = TimeSeries(trajectory.time, {**trajectory.channels, TOW_CHANNEL: forces})
        result = dataclasses.replace(result, trajectory=trajectory)
    return result, summary


STEADY_CHANGE = 0.1  # the line force's change across the steady window, of its mean
SPEED_MISMATCH = 0.2  # the centre of mass's speed off the tow's by more: not towed steadily


def _unsteady(forces: np.ndarray, com_speed: float, tow_speed: float) -> list[str]:
    """Why the steady window holds no steady sliding (empty: it does): the line force still
    changing between its halves, or the robot not keeping up with the tow point."""
    problems = []
    if forces.size >= 4:
        first, second = forces[:forces.size // 2].mean(), forces[forces.size // 2:].mean()
        if abs(second - first) > STEADY_CHANGE * max(abs(forces.mean()), 1e-9):
            problems.append(f"the line force was still changing in the steady window (mean "
                            f"{first:.4g} N in its first half, {second:.4g} N in its second): "
                            "the robot never slid steadily")
    if not abs(com_speed - tow_speed) <= SPEED_MISMATCH * tow_speed:
        problems.append(f"its centre of mass moved at {com_speed:.3g} m/s in the steady window, "
                        f"not the tow's {tow_speed:g} m/s: it did not slide with the tow")
    return problems


def drag_figure(series: TimeSeries, summary: dict[str, Any]) -> Figure:
    """The tow-line force over time against μ m g, with the steady window shaded."""
    fig = Figure(figsize=(7, 3.2))
    ax = fig.subplots()
    ax.plot(*thin(series.time, series[TOW_CHANNEL]), color="black", lw=1.0, label="tow line")
    ax.axhline(summary["coulomb_force_N"], color="tab:red", ls="--", lw=1.0,
               label=f"μ m g = {summary['coulomb_force_N']:.3f} N")
    s = summary["settings"]
    ax.axvspan(s["settle"] + s["steady_from"], s["duration"], color="tab:blue", alpha=0.1,
               label=f"steady: mean {summary['drag_force_N']:.3f} N")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("drag force [N]")
    ax.set_title(f"Drag at {s['speed']} m/s: effective friction "
                 f"{summary['effective_friction']:.4f}", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def write_drag(out: Path, result: SimulationResult, summary: dict[str, Any],
               structure: Structure | None = None,
               controller: ControllerConfig | None = None) -> Path:
    """Writes the tow force over time, the cable tensions, trajectory (with the line force as
    channel ``tow_force/line``), the robot (``structure``, None: the preset), its controller
    and summary."""
    out.mkdir(parents=True, exist_ok=True)
    save_figure(drag_figure(result.trajectory, summary), out / "drag_force.png")
    robot = "Tetraspine3" if structure is None else summary.get("model", structure.name)
    if result.cables:
        plot_cable_tensions(result.trajectory, out / "tensions.png",
                            title=f"{robot} drag test: measured tension (black), commanded "
                                  "(blue dashed)")
    figures = ["drag_force.png", "tensions.png"] if result.cables else ["drag_force.png"]
    return write_run(out, result, {**summary, "figures": figures}, structure=structure,
                     controller=controller)
