"""A batch's trial run to its end alone: the single-run path (:class:`Simulation` and its
compiled record loop) on a batch thread.

Where the compiled record loop runs, :func:`tensim.sim.run_batch` hands each thread whole
trials: a trial steps one model and one ``MjData`` from start to end inside the compiled
loop, which releases the GIL, as ``mujoco.rollout`` steps each of its simulations, so its
working set stays in the core's caches. (Stepping many trials a record at a time in turn
reloads each one's model and data every record; on a loaded machine, whose other programs
evict them between turns, that cost a tenth of the rate.) A trial is then a single run by
construction, bit for bit.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable

import mujoco

from tensim.model import CompiledModel
from tensim.sim import _law, _record_native
from tensim.sim._loop import StabilityLimits
from tensim.sim._simulation import Simulation, SimulationError, SimulationResult
from tensim.sim._trials import PhysicsScale, Trial, TrialResult, check_law, check_state, scale


def solo_available() -> bool:
    """Whether a batch's trials can run alone in the compiled record loop (see
    :func:`tensim.sim._record_native.usable_backend`); installs the compiled cable law, which
    that loop checks MuJoCo runs."""
    if not _law.compiled_available():
        return False
    _law.install("compiled")
    return _record_native.usable_backend("compiled")


class SoloTrial:
    """One trial of a batch, run alone to its end by :meth:`run`.

    Args:
        compiled: the trial's model (with the batch's load inputs).
        trial: the trial.
        number: its place in the batch, for messages.
        record_dt: recording period [s].
        limits: the stability bounds.
    """

    def __init__(self, compiled: CompiledModel, trial: Trial, number: int, record_dt: float,
                 limits: StabilityLimits):
        self.compiled, self.trial, self.number = compiled, trial, number
        self.trials = (trial,)  # what the batch's progress counts
        self.record_dt, self.limits = record_dt, limits
        self.result: TrialResult | None = None

    def _simulation(self) -> Simulation:
        """The trial's simulation: its physics multipliers on a copy of its model, its
        controller's gains, its initial state."""
        compiled, trial = self.compiled, self.trial
        if trial.physics != PhysicsScale():
            model = copy.copy(compiled.model)
            scale(compiled, model, trial.physics)
            compiled = dataclasses.replace(compiled, model=model)
        sim = Simulation(compiled, controller=trial.controller, loads=trial.loads,
                         record_dt=self.record_dt, backend="compiled", limits=self.limits)
        check_law(compiled, sim.model)
        if trial.initial_state is not None:
            check_state(sim.model, trial.initial_state)
            sim.set_state(trial.initial_state)
        return sim

    def run(self, duration: float, progress: Callable[[float, float], None]) -> None:
        """Runs the trial for ``duration`` [s] into :attr:`result` (a failure as its error);
        ``progress`` hears its simulated time about every second (and may raise to stop)."""
        try:
            with self._simulation() as sim:
                trajectory = sim.run(duration, progress)
                drive = sim.drive
                self.result = TrialResult(SimulationResult(
                    trajectory, drive.peak.copy(), 0.0, duration, sim.dt, sim.index.cables,
                    drive.peak_speed.copy(), drive.peak_power.copy()))
        except (ValueError, KeyError, TypeError, SimulationError) as exc:
            self.result = TrialResult(None, f"trial {self.number}: {exc}")
        except mujoco.FatalError as exc:
            self.result = TrialResult(None, f"trial {self.number}: MuJoCo: {exc}")

    def results(self, duration: float, wall: float) -> list[TrialResult]:
        """The trial's result, its ``wall_s`` its share of the batch's ``wall`` time [s]."""
        assert self.result is not None, "the trial has not run"
        run = self.result.result
        if run is None:
            return [self.result]
        return [TrialResult(dataclasses.replace(run, wall_s=wall))]


__all__ = ["SoloTrial", "solo_available"]
