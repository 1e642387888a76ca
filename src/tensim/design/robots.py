"""Motor duty over a gait on K randomised robots, run as one batch.

Real robots differ from their model: each of the K trials scales the cables' stiffness and
damping, the bodies' masses and the ground friction by factors drawn uniformly from
[1 - spread, 1 + spread] (``tensim.sim.PhysicsScale``, seeded), and runs the same controller
through :func:`tensim.sim.run_batch`. The motors are then sized for the worst trial of each
cable (:func:`tensim.design.motors.merge`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from tensim.design._errors import DesignError
from tensim.design.motors import CableDuty, cable_duty, merge, tracked_peaks
from tensim.model import CompiledModel
from tensim.sim import Controller, PhysicsScale, Trial, run_batch


def random_scales(robots: int, spread: float, seed: int) -> list[PhysicsScale]:
    """``robots`` physics scales, each factor uniform in [1 - spread, 1 + spread]."""
    if robots < 1 or not 0 <= spread < 1:
        raise DesignError(f"need robots >= 1 and 0 <= spread < 1, got {robots} and {spread}")
    rng = np.random.default_rng(seed)
    draw = rng.uniform(1 - spread, 1 + spread, size=(robots, 4))
    return [PhysicsScale(friction=f, stiffness=k, damping=b, mass=m) for k, b, m, f in draw]


def gait_duties(compiled: CompiledModel, controller: Callable[[], Controller | None],
                duration: float, scales: list[PhysicsScale],
                limits: dict[str, tuple[float, float]] | None = None, threads: int = 1,
                progress: Callable[[float, float], None] | None = None
                ) -> tuple[list[CableDuty], int]:
    """Each cable's worst duty over the trials, and how many trials finished.

    Args:
        compiled: the robot.
        controller: makes a fresh controller for each trial.
        duration: simulated time per trial [s].
        scales: one physics scale per trial.
        limits: cable -> (max_speed [m/s], max_tension [N]), for the time at limit.
        threads: worker threads.
        progress: called as progress(done_s, total_s) while the batch runs.

    Raises:
        DesignError: every trial failed.
    """
    trials = [Trial(controller=controller(), physics=scale) for scale in scales]
    done = [r.result for r in run_batch(compiled, trials, duration, threads=threads,
                                                progress=progress)
            if r.result is not None]
    if not done:
        raise DesignError("every randomised robot's run failed; check the gait with "
                          "`tensim simulate` first")
    return merge([cable_duty(run.trajectory, limits, tracked_peaks(run)) for run in done]), \
        len(done)
