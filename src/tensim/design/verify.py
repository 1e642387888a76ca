"""Simulating an inverse-statics answer: do the nodes settle where the statics says?

The standing robot's motors wind from its own rest lengths to the answer's
(:class:`tensim.design.inverse.RestCommand`) at a slow line speed, so the motion is nearly
quasi-static (a fast wind makes a tall robot rock and its feet slide), then the robot rests.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from tensim.design.inverse import InverseStatics
from tensim.hardware import node_positions
from tensim.model import compile_structure
from tensim.sim import simulate
from tensim.structure import Structure

WIND_SPEED = 0.01  # m/s: line speed of the motors while they wind to the answer
REST_TIME = 2.0  # s: simulated after the slowest motor arrives


def settle_errors(structure: Structure, result: InverseStatics,
                  speed: float = WIND_SPEED) -> tuple[dict[str, float], float]:
    """Each free node's distance from the static answer after winding and resting [m], and
    the simulated time [s]."""
    slow = dataclasses.replace(structure, cables=tuple(
        dataclasses.replace(c, motor=dataclasses.replace(
            c.motor, max_speed=min(c.motor.max_speed, speed))) for c in structure.cables))
    compiled = compile_structure(slow)
    duration = round(float(np.abs(result.change).max()) / speed + REST_TIME, 1)
    run = simulate(compiled, duration, controller=result.command())
    nodes = [n.name for n in structure.nodes if compiled.index.node_body.get(n.name, 0) != 0]
    settled = node_positions(run.trajectory, compiled, nodes)
    return ({n: float(np.linalg.norm(settled[n][-1] - result.target.position(n)))
             for n in nodes}, duration)
