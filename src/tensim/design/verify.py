"""Simulating an inverse-statics answer: do the nodes settle where the statics says?

The standing robot's motors wind from its own rest lengths to the answer's
(:class:`tensim.design.inverse.RestCommand`) at a slow line speed, so the motion is nearly
quasi-static (a fast wind makes a tall robot rock and its feet slide), then the robot rests.
"""

from __future__ import annotations

import numpy as np

from tensim.design.inverse import InverseStatics
from tensim.hardware import node_positions
from tensim.model import compile_structure
from tensim.sim import simulate
from tensim.structure import Structure

WIND_SPEED = 0.01  # m/s: line speed of the motors while they wind to the answer
REST_TIME = 2.0  # s: simulated after the slowest motor arrives


def settle_time(result: InverseStatics, speed: float = WIND_SPEED) -> float:
    """Time [s] for the slowest motor to wind to the answer at ``speed`` [m/s] and rest
    :data:`REST_TIME`, to 0.1 s."""
    return round(float(np.abs(result.change).max()) / speed + REST_TIME, 1)


def settle_errors(structure: Structure, result: InverseStatics,
                  speed: float = WIND_SPEED) -> tuple[dict[str, float], float]:
    """Each free node's distance from the static answer after winding and resting [m], and
    the simulated time [s]."""
    compiled = compile_structure(structure)
    duration = settle_time(result, speed)
    run = simulate(compiled, duration, controller=result.command(speed))
    nodes = [n.name for n in structure.nodes if compiled.index.node_body.get(n.name, 0) != 0]
    settled = node_positions(run.trajectory, compiled, nodes)
    return ({n: float(np.linalg.norm(settled[n][-1] - result.target.position(n)))
             for n in nodes}, duration)
