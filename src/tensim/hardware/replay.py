"""Replaying a hardware log in simulation (the logged V*, or the controller's own gait), and
the world positions of nodes in a simulated run, to set beside motion capture."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from tensim.control import ControllerConfig, VelocityTable
from tensim.hardware.loads import loads_for
from tensim.hardware.logs import HardwareLog, check_items
from tensim.limits import check_run
from tensim.model import CompiledModel, WorldOptions, compile_structure
from tensim.sim import SimulationResult, TimeSeries, simulate
from tensim.structure import Structure


def replay_config(log: HardwareLog, config: ControllerConfig, *, vstar_scale: float = 1.0,
                  margin: float = 0.0) -> ControllerConfig:
    """The controller that replays ``log``: its V* table if it has one, else ``config``'s gait.

    Args:
        log: the hardware log.
        config: impedance laws (and the gait used when the log holds no V*).
        vstar_scale: factor on the logged V* (simulated = scale x logged).
        margin: extra time past the log's end to cover [s] (the last V* row is held).
    """
    table = log.velocity_table()
    duration = log.duration + margin
    if table is None:
        return config.with_duration(duration)
    scaled = VelocityTable(table.cables, table.period, table.values * vstar_scale)
    return config.with_gait(scaled).with_duration(duration)


def replay(log: HardwareLog, structure: Structure, config: ControllerConfig, *,
           world: WorldOptions | None = None, vstar_scale: float = 1.0, margin: float = 0.5,
           progress: Callable[[float, float], None] | None = None) -> SimulationResult:
    """Simulates the log's inputs on ``structure`` (simulation time 0 = the log's first row):
    its V* (or ``config``'s gait) and its external loads (columns or header experiment).

    Args:
        log: the hardware log.
        structure: the robot.
        config: impedance laws, and the gait used when the log holds no V*.
        world: world options.
        vstar_scale: factor on the logged V*.
        margin: simulated time past the log's end, so a delayed reading can be matched [s].
        progress: called as progress(done_s, total_s).

    Raises:
        LogError: a column names no cable or node of ``structure``.
    """
    check_items(log, structure)
    played = replay_config(log, config, vstar_scale=vstar_scale, margin=margin)
    compiled = compile_structure(structure, world)
    duration = log.duration + margin
    check_run(duration, compiled.model.opt.timestep)
    reported = [0.0]

    def report(done: float, total: float) -> None:
        reported[0] = done
        if progress is not None:
            progress(done, total)

    result = simulate(compiled, duration, controller=played.build(compiled.model.opt.timestep),
                      loads=loads_for(log, structure), progress=report)
    if progress is not None and reported[0] < duration:
        progress(duration, duration)  # the last partial second: finish the bar
    return result


def node_positions(series: TimeSeries, compiled: CompiledModel, nodes: Sequence[str]
                   ) -> dict[str, np.ndarray]:
    """World positions of nodes from a run's recorded body poses.

    Returns:
        node -> (T, 3) positions [m].

    Raises:
        KeyError: an unknown node, or one welded to the world.
    """
    body_name = dict(zip(compiled.index.body.tolist(), compiled.index.bodies, strict=True))
    out = {}
    for node in nodes:
        if node not in compiled.index.node_body or compiled.index.node_body[node] == 0:
            raise KeyError(f"no free node {node!r} in {compiled.structure.name!r}")
        body = body_name[compiled.index.node_body[node]]
        pos = np.stack([series[f"pos_{a}/{body}"] for a in "xyz"], axis=1)
        quat = np.stack([series[f"quat_{a}/{body}"] for a in "wxyz"], axis=1)
        rotation = Rotation.from_quat(quat, scalar_first=True)
        out[node] = pos + rotation.apply(compiled.index.node_local[node])
    return out
