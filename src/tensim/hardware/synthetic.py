"""Simulated hardware logs: a run recorded the way the robot's PC logs it.

V* commands every ``command_period`` (10 ms on Tetraspine3), feedback (tension through a sensor
model, commanded tension, cable length, optional node positions) every ``feedback_period``
(200 ms). With perturbed parameters and a realistic sensor such a log is a stand-in for a
hardware one with known ground truth, for demos and for testing system identification.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from tensim.control import ControllerConfig, VelocityTable
from tensim.hardware.loads import EXPERIMENTS, format_params
from tensim.hardware.logs import AXES, HardwareLog
from tensim.hardware.parameters import apply_physical, apply_world
from tensim.hardware.replay import node_positions
from tensim.hardware.sensor import SensorModel
from tensim.model import CompiledModel, WorldOptions, compile_structure
from tensim.sim import TimeSeries, simulate
from tensim.structure import Structure


def simulated_log(structure: Structure, config: ControllerConfig, duration: float, *,
                  parameters: Mapping[str, float] | None = None,
                  sensor: SensorModel | None = None, rng: np.random.Generator | None = None,
                  command_period: float = 0.01, feedback_period: float = 0.2,
                  adc: bool = False, mocap_nodes: Sequence[str] = (),
                  world: WorldOptions | None = None,
                  experiment: tuple[str, Mapping[str, float]] | None = None,
                  progress: Callable[[float, float], None] | None = None) -> HardwareLog:
    """Simulates ``config`` on ``structure`` and logs it at the robot's rates.

    Args:
        structure: the nominal robot.
        config: impedance laws and gait (no gait: V* = 0, no V* columns).
        duration: logged time [s].
        parameters: named physical parameters (:mod:`tensim.hardware.parameters`) that the
            "hardware" has; ``vstar_scale`` scales the V* it plays relative to the logged one.
        sensor: how tensions are read (default: exact, no delay).
        rng: random generator for the sensor noise.
        command_period: time between V* rows [s].
        feedback_period: time between feedback rows [s], a whole number of command periods.
        adc: log raw ``adc/`` counts through ``sensor.loadcell`` instead of ``tension_N/``.
        mocap_nodes: nodes whose positions are logged (motion capture).
        world: world options.
        experiment: a built-in protocol (:data:`~tensim.hardware.loads.EXPERIMENTS`) and its
            parameters: its loads act on the "hardware", are logged as ``load_N/`` columns on
            every command row, and the header names it.
        progress: called as progress(done_s, total_s).

    Raises:
        ValueError: a feedback period that is not a whole number of command periods, or
            ``adc`` without a load cell.
    """
    parameters = dict(parameters or {})
    sensor = sensor or SensorModel()
    every = round(feedback_period / command_period)
    if every < 1 or abs(every * command_period - feedback_period) > 1e-9:
        raise ValueError(f"feedback_period {feedback_period} s must be a whole number of "
                         f"command periods ({command_period} s)")
    if adc and sensor.loadcell is None:
        raise ValueError("logging raw ADC counts needs a sensor with a load cell")
    compiled = compile_structure(apply_physical(structure, parameters),
                                 apply_world(world, parameters))
    times = np.arange(math.floor(duration / command_period + 1e-9) + 1) * command_period
    table = config.gait.velocity_table(duration, command_period) if config.gait else None
    played = config if table is None else config.with_gait(VelocityTable(
        table.cables, table.period, table.values * parameters.get("vstar_scale", 1.0)))
    loads = EXPERIMENTS[experiment[0]].loads(experiment[1]) if experiment else ()
    result = simulate(compiled, duration, controller=played.build(compiled.model.opt.timestep),
                      loads=loads, progress=progress)
    channels = _feedback(result.trajectory, compiled, times, every, sensor, rng, adc,
                         mocap_nodes)
    if table is not None:
        for k, cable in enumerate(table.cables):
            channels[f"vstar/{cable}"] = table.values[: times.size, k] + 0.0  # no -0.0
    for load in loads:
        for a, axis in enumerate(AXES):
            channels[f"load/{load.node}/{axis}"] = load.forces_at(times)[:, a] + 0.0
    meta = {"model": structure.name, "synthetic": "simulated by tensim",
            "parameters": ", ".join(f"{k}={v:g}" for k, v in parameters.items()) or "nominal",
            "sensor": ", ".join(f"{k}={v}" for k, v in sensor.to_dict().items()
                                if k != "loadcell"),
            "command_period_s": f"{command_period:g}", "feedback_period_s": f"{feedback_period:g}"}
    if adc and sensor.loadcell is not None:
        meta["loadcell"] = f"{sensor.loadcell.gain!r} * ADC + {sensor.loadcell.offset!r}"
    if experiment:
        meta["experiment"] = experiment[0]
        meta["experiment_params"] = format_params(experiment[1])
    order = sorted(channels, key=lambda n: n.split("/")[0] not in ("vstar", "load"))
    return HardwareLog(TimeSeries(times, {n: channels[n] for n in order}), "<simulated>", meta)


def _feedback(series: TimeSeries, compiled: CompiledModel, times: np.ndarray, every: int,
              sensor: SensorModel, rng: np.random.Generator | None, adc: bool,
              mocap_nodes: Sequence[str]) -> dict[str, np.ndarray]:
    """Feedback columns: values on every ``every``-th row, NaN elsewhere."""
    rows = np.zeros(times.size, dtype=bool)
    rows[::every] = True
    at = times[rows]
    cables = compiled.index.cables
    tension = sensor.measure(series.time, series.matrix("tension", cables), at, rng)
    exact = SensorModel(delay=sensor.delay)
    readings = {"adc" if adc else "tension": sensor.loadcell.to_counts(tension)
                if adc and sensor.loadcell is not None else tension,
                "setpoint": exact.expected(series.time, series.matrix("setpoint", cables), at),
                "length": exact.expected(series.time, series.matrix("length", cables), at)}
    channels: dict[str, np.ndarray] = {}
    for quantity, values in readings.items():
        for k, cable in enumerate(cables):
            column = np.full(times.size, np.nan)
            column[rows] = values[:, k]
            channels[f"{quantity}/{cable}"] = column
    for node, xyz in node_positions(series, compiled, mocap_nodes).items():
        for a, axis in enumerate("xyz"):
            column = np.full(times.size, np.nan)
            column[rows] = np.interp(at - sensor.delay, series.time, xyz[:, a])
            channels[f"mocap_{axis}/{node}"] = column
    return channels
