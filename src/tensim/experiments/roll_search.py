"""Tips that statics cannot plan, searched in simulation.

A 3-bar lying on a side face tips over the far edge of that face only dynamically: the
statics plan flattens the prism before its centre of mass reaches the edge
(docs/rolling.md). :func:`search_tip` tries constant rest-length commands on the robot itself,
simulated from the face's canonical pose (:func:`tensim.control.roll_plans.face_down_pose`,
every cable at its built rest length, at rest), and keeps the one whose centre of mass
crosses the edge soonest and stays past it. The statics plan is the first try; the others
are drawn within the gait's travel (each motorised cable shortened, kept or paid out to the
travel's ends, or anywhere between). :class:`~tensim.control.roll_plans.PlanCache` asks for it
once per face and edge and shares the result through the robot's symmetry.
"""

from __future__ import annotations

import numpy as np

from tensim.control.rolling import RollSettings, support_edges
from tensim.model import WorldOptions, compile_structure
from tensim.sim import Simulation
from tensim.structure import Structure

WINDOW_S = 2.0  # s: a try must cross the edge within this and be past it at its end


def search_tip(pose: Structure, feet: tuple[str, ...], edge: tuple[str, str],
               first: np.ndarray, built: np.ndarray, settings: RollSettings,
               world: WorldOptions, seed: int = 0) -> np.ndarray | None:
    """The constant rest-length command that tips ``pose`` over ``edge`` soonest.

    Args:
        pose: the robot standing on ``feet`` (its canonical pose for that face) [m].
        feet: the support face's nodes.
        edge: the two feet the tip goes over.
        first: (n_cables,) the first command tried (the statics plan) [m].
        built: (n_cables,) the built rest lengths [m].
        settings: the travel (``shorten``, ``lengthen``), the number of tries (``search``)
            and the control period the crossing is looked at with.
        world: the physics (time step, cable law, contact).
        seed: seeds the drawn tries.

    Returns:
        (n_cables,) the command, or None where no try crossed the edge and stayed past it
        within :data:`WINDOW_S`.
    """
    positions = {n.name: np.asarray(n.position, dtype=float) for n in pose.nodes}
    polygon = np.array([positions[f][:2] for f in feet])
    line = next(e for e in support_edges(polygon)
                if sorted(feet[i] for i in np.argsort(np.abs(polygon @ e[:2] + e[2]))[:2])
                == sorted(edge))
    compiled = compile_structure(pose, world)
    motorised = np.array([not c.motor.passive for c in compiled.structure.cables])
    lower, upper = built * (1 - settings.shorten), built * (1 + settings.lengthen)
    rng = np.random.default_rng(seed)
    best: tuple[float, np.ndarray] | None = None
    for k in range(settings.search):
        if k == 0:
            command = np.asarray(first, dtype=float).copy()
        elif k % 2:  # each cable at an end of its travel or built
            pick = rng.integers(0, 3, size=len(built))
            command = np.choose(pick, [lower, built, upper])
        else:
            command = rng.uniform(lower, upper)
        command = np.where(motorised, command, built)
        crossed = _crossing(compiled, command, motorised, line, settings.period_s)
        if crossed is not None and (best is None or crossed < best[0]):
            best = (crossed, command)
    return None if best is None else best[1]


def _crossing(compiled: object, command: np.ndarray, motorised: np.ndarray, line: np.ndarray,
              period: float) -> float | None:
    """When the centre of mass first crossed ``line`` (a, b, c) under ``command`` [s]; None
    where it did not, or was back behind it at the end of :data:`WINDOW_S`."""
    when = None
    with Simulation(compiled) as sim:  # type: ignore[arg-type]
        sim.drive.rest_command[motorised] = command[motorised]
        while sim.time < WINDOW_S - 1e-9:
            sim.run(period)
            past = float(line[:2] @ sim.data.subtree_com[0][:2] + line[2]) > 0
            if when is None and past:
                when = sim.time
        return when if past else None
