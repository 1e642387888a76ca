"""Sidewinding (paper Fig. 1, middle): the 12-segment Tetraspine moves sideways.

The gait is the shipped ``tetraspine_sidewind``: a travelling wave of pitch and yaw bending
(:class:`~tensim.control.wave.SpineWave`, eight numbers) learned with ``tensim learn --controller
wave --direction sideways`` (CMA-ES, 300 trials of 20 s on flat ground). As in a sidewinding
snake, each section of the spine is lifted while it swings one way and set down while it swings
back, so the robot travels across its own axis. :func:`transferred_cpg` carries a Tetraspine3
spine CPG (paper Fig. 5) onto the long spine instead, for comparison. The summary gives the
displacement in the world and in the robot's own frame (forward along its spine, sideways to its
left) and the turn.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tensim.control import ControllerConfig, SpineCPG, spine_parameters
from tensim.experiments.scenarios import (
    COMMAND_PERIOD,
    MODEL,
    resolve,
    run_scenario,
    write_scenario,
)
from tensim.model import WorldOptions
from tensim.models import load_controller, preset
from tensim.sim import SimulationResult
from tensim.terrain import Flat, Terrain

SIDEWIND_DURATION = 60.0  # s
SIDEWIND_GAIT = "tetraspine_sidewind"  # the shipped, learned sidewinding wave
SIDEWIND_TERRAIN = Flat()  # the robot's own friction, as in the hardware tests


def transferred_cpg(source: str, model: str = MODEL, *,
                    amplitude: float | None = None, frequency: float | None = None) -> SpineCPG:
    """The CPG of controller ``source`` with its parameter values on ``model``'s spine.

    Args:
        source: a controller file or shipped name whose gait is a spine CPG.
        model: the preset to put it on.
        amplitude: replaces the source's amplitude [m/s] (None keeps it).
        frequency: replaces the source's frequency [Hz] (None keeps it).

    Raises:
        ValueError: the source has no spine CPG, or its layout names other parameters.
    """
    short = load_controller(source)
    if not isinstance(short.gait, SpineCPG):
        raise ValueError(f"controller {source!r} has no spine CPG gait to transfer")
    src = short.gait.layout
    layout = spine_parameters(preset(model).build(), weight=src.weight, phase=src.phase,
                              amplitude=src.amplitude, frequency=src.frequency,
                              convergence=src.convergence)
    values = dict(zip(src.names, short.gait.values, strict=True))
    values.update({k: v for k, v in (("amplitude", amplitude), ("frequency", frequency))
                   if v is not None})
    missing = [n for n in layout.names if n not in values]
    if missing:
        raise ValueError(f"{model!r}'s CPG has parameters {missing[:3]}... that controller "
                         f"{source!r} does not set")
    return layout.gait([values[n] for n in layout.names])


def sidewind_controller(duration: float = SIDEWIND_DURATION) -> ControllerConfig:
    """The scenario's default controller: the shipped sidewinding wave for ``duration`` s."""
    return load_controller(SIDEWIND_GAIT).with_duration(duration)


def transferred_controller(source: str, duration: float = SIDEWIND_DURATION, *,
                           amplitude: float | None = None,
                           frequency: float | None = None) -> ControllerConfig:
    """The 12-segment preset's impedance laws under the spine CPG of ``source``
    (:func:`transferred_cpg`), for ``duration`` s."""
    impedance = preset(MODEL).controller()
    assert impedance is not None  # the Tetraspine presets have impedance laws
    gait = transferred_cpg(source, amplitude=amplitude, frequency=frequency)
    return ControllerConfig(impedance, gait, duration=duration, command_period=COMMAND_PERIOD,
                            model=MODEL, description=f"spine CPG of {source} on the {MODEL} "
                            "spine")


def sideways_share(summary: dict[str, Any]) -> float:
    """Fraction of the robot-frame displacement that is sideways (1: purely sideways)."""
    forward, side = summary.get("body_forward_m", 0.0), summary.get("body_sideways_m", 0.0)
    total = math.hypot(forward, side)
    return round(abs(side) / total, 4) if total > 0 else 0.0


def run_sidewind(*, terrain: Terrain | None = None,
                 controller: str | ControllerConfig | None = None,
                 duration: float | None = None, world: WorldOptions | None = None,
                 progress: Callable[[float, float], None] | None = None
                 ) -> tuple[SimulationResult, dict[str, Any], ControllerConfig, Terrain]:
    """Runs the sidewinding gait.

    Args:
        terrain: the ground (None: :data:`SIDEWIND_TERRAIN`).
        controller: controller file, shipped name or config (None: :func:`sidewind_controller`).
        duration: simulated time [s] (None: the controller's gait duration, 60 s by default).
        world: physics step and other world options (its terrain is replaced).
        progress: called as progress(done_s, total_s).

    Returns:
        The result, its summary, the controller and the terrain.
    """
    terrain = terrain or SIDEWIND_TERRAIN
    config = resolve(controller, sidewind_controller(), duration)
    result, summary = run_scenario("sidewind", config, terrain, world=world,
                                   progress=progress)
    summary["sideways_share"] = sideways_share(summary)
    return result, summary, config, terrain


def write_sidewind(out: Path, result: SimulationResult, summary: dict[str, Any],
                   config: ControllerConfig, terrain: Terrain) -> Path:
    """Writes the run folder (see :func:`~tensim.experiments.scenarios.write_scenario`)."""
    return write_scenario(out, result, summary, config, terrain)
