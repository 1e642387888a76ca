"""Many trials of one robot in one call, on threads, each run to its end by one thread.

Every trial steps its own copy of the model: its controller writes the law's parameters
there and its commands into its ``ctrl``, its physics multipliers scale that copy's fields
(or it brings a compiled model of its own), and the stateless compiled law runs inside
MuJoCo's step. Without the compiled record loop, a trial is a row of MuJoCo state in a
:class:`mujoco.batch.Batch` (MuJoCo's batch engine).
A trial here is bit-identical to the same trial run alone with :class:`~tensim.sim.Simulation`,
at any thread count.

Threads never wait for each other: each thread takes the next job left when it finishes one
(work stealing), so a thread that the machine deschedules delays only its own job, where a
lock-step batch would hold every thread at each record's barrier. Where the compiled record
loop is built (the common case), a job is one trial run alone to its end, a single run on the
batch's thread (:mod:`tensim.sim._solo`: one model and one ``MjData`` stepped from start to
end, as ``mujoco.rollout`` steps each simulation); otherwise the trials are cut into chunks of
a few each, every chunk a one-thread ``Batch`` run to its end by the record loop.
"""

from __future__ import annotations

import copy
import itertools
import math
import threading
import time as _time
from collections.abc import Callable, Sequence
from typing import Protocol

import mujoco
import numpy as np
from mujoco import batch as mjbatch

from tensim.limits import MAX_STEPS, check_count
from tensim.model import BUILD_KEY, CompiledModel
from tensim.sim import _law
from tensim.sim._contact_check import ContactCheck
from tensim.sim._drive import InputPlan
from tensim.sim._loop import (
    RING_STEPS,
    Energy,
    EnergyHistory,
    ForceHistory,
    StabilityLimits,
    contact_problem,
    energy_message,
    next_step,
    prestress_band,
    record_loop,
    ring_message,
    sample_count,
    sample_time,
    stable,
    tunnel_message,
    watched,
    whole_steps,
)
from tensim.sim._samples import SampleBuffers
from tensim.sim._simulation import diagnose
from tensim.sim._solo import SoloTrial, solo_available
from tensim.sim._trials import (
    PhysicsScale,
    Trial,
    TrialResult,
    setup_trial,
    trial_models,
    trial_results,
)
from tensim.sim._warp_batch import run_batch_warp

__all__ = ["PhysicsScale", "Trial", "TrialResult", "run_batch", "setup_trial"]

MAX_SAMPLES = 50_000_000  # trials x samples x channels a batch may hold in memory
_BLOCK_STEPS = 2_000  # physics steps of inputs computed at once
_MAX_STEP_CALLS = 3  # runs of constant inputs in a record stepped one Batch.step call each
_CHUNKS_PER_THREAD = 2  # chunks of trials per thread: the last ones balance the threads
_MIN_CHUNK = 4  # trials a chunk holds at least (where each thread gets that many): a chunk's
# Python per record is shared by its trials (at 4 Tetraspine3 trials about 2 % of the CPU)
_RECORD = ("ten_length", "ten_velocity", "xpos", "xquat", "subtree_com", "act", "ctrl", "qvel",
           "actuator_force")


