"""The paper's steady-disturbance test (Fig. 3) on Tetraspine3.

A forward force on the front segment's tip ramps 0 -> 22.56 N (2.3 kg-force) over 30-35 s,
holds until 40 s and ramps back to 0 by 45 s; restoring forces of 0.45 and 0.55 of it act
backwards at the middle and rear tips, so the robot is held in place. The impedance
controllers run from t = 0 with the reference gains.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tensim.control import ControllerConfig
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


def disturbance_loads(peak: float = PEAK_FORCE) -> list[NodeLoad]:
    """The push on segment 0's tip and the restoring forces on the other tips."""
    push = ramp_hold_release(node_name(0, "tip"), (1.0, 0.0, 0.0), peak, START, RISE, HOLD, FALL)
    return [push] + [push.scaled(-share).at(node_name(seg, "tip"))
                     for seg, share in RESTORING_SHARE.items()]


def record_period(dt: float, target: float = 0.01) -> float:
    """A recording period near ``target`` that is a whole number of steps of ``dt`` [s]."""
    return dt * max(1, math.ceil(target / dt - 1e-9))


def run_disturbance(dt: float = 1e-3, duration: float = DURATION, backend: str = "auto",
                    progress: Callable[[float, float], None] | None = None,
                    world: WorldOptions | None = None, structure: Structure | None = None
                    ) -> tuple[SimulationResult, dict[str, Any]]:
    """Runs the test and returns the result and its summary.

    Args:
        structure: the robot (None: the ``tetraspine3`` preset); a variant of it, e.g. one
            fitted to hardware logs, must keep its node and cable names.
    """
    model = preset("tetraspine3")
    world = world or WorldOptions()
    compiled = compile_structure(structure or model.build(),
                                 dataclasses.replace(world, timestep=dt))
    result = simulate(compiled, duration, controller=model.controller(),
                      loads=disturbance_loads(), record_dt=record_period(dt), backend=backend,
                      progress=progress)
    return result, {**summarize(result), **world_record(compiled.world)}


def summarize(result: SimulationResult) -> dict[str, Any]:
    """Headline figures plus each cable's mean tension before and during the hold phase."""
    series = result.trajectory
    summary: dict[str, Any] = {"model": "tetraspine3", "experiment": "disturbance",
                               "controller": DEFAULT_CONTROLLER, **result.summary()}
    if series.time[-1] >= DURING[1]:
        before = series.between(*BEFORE).matrix("tension", result.cables).mean(axis=0)
        during = series.between(*DURING).matrix("tension", result.cables).mean(axis=0)
        summary["mean_tension_before_N"] = _named(result.cables, before)
        summary["mean_tension_hold_N"] = _named(result.cables, during)
        summary["tension_change_hold_N"] = _named(result.cables, during - before)
    summary["peak_force_N"] = PEAK_FORCE
    return summary


def _named(names: tuple[str, ...], values: np.ndarray) -> dict[str, float]:
    return {n: round(float(v), 4) for n, v in zip(names, values, strict=True)}


CABLE_PANELS = tuple(f"{kind}_{j}" for j in (1, 2) for kind in (
    "outer_top", "outer_left", "outer_right", "inner_top", "inner_left", "inner_right"))


def disturbance_figures() -> list[FigurePlan]:
    """The figures of a disturbance run folder (tensions, lengths, path), before it runs."""
    spans = (Span(START, START + RISE + HOLD + FALL, "force ramps / holds", 0.10),
             Span(*DURING, "hold (averaged)", 0.25),
             Span(*BEFORE, "before (averaged)", 0.12, "tab:green"))
    return [FigurePlan("tensions.png", "tensions", {
                "cables": CABLE_PANELS, "columns": 3, "spans": spans,
                "title": "Tetraspine3 disturbance test: measured tension (black), commanded "
                         "(blue dashed);\norange: external force on, darker while held "
                         f"({DURING[0]:g}-{DURING[1]:g} s); green: the window before"}),
            FigurePlan("lengths.png", "lengths", {
                "cables": CABLE_PANELS, "columns": 3,
                "title": "Tetraspine3 disturbance test: cable length and motor rest length"}),
            FigurePlan("path.png", "path")]


def write_disturbance(out: Path, result: SimulationResult, summary: dict[str, Any],
                      structure: Structure | None = None,
                      drawer: FigureDrawer | None = None) -> Path:
    """Writes the run folder: trajectory, tension and length figures, the robot (``structure``,
    None: the preset) and its controller, summary.

    ``drawer``: a drawer of :func:`disturbance_figures` opened before the run (it may have
    laid them out meanwhile); None: drawn here.
    """
    drawer = drawer or FigureDrawer(disturbance_figures())
    for plan in drawer.plans.values():
        drawer.draw(plan.file, result.trajectory, out)
    summary = {**summary, "figures": ["tensions.png", "lengths.png"]}
    impedance = preset("tetraspine3").controller()
    config = ControllerConfig(impedance, model="tetraspine3") if impedance else None
    return write_run(out, result, summary, structure=structure, controller=config,
                     drawer=drawer)
