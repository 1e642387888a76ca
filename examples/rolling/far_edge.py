"""The `three_bar` preset's far side edge: one tip planned with the feet held, and on sliding feet.

Lying on a side face, the 3-bar rolls toward -30 degrees over the far side edge of that face
(docs/rolling.md). The statics gait plans the tip with the feet held where they stand
(friction takes any sideways force); ``RollSettings(sliding=True)`` plans it with the feet on
frictionless ground (held only in height): the robot's motors pull with up to 2 kN, its feet
carry about 40 N each. For each, this script prints the plan's static centre of mass against
the far edge (how far short of it, how high up, and the work to tip the rigid robot over the
edge from there, M g (sqrt(d^2 + h^2) - h)), then commands the plan's rest lengths from the
build pose and prints where the simulated robot lies 2 s later.

Usage: python examples/rolling/far_edge.py
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from tensim.control.rolling import PRISM_SETTINGS, heading_vector, plan_tip, support_face
from tensim.design._bodies import GRAVITY
from tensim.experiments.roll import node_positions
from tensim.model import WorldOptions, compile_structure
from tensim.models import load_model
from tensim.sim import Simulation

HEADING = -30.0  # deg: across the preset's long axis, over the far edge of its build face
STEPS = 30  # statics steps of the plan (finer than the gait's 12)
WAIT_S = 2.0


def main() -> None:
    compiled = compile_structure(load_model("three_bar"), WorldOptions())
    robot, built = compiled.structure, compiled.rest_length.copy()
    mass = float(compiled.model.body_subtreemass[0])
    motorised = np.array([not c.motor.passive for c in robot.cables])
    for label, sliding in (("feet held", False), ("feet sliding", True)):
        settings = dataclasses.replace(PRISM_SETTINGS, steps=STEPS, sliding=sliding)
        plan = plan_tip(robot, built, built, heading_vector(HEADING), settings)
        height = plan.height
        short = max(0.0, -plan.margin)
        work = mass * GRAVITY * (math.hypot(short, height) - height)
        with Simulation(compiled) as sim:
            sim.drive.rest_command[motorised] = plan.rest_lengths[motorised]
            sim.run(WAIT_S)
            face = support_face(node_positions(sim))
            up = float(sim.data.subtree_com[0][2])
        print(f"{label}: static centre of mass {short:.3f} m short of the far edge, "
              f"{height:.3f} m up, {work:.2f} J to tip; after {WAIT_S:g} s the robot lies "
              f"on {' '.join(face)}, centre of mass {up:.2f} m up")


if __name__ == "__main__":
    main()