def run_batch(compiled: CompiledModel, trials: Sequence[Trial], duration: float, *,
              threads: int = 1, record_dt: float = 0.01,
              limits: StabilityLimits | None = None,
              progress: Callable[[float, float], None] | None = None,
              backend: str = "cpu", device: str | None = None,
              force: bool = False) -> list[TrialResult]:
    """Runs ``trials`` of ``compiled`` for ``duration`` seconds each, ``threads`` at a time.

    Each trial is recorded like :func:`~tensim.sim.simulate` (same channels, same
    ``TimeSeries``). A trial that fails (a controller error, NaN parameters, an unstable
    state) is reported with its diagnosis and the others go on.

    Args:
        compiled: the model all trials share.
        trials: the trials.
        duration: simulated time per trial [s].
        threads: worker threads (the calling thread counts as one).
        record_dt: recording period [s]; a whole number of physics steps.
        limits: the stability bounds.
        progress: called as progress(done_s, total_s) about every simulated second.
        backend: ``"cpu"`` (threads of this process, bit-identical to single runs) or
            ``"warp"`` (MuJoCo Warp, one world per trial, float32; ``tensim[gpu]``).
        device: the Warp device for ``backend="warp"`` (None: a GPU if there is one).
        force: run past :data:`tensim.limits.MAX_STEPS` physics steps (all trials together)
            and :data:`tensim.limits.MAX_SAMPLES` recorded values.

    Raises:
        ValueError: no trials, a bad duration, record_dt or backend, a batch too large to
            hold, or (``InputError``) more physics steps than the limit.
        ImportError: ``backend="warp"`` without MuJoCo Warp installed.
    """
    if not trials:
        raise ValueError("a batch needs at least one trial")
    if not (math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a finite number of seconds > 0, got {duration}")
    if threads < 1:
        raise ValueError(f"threads must be >= 1, got {threads}")
    if backend not in ("cpu", "warp"):
        raise ValueError(f"backend must be 'cpu' or 'warp', got {backend!r}")
    if all(c.motor.dc is None for c in compiled.structure.cables):
        for i, trial in enumerate(trials):
            dc_only = [f for f in ("motor_stall", "motor_inertia", "motor_friction")
                       if getattr(trial.physics, f) != 1.0]
            if dc_only:
                raise ValueError(f"trial {i}: physics {dc_only[0]} scales DC motors, and the "
                                 "robot has none: it would change nothing")
    nodes = tuple(dict.fromkeys(ld.node for t in trials for ld in t.loads))
    compiled = compiled.with_load_nodes(nodes)
    dt = float(compiled.model.opt.timestep)
    check_count(f"{len(trials)} trials of {duration:g} s at a physics step of {dt:g} s: "
                "physics steps", len(trials) * duration / dt, MAX_STEPS, force=force)
    record_steps = whole_steps(record_dt, dt, "record_dt")
    n_samples = sample_count(duration, record_steps, dt)
    size = len(trials) * (n_samples + 1) * (6 * compiled.n_cables + 7 * len(compiled.index.bodies))
    if size > MAX_SAMPLES and not force:
        raise ValueError(f"a batch of {len(trials)} trials x {n_samples + 1} samples would hold "
                         f"{size:.3g} recorded values (limit {MAX_SAMPLES:.0e}); run fewer "
                         "trials per batch or record less often (record_dt)")
    if backend == "warp":
        return run_batch_warp(compiled, trials, duration, record_steps=record_steps,
                              n_samples=n_samples, limits=limits or StabilityLimits(),
                              progress=progress, device=device)
    _law.install("compiled")
    limits = limits or StabilityLimits()
    runs: Sequence[_Job] = _solos(compiled, trials, record_dt, limits) if solo_available() \
        else _chunks(compiled, trials, threads, record_steps, limits, n_samples)
    started = _time.perf_counter()
    _run_stealing(runs, threads, duration, progress)
    wall = _time.perf_counter() - started
    return [r for run in runs for r in run.results(duration, wall * len(run.trials)
                                                   / len(trials))]


class _Job(Protocol):
    """Trials a thread runs to their end: a trial alone, or a chunk as a one-thread batch."""

    @property
    def trials(self) -> Sequence[Trial]:
        """The job's trials."""

    def run(self, duration: float, progress: Callable[[float, float], None]) -> None:
        """Runs the trials; ``progress`` hears their simulated time [s]."""

    def results(self, duration: float, wall: float) -> list[TrialResult]:
        """The trials' results, each given ``wall`` [s] as its wall time."""


def _solos(compiled: CompiledModel, trials: Sequence[Trial], record_dt: float,
           limits: StabilityLimits) -> list[SoloTrial]:
    """Every trial alone, to run in the compiled record loop (see :mod:`tensim.sim._solo`)."""
    compileds = trial_models(compiled, trials)
    return [SoloTrial(own, trial, i, record_dt, limits)
            for i, (own, trial) in enumerate(zip(compileds, trials, strict=True))]


def _chunks(compiled: CompiledModel, trials: Sequence[Trial], threads: int, record_steps: int,
            limits: StabilityLimits, n_samples: int) -> list[_BatchRun]:
    """The trials in chunks of consecutive ones, each set up as a one-thread batch (one chunk
    on one thread): where the compiled record loop is not available."""
    n = len(trials)
    size = n if threads == 1 else max(math.ceil(n / (threads * _CHUNKS_PER_THREAD)),
                                      min(_MIN_CHUNK, math.ceil(n / threads)))
    compileds = trial_models(compiled, trials)
    return [_BatchRun(compiled, trials[first:first + size], record_steps, limits,
                      compileds[first:first + size], n_samples, first)
            for first in range(0, len(trials), size)]


class _Abandoned(Exception):
    """A chunk stopped because another thread's failed or was interrupted."""


def _run_stealing(runs: Sequence[_Job], threads: int, duration: float,
                  progress: Callable[[float, float], None] | None) -> None:
    """Runs every job to its end on ``threads`` threads (the caller's among them), each
    thread taking the next job left; ``progress`` hears the trials' mean simulated time."""
    lock = threading.Lock()
    queue = iter(enumerate(runs))
    done = [0.0] * len(runs)
    total = sum(len(run.trials) for run in runs)
    failures: list[BaseException] = []

    def report(k: int, done_s: float) -> None:
        if failures:  # another thread failed or was interrupted (Ctrl-C): stop here too
            raise _Abandoned
        with lock:
            done[k] = done_s * len(runs[k].trials)
            mean = sum(done) / total
        if progress is not None:
            progress(mean, duration)

    def work() -> None:
        try:
            while not failures:
                with lock:
                    k, run = next(queue, (-1, None))
                if run is None:
                    return
                run.run(duration, lambda d, _t, k=k: report(k, d))  # type: ignore[misc]
        except _Abandoned:
            return
        except BaseException as exc:  # raised in the caller's thread below
            failures.append(exc)

    helpers = [threading.Thread(target=work, name=f"tensim-batch-{k}", daemon=True)
               for k in range(min(threads, len(runs)) - 1)]
    for helper in helpers:
        helper.start()
    work()
    for helper in helpers:
        helper.join()
    if failures:
        raise failures[0]


class _BatchRun:
    """The state of one :func:`run_batch` call."""

    def __init__(self, compiled: CompiledModel, trials: Sequence[Trial], record_steps: int,
                 limits: StabilityLimits, compileds: Sequence[CompiledModel], n_samples: int,
                 first: int = 0):
        self.compiled, self.trials, self.limits = compiled, trials, limits
        self.n_samples = n_samples
        self.record_steps, self.dt = record_steps, float(compiled.model.opt.timestep)
        self.first = first  # the batch's number of this chunk's first trial, for messages
        n, m = len(trials), compiled.model
        self.error: list[str | None] = [None] * n
        self.compileds = list(compileds)
        # each trial steps its own copy of its model: its controller's gains, its physics
        self.models = [copy.copy(c.model) for c in self.compileds]
        self.plans: list[InputPlan | None] = [self._setup(i, t) for i, t in enumerate(trials)]
        self.batch = mjbatch.Batch(m, n, nthread=1)
        try:
            self.batch.set_models(self.models)
        except ValueError as exc:
            raise ValueError(f"the trials' models differ in layout (sizes): {exc}") from None
        self.batch.reset(keyframe=m.key(BUILD_KEY).id, stage=mujoco.mjtStage.mjSTAGE_NONE)
        for i, trial in enumerate(trials):
            if self.error[i] is None and trial.initial_state is not None:
                self.batch.state[i] = trial.initial_state
        self.samples: SampleBuffers | None = None
        self.count = np.zeros(n, dtype=int)
        self._template = mujoco.MjData(m)
        self._contact = ContactCheck(compiled) \
            if any(c.contact for c in compiled.structure.cables) else None
        self._scratch = mujoco.MjData(m) if self._contact is not None else None
        # the cable forces of the last steps, for the ringing check
        self.forces = ForceHistory(n, prestress_band(compiled.structure))
        self.energy = Energy(compiled)
        allowance = max((self.energy.load_allowance(t.loads) for t in trials), default=0.0)
        self.energies = EnergyHistory(n, self.energy.scale + allowance)
        self._bound = {name: self.batch.bind(name) for name in _RECORD}  # refreshed per call
        self._out: dict[tuple[int, int], dict[str, np.ndarray]] = {}

    # -- set-up ------------------------------------------------------------------------------

    def _setup(self, i: int, trial: Trial) -> InputPlan | None:
        try:
            return setup_trial(self.compileds[i], self.models[i], trial, self.dt)
        except (ValueError, KeyError, TypeError) as exc:
            self.error[i] = f"trial {self.first + i}: {exc}"
            return None

    # -- stepping ----------------------------------------------------------------------------

    def _live(self) -> np.ndarray:
        return np.array([i for i, e in enumerate(self.error) if e is None], dtype=np.int32)

    def _start(self, n_samples: int) -> None:
        """The motor update at t = 0 for fresh trials; derived fields for restored ones."""
        self.samples = SampleBuffers.empty(self.compiled, n_samples + 1, (len(self.trials),))
        live = self._live()
        fresh = np.array([i for i in live if self.trials[i].initial_state is None],
                         dtype=np.int32)
        restored = np.setdiff1d(live, fresh).astype(np.int32)
        if fresh.size:
            self._rollout(fresh, 1)
        if restored.size:
            try:
                self.batch.forward(restored)
            except mjbatch.SimulationError as exc:
                self._fail(exc.ids)
        self._ids = self._live()
        self._fields = {name: field[self._ids] for name, field in self._bound.items()}

    def _plan(self, i: int) -> InputPlan:
        plan = self.plans[i]
        assert plan is not None
        return plan

    def run(self, duration: float, progress: Callable[[float, float], None] | None) -> None:
        self._start(self.n_samples)
        self.per_block = max(1, _BLOCK_STEPS // self.record_steps)
        record_loop(self, self.n_samples, self.record_steps, self.dt, duration, progress)

    # the back-end of record_loop: the live trials' fields after their latest record

    def advance(self, k: int, nstep: int) -> bool:
        live = self._live()
        if not live.size:
            return False
        if k % self.per_block == 0:  # the inputs of the next records, every trial at once
            self._block = _Block(self, min(self.per_block, self.n_samples - k) * nstep)
        self._ids, self._fields = self._block.advance(live, nstep,
                                                      watched(k, self.n_samples, nstep))
        return True

    def take(self) -> None:
        self._take(self._ids, self._fields)

    def check(self) -> None:
        self._check(self._ids, self._fields)

    def _rollout(self, live: np.ndarray, nstep: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Steps trials ``live`` by nstep with their inputs (see :class:`_Block`)."""
        return _Block(self, nstep).advance(live, nstep)

    def _buffers(self, n: int, nstep: int) -> dict[str, np.ndarray]:
        key = (n, nstep)
        if key not in self._out:
            d = self._template
            self._out = {key: {name: np.empty((n, nstep, *getattr(d, name).shape),
                                              getattr(d, name).dtype) for name in _RECORD}}
        return self._out[key]

    def _fail(self, ids: np.ndarray) -> None:
        for i in ids:
            self.error[int(i)] = f"trial {self.first + int(i)}: MuJoCo: " \
                f"{self.batch.error(int(i))}"

    def _take(self, ids: np.ndarray, fields: dict[str, np.ndarray]) -> None:
        assert self.samples is not None
        time = sample_time(self.batch.state[ids, 0], self.dt)
        if ids.size == len(self.trials) and (self.count == self.count[0]).all():
            # every trial, all at the same sample: plain slices, no fancy indexing
            self.samples.put(slice(None), int(self.count[0]), time, fields, self.compiled.index)
        else:
            self.samples.put(ids, self.count[ids], time, fields, self.compiled.index)
        self.count[ids] += 1

    def _check(self, ids: np.ndarray, fields: dict[str, np.ndarray]) -> None:
        n = self.compiled.n_cables
        bad_acc = self.batch.warning[ids, mujoco.mjtWarning.mjWARN_BADQACC, 1]
        fine = stable(fields["qvel"], fields["actuator_force"][:, :n], bad_acc, self.limits)
        fresh = self.forces.fresh  # the energy on the ringing check's schedule
        self._check_ringing(ids[fine])
        if fresh:
            self._check_energy(ids, fields, fine)
        for row in np.flatnonzero(~fine):
            i = int(ids[row])
            d = mujoco.MjData(self.compiled.model)
            d.qvel[:] = fields["qvel"][row]
            d.actuator_force[:] = fields["actuator_force"][row]
            warning = d.warning[mujoco.mjtWarning.mjWARN_BADQACC]  # names the body MuJoCo found
            warning.lastinfo, warning.number = self.batch.warning[
                i, mujoco.mjtWarning.mjWARN_BADQACC]
            time = float(self.samples.time[i, self.count[i] - 1]) if self.samples else 0.0
            self.error[i] = f"trial {self.first + i}: " + diagnose(
                self.compiled.model, d, self.compiled.index, self.limits, time,
                bool(bad_acc[row]))
        if self._contact is not None:
            still = np.array([self.error[int(i)] is None for i in ids[fine]], dtype=bool)
            self._check_contact(ids[fine][still])

    def _check_ringing(self, ids: np.ndarray) -> None:
        """Fails the trials with a cable that rings at the step frequency (see
        :func:`tensim.sim._loop.ringing`), as :meth:`Simulation.check` does."""
        ring = self.forces.ringing(ids)
        for row in np.flatnonzero(ring.any(axis=1)):
            i = int(ids[row])
            time = float(self.samples.time[i, self.count[i] - 1]) if self.samples else 0.0
            self.error[i] = f"trial {self.first + i}: " + ring_message(
                self.compiled.index.cables, ring[row], self.forces.force[i], time, self.dt)

    def _check_energy(self, ids: np.ndarray, fields: dict[str, np.ndarray],
                      fine: np.ndarray) -> None:
        """Fails the trials whose mechanical energy runs away (see
        :func:`tensim.sim._loop.energy_growing`), as :meth:`Simulation.check` does."""
        parts = [fields[name] for name in ("qvel", "xpos", "ten_length", "act")]
        growing = self.energies.push(ids, self.energy.total(*parts)) & fine
        for row in np.flatnonzero(growing):
            i = int(ids[row])
            if self.error[i] is not None:
                continue
            time = float(self.samples.time[i, self.count[i] - 1]) if self.samples else 0.0
            excess = self.energies.energy[i] - self.energies.lowest[i]
            what = self.energy.largest(*(part[row:row + 1] for part in parts))
            self.error[i] = f"trial {self.first + i}: " + energy_message(what, excess, time,
                                                                          self.dt,
                                                                          self.energy.remedy)

    def _check_contact(self, ids: np.ndarray) -> None:
        """Fails the trials whose contact cables went through an obstacle, as
        :meth:`Simulation.check` does: each trial's state is placed on a scratch copy of its
        model's data (its contacts and sites computed) and checked by the same
        :class:`ContactCheck`."""
        assert self._contact is not None and self._scratch is not None
        assert self.samples is not None
        for i in map(int, ids):
            problem = contact_problem(self._contact, self.models[i], self._scratch,
                                      self.batch.state[i])
            if problem is not None:
                time = float(self.samples.time[i, self.count[i] - 1])
                self.error[i] = f"trial {self.first + i}: " + tunnel_message(time, problem)

    # -- results -----------------------------------------------------------------------------

    def results(self, duration: float, wall: float) -> list[TrialResult]:
        assert self.samples is not None
        return trial_results(self.samples, self.count, self.models, self.error,
                             self.compiled.index.cable_peaks(self.batch.bind("act")),
                             self.compiled.index, self.dt, duration, wall)


class _Block:
    """The inputs of a block of steps for the live trials, stepped a record at a time.

    A record's runs of constant inputs (the common case: commands change on their own period)
    are one ``Batch.step`` call each; where the inputs change more often, ``Batch.rollout``
    sets each step's inputs. Trials MuJoCo raises on are marked failed (MuJoCo leaves them as
    they were and runs the others to the end).
    """

    def __init__(self, run: _BatchRun, nstep: int):
        self.run, self.ids, self.at = run, run._live(), 0
        steps = next_step(run.batch.state[self.ids, 0], run.dt)
        self.control = np.stack([run._plan(int(i)).control(int(s), nstep)
                                 for i, s in zip(self.ids, steps, strict=True)])
        self.change = (self.control[:, 1:] != self.control[:, :-1]).any(axis=(0, 2))

    def advance(self, live: np.ndarray, nstep: int, watch: bool = False
                ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Steps trials ``live`` (a subset of the block's) by nstep; returns the trials that
        ran and their fields after the last step. ``watch``: keep the cable forces of the last
        steps for the ringing check (the last two then stepped one call each)."""
        run, a, n = self.run, self.at, self.run.compiled.n_cables
        every = live.size == self.ids.size  # live is a subset of ids: then equal to them
        rows = self.control[:, a:a + nstep] if every else \
            self.control[np.searchsorted(self.ids, live), a:a + nstep]
        # every trial of the chunk: MuJoCo's "all" (None) and plain slices, not ids to check
        whole = live.size == len(run.trials)
        ids, at = (None, slice(None)) if whole else (live, live)
        self.at += nstep
        cuts = [0, *(np.flatnonzero(self.change[a:a + nstep - 1]) + 1).tolist(), nstep]
        last = max(0, nstep - RING_STEPS)  # the watched steps start here
        try:
            if len(cuts) > _MAX_STEP_CALLS + 1:  # inputs change often: set them step by step
                out = run._buffers(live.size, nstep)
                run.batch.rollout(nstep, rows, record=_RECORD, ids=ids, out=out)
                fields = {name: v[:, -1] for name, v in out.items()}
                for step in range(last, nstep) if watch else ():
                    run.forces.push(at, out["actuator_force"][:, step, :n])
            else:  # a few runs of constant inputs: one Batch.step each (Batch.rollout would
                # stop a trial whose warning counters rise, where a single run goes on)
                if watch:  # the forces after each of the last RING_STEPS steps
                    cuts = sorted({*cuts, *range(max(1, last + 1), nstep)})
                ctrl, force = run._bound["ctrl"], run._bound["actuator_force"]
                for start, stop in itertools.pairwise(cuts):
                    ctrl[at] = rows[:, start]  # a view of the state rows
                    run.batch.step(ids, stop - start)
                    if watch and stop > last:
                        run.forces.push(at, force[at, :n])
                # every trial of the chunk: the bound arrays themselves (read before the next
                # call refreshes them)
                fields = run._bound if whole else \
                    {name: field[live] for name, field in run._bound.items()}
        except mjbatch.SimulationError as exc:  # the only way a live trial fails here
            run._fail(exc.ids)
            fields = {name: field[live] for name, field in run._bound.items()}
            ran = np.array([run.error[int(i)] is None for i in live])
            return live[ran], {name: v[ran] for name, v in fields.items()}
        return live, fields


