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

from tensim.control.rest import RestCommand
from tensim.control.rolling import RollSettings, support_edges
from tensim.model import CompiledModel, WorldOptions, compile_structure
from tensim.sim import COM, Simulation, Trial, TrialResult, run_batch
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
    commands = []
    for k in range(settings.search):
        if k == 0:
            command = np.asarray(first, dtype=float).copy()
        elif k % 2:  # each cable at an end of its travel or built
            pick = rng.integers(0, 3, size=len(built))
            command = np.choose(pick, [lower, built, upper])
        else:
            command = rng.uniform(lower, upper)
        commands.append(np.where(motorised, command, built))
    best: tuple[float, np.ndarray] | None = None
    for command, crossed in zip(commands, crossings(compiled, commands, motorised, line,
                                                    settings.period_s), strict=True):
        if crossed is not None and (best is None or crossed < best[0]):
            best = (crossed, command)
    return None if best is None else best[1]


def crossings(compiled: CompiledModel, commands: list[np.ndarray], motorised: np.ndarray,
              line: np.ndarray, period: float) -> list[float | None]:
    """For each constant rest-length command, when the centre of mass first crossed ``line``
    (a, b, c) [s]; None where it did not, was back behind it at the end of :data:`WINDOW_S`,
    or the try ran away.

    The tries run as one batch (:func:`~tensim.sim.run_batch`), each from the state a new
    :class:`~tensim.sim.Simulation` of ``compiled`` starts in (the motor update at t = 0 taken
    with the built rest lengths) and then commanded, and looked at every ``period``: bit for
    bit what one simulation per try, commanded after it is made, gives.
    """
    with Simulation(compiled) as sim:
        start = sim.get_state()
    cables = tuple(name for name, m in zip(compiled.index.cables, motorised, strict=True) if m)
    trials = [Trial(RestCommand(cables, tuple(float(v) for v in command[motorised])),
                    initial_state=start) for command in commands]
    return [_crossing(trial, line) for trial in run_batch(compiled, trials, WINDOW_S,
                                                          record_dt=period)]


def _crossing(trial: TrialResult, line: np.ndarray) -> float | None:
    """When a try's recorded centre of mass first crossed ``line``, if past it at the end."""
    if trial.result is None:
        return None
    series = trial.result.trajectory
    com = np.stack([series[f"pos_x/{COM}"], series[f"pos_y/{COM}"]], axis=1)[1:]
    past = [float(line[:2] @ c + line[2]) > 0 for c in com]
    if not past[-1]:
        return None
    return float(series.time[1:][past.index(True)])
