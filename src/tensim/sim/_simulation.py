"""One robot simulated: fixed-step MuJoCo with cables, on the loop of :mod:`tensim.sim._loop`."""

from __future__ import annotations

import copy
import dataclasses
import math
import time as _time
import weakref
from collections.abc import Callable, Sequence
from typing import Protocol

import mujoco
import numpy as np

from tensim.model import BUILD_KEY, CompiledModel, ModelIndex
from tensim.sim import _record_native
from tensim.sim._contact_check import ContactCheck
from tensim.sim._drive import CableDrive, InputPlan, changes
from tensim.sim._law import install, release, use_reference_law
from tensim.sim._loads import NodeLoad
from tensim.sim._loop import (
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
    split_steps,
    stable,
    tunnel_message,
    watched,
    whole_steps,
)
from tensim.sim._samples import COM, SampleRows, sample_channels
from tensim.sim._timeseries import TimeSeries

_BLOCK_STEPS = 20_000  # physics steps of inputs computed at once, at most
# ctrl values computed at once, at most (16 MB): 20,000 steps of a 796-cable robot's inputs
# were 127 MB, and writing them cost more than stepping in shorter blocks
_BLOCK_VALUES = 2_000_000


def _block_steps(nu: int) -> int:
    """Physics steps of inputs computed at once for ``nu`` inputs (any split of the steps
    gives the same run: the block's runs of equal rows end at its edge)."""
    return max(1, min(_BLOCK_STEPS, _BLOCK_VALUES // max(nu, 1)))


class SimulationError(RuntimeError):
    """The simulation became unstable (non-finite state or runaway energy)."""


class CableSetup(Protocol):
    """What a controller configures: a Simulation, or one trial of a batch."""

    @property
    def compiled(self) -> CompiledModel:
        """The compiled model."""

    @property
    def drive(self) -> CableDrive:
        """The law's parameters and commands."""

    @property
    def dt(self) -> float:
        """The physics step [s]."""

    @property
    def index(self) -> ModelIndex:
        """Names and ids."""


class Controller(Protocol):
    """Anything that sets up a simulation's cable drive (gains, targets, V* table)."""

    def configure(self, sim: CableSetup) -> None:
        """Writes this controller's commands into ``sim.drive``."""


class Simulation:
    """One robot simulated at a fixed step, with its cables, motors and controller.

    All dynamic state is MuJoCo's: rest lengths and peak tensions are actuator activations, the
    cable commands and node loads are ``ctrl`` inputs, and the law's parameters live in this
    simulation's own copy of the model (``sim.model``), so ``mj_getState`` with
    ``mjSTATE_INTEGRATION`` (see :meth:`get_state`) captures a run completely.

    Time: a sample at ``sim.time`` = t holds the kinematics at t and the rest lengths the motors
    set at t; ``sim.data`` is one physics step ahead (its time is t + dt). Construction takes
    that first step, the motor update at t = 0.

    Args:
        compiled: the compiled model (recompiled with force inputs if ``loads`` need them).
        loads: external node forces.
        controller: sets up the cable drive before the first step; None keeps every rest
            length where it is.
        record_dt: recording period [s]; a whole number of physics steps.
        backend: the cable law, ``"auto"``, ``"compiled"`` or ``"python"`` (the reference,
            slow). The choice is this simulation's alone: other live simulations keep theirs.
        limits: the stability bounds.
    """

    def __init__(self, compiled: CompiledModel, *, controller: Controller | None = None,
                 loads: Sequence[NodeLoad] = (), record_dt: float = 0.01, backend: str = "auto",
                 limits: StabilityLimits | None = None):
        self.backend = install(backend)
        compiled = compiled.with_load_nodes(tuple(ld.node for ld in loads))
        self.compiled = compiled
        self.model = copy.copy(compiled.model)  # the controller writes its gains here
        self.data = mujoco.MjData(self.model)
        if self.backend == "python":  # this model only: its marker selects the law's body
            use_reference_law(self.model, self.data)
            weakref.finalize(self, release, self.data)
        mujoco.mj_resetDataKeyframe(self.model, self.data, self.model.key(BUILD_KEY).id)
        self.index = compiled.index
        self.dt = float(self.model.opt.timestep)
        self.record_steps = whole_steps(record_dt, self.dt, "record_dt")
        self.limits = limits or StabilityLimits()
        self.drive = CableDrive(compiled, self.model, data=self.data)
        self._loads = tuple(loads)
        self._qvel, self._ctrl = self.data.qvel, self.data.ctrl  # views, looked up once
        self._cable_force = self.data.actuator_force[:compiled.n_cables]
        d = self.data
        self._energy_fields = (d.qvel[None], d.xpos[None], d.ten_length[None], d.act[None])
        self._bad_acc = self.data.warning[mujoco.mjtWarning.mjWARN_BADQACC]
        self._contact = ContactCheck(compiled) \
            if any(c.contact for c in compiled.structure.cables) else None
        # the cable forces of the last steps, for the ringing check
        self._forces = ForceHistory(1, prestress_band(compiled.structure))
        self._energy = Energy(compiled)  # and the energy at each check, for its growth
        self._energies = EnergyHistory(1, self._energy.scale
                                       + self._energy.load_allowance(self._loads))
        self._native: _record_native.NativeRecords | None = None
        self._native_made = False
        if controller is not None:
            controller.configure(self)
        self._advance(1)  # the motor update at t = 0

    # -- lifecycle ---------------------------------------------------------------------------

    def close(self) -> None:
        """Releases the reference law's hold on this simulation's data (``backend="python"``);
        the compiled law needs nothing released."""
        if self.backend == "python":
            release(self.data)

    def __enter__(self) -> Simulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def time(self) -> float:
        """Time of the latest motor update (the state the outputs describe) [s]."""
        return (self._next_step() - 1) * self.dt

    def _next_step(self) -> int:
        return next_step(self.data.time, self.dt)

    def get_state(self) -> np.ndarray:
        """The complete simulation state (``mjSTATE_INTEGRATION``): restore with set_state."""
        spec = mujoco.mjtState.mjSTATE_INTEGRATION
        state = np.empty(mujoco.mj_stateSize(self.model, spec))
        mujoco.mj_getState(self.model, self.data, state, spec)
        return state

    def set_state(self, state: np.ndarray) -> None:
        """Restores a state from :meth:`get_state`; continuing is bit-identical to never
        having stopped."""
        spec = mujoco.mjtState.mjSTATE_INTEGRATION
        state = np.asarray(state, dtype=float)
        if state.shape != (mujoco.mj_stateSize(self.model, spec),):
            raise ValueError(f"state must have {mujoco.mj_stateSize(self.model, spec)} values "
                             f"(mjSTATE_INTEGRATION of this model), got {state.shape}")
        mujoco.mj_setState(self.model, self.data, state, spec)
        mujoco.mj_forward(self.model, self.data)  # derived fields; the state is unchanged
        self._forces.count[:] = 0  # the kept forces were another state's
        self._energies.reset(slice(None))

    def inputs(self) -> InputPlan:
        """The ``ctrl`` rows of this simulation's commands and loads (read when called)."""
        return InputPlan(self.drive, self._loads, self.compiled)

    # -- stepping ----------------------------------------------------------------------------

    def step(self, nstep: int = 1) -> None:
        """Advances ``nstep`` physics steps inside MuJoCo, then checks stability.

        Raises:
            SimulationError: the state is non-finite, running away or ringing.
        """
        if nstep > 0:
            for count, push in split_steps(nstep):
                self._advance(count)
                if push:
                    self.push_forces()
            self.check()

    def _advance(self, nstep: int) -> None:
        plan = self.inputs()
        block = _block_steps(plan.nu)
        for first in range(0, nstep, block):
            count = min(block, nstep - first)
            _Segments(plan.control(self._next_step(), count)).run(self, 0, count)

    def _native_records(self) -> _record_native.NativeRecords | None:
        """The compiled record loop of this simulation's runs, made at the first (None where
        runs record in Python, see :func:`~tensim.sim._record_native.usable`)."""
        if not self._native_made:
            self._native = _record_native.NativeRecords(self) \
                if _record_native.usable(self) else None
            self._native_made = True
        return self._native

    def push_forces(self) -> None:
        """Keeps the cable forces of the step just taken for the ringing check."""
        self._forces.push(slice(0, 1), self._cable_force)

    def run(self, duration: float, progress: Callable[[float, float], None] | None = None,
            on_record: Callable[[Simulation], None] | None = None) -> TimeSeries:
        """Simulates ``duration`` seconds more, recording every ``record_dt``.

        The cable commands and loads are read when the run starts.

        Args:
            duration: simulated time [s].
            progress: called as progress(done_s, total_s) about every simulated second.
            on_record: called with this simulation after each sample (every ``record_dt``),
                e.g. to log extra signals or to set ``data.xfrc_applied`` in between.

        Returns:
            The recorded samples, the current state included as the first one.
        """
        n_samples = sample_count(duration, self.record_steps, self.dt)
        run = _SingleRun(self, n_samples)
        record_loop(run, n_samples, self.record_steps, self.dt, duration, progress,
                    None if on_record is None else lambda: on_record(self))
        return run.recorder.series()

    # -- checks ------------------------------------------------------------------------------

    def check(self) -> None:
        """Raises :class:`SimulationError` naming the body or cable if the state ran away or a
        cable rings at the step frequency."""
        bad_acc = self._bad_acc.number
        if stable(self._qvel, self._cable_force,
                  np.array(bad_acc), self.limits):
            # MuJoCo's reset clears the activations: keep the peak tensions for the message
            self._peak_seen = (self.time, self.drive.peak.copy())
            ring = self._forces.ringing(slice(0, 1))[0] if self._forces.fresh else None
            if ring is not None and ring.any():
                raise SimulationError(ring_message(self.index.cables, ring,
                                                   self._forces.force[0], self.time, self.dt))
            if ring is not None:  # the energy on the same schedule: every RING_EVERY checks
                self._check_energy()
            problem = contact_problem(self._contact, self.model, self.data) \
                if self._contact else None
            if problem is None:
                return
            raise SimulationError(tunnel_message(self.time, problem))
        raise SimulationError(diagnose(self.model, self.data, self.index, self.limits,
                                       self.time, bool(bad_acc),
                                       getattr(self, "_peak_seen", None)))


    def _check_energy(self, fields: tuple[np.ndarray, ...] | None = None,
                      time: float | None = None) -> None:
        """Raises :class:`SimulationError` where the mechanical energy grows geometrically
        (:func:`~tensim.sim._loop.energy_growing`), naming what holds most of it.

        Args:
            fields: qvel, xpos, ten_length and act, (1, ...), of a state the compiled record
                loop kept at the time [s] ``time`` (default: the data's now).
        """
        fields = fields or self._energy_fields
        if self._energies.push(slice(None), self._energy.total(*fields))[0]:
            excess = self._energies.energy[0] - self._energies.lowest[0]
            raise SimulationError(energy_message(self._energy.largest(*fields), excess,
                                                 self.time if time is None else time, self.dt,
                                                 self._energy.remedy))


def diagnose(m: mujoco.MjModel, d: mujoco.MjData, index: ModelIndex, limits: StabilityLimits,
             time: float, bad_acc: bool,
             peak_seen: tuple[float, np.ndarray] | None = None, reset: bool = True) -> str:
    """The message for an unstable state: the fastest body, the most loaded cable, what to try.

    After MuJoCo's bad-acceleration reset the state is the reset one: the body is then the one
    of the degree of freedom MuJoCo found (its warning keeps it), and ``peak_seen`` (time [s],
    (n_cables,) peak tensions [N] at the last check before) gives the cable tensions. An
    engine that does not reset (MuJoCo Warp: ``reset=False``) keeps the state it reached.
    """
    qvel = np.nan_to_num(np.abs(d.qvel), nan=np.inf)
    body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.dof_bodyid[np.argmax(qvel)])) \
        if m.nv else "-"
    applied = np.nan_to_num(-d.actuator_force[:len(index.cables)], nan=np.inf)
    load, when = "the most loaded cable is", f"at t = {time:.3f} s"
    warning = d.warning[mujoco.mjtWarning.mjWARN_BADQACC]
    if bad_acc:
        what = "MuJoCo found a non-finite acceleration" + (" and reset the state" if reset
                                                           else "")
        if warning.number and 0 <= warning.lastinfo < m.nv:
            dof_body = int(m.dof_bodyid[warning.lastinfo])
            what = (f"MuJoCo found a non-finite acceleration of body "
                    f"{mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, dof_body)!r} and reset "
                    "the state")
        if peak_seen is not None:  # the reset also reset the clock
            applied = np.nan_to_num(peak_seen[1], nan=np.inf)
            when = f"after t = {peak_seen[0]:.3f} s"
            load = "before it the most loaded cable had reached"
    else:
        what = f"body {body!r} reached speed {qvel.max():.3g} " \
               f"(limit {limits.max_speed:g} m/s or rad/s)"
    cable = index.cables[int(np.argmax(applied))] if applied.size else "-"
    advice = "Try a smaller timestep (--dt), lower cable stiffness or pretension, or more " \
        "cable damping."
    bead = next((k for k, b in enumerate(index.beads) if repr(b) in what), None)
    if bead is not None:  # too light for the step: see tensim.model._beads
        body = index.bead[bead]
        inertia = m.body_mass[body] + m.dof_armature[m.body_dofadr[body]]
        advice = (f"{index.beads[bead]!r} is a contact cable's bead ({inertia * 1e3:.3g} g of "
                  "inertia): take a smaller timestep (--dt), or give its cable beads of more "
                  "mass than that (contact: mass).")
    return (f"simulation unstable {when}: {what}; {load} {cable!r} at "
            f"{applied.max(initial=0.0):.4g} N. {advice}")


class _Segments:
    """Steps through a block of ``ctrl`` rows, one ``mj_step`` call per run of equal rows."""

    def __init__(self, control: np.ndarray):
        self.control = control
        self.cuts = [*changes(control).tolist(), control.shape[0]]
        self.cut_array = np.array(self.cuts, dtype=np.int64)  # for the compiled loop
        self._i = 0

    def run(self, sim: Simulation, start: int, stop: int) -> None:
        """Takes steps start .. stop - 1 of the block (in order, without gaps)."""
        m, d, cuts, ctrl = sim.model, sim.data, self.cuts, sim._ctrl
        while start < stop:
            while cuts[self._i] <= start:
                self._i += 1
            end = min(cuts[self._i], stop)
            ctrl[:] = self.control[start]
            mujoco.mj_step(m, d, nstep=end - start)
            start = end


class _SingleRun:
    """The back-end of one :meth:`Simulation.run` for :func:`record_loop`: blocks of inputs
    stepped in runs of equal rows, samples into a :class:`_Recorder`."""

    def __init__(self, sim: Simulation, n_samples: int):
        self.sim, self.n_samples = sim, n_samples
        self.recorder = _Recorder(sim, n_samples + 1)
        self.plan = sim.inputs()
        self.per_block = max(1, _block_steps(self.plan.nu) // sim.record_steps)
        self.segments, self.done = _Segments(np.zeros((0, 0))), 0
        self.native = sim._native_records()
        if self.native is not None:
            self.native.begin(self.recorder.rows, n_samples, sim.limits)

    def _block(self, k: int, nstep: int) -> None:
        if k % self.per_block == 0:  # the inputs of the next records
            count = min(self.per_block, self.n_samples - k) * nstep
            self.segments = _Segments(self.plan.control(self.sim._next_step(), count))
            self.done = 0

    def records(self, k: int, stop: int) -> tuple[int, bool]:
        """Records k .. stop - 1 (to the end of their block of inputs at most) in the
        compiled loop (:mod:`tensim.sim._record_native`); none without it."""
        if self.native is None:
            return k, False
        self._block(k, self.sim.record_steps)
        control = self.segments.control
        if control.dtype != np.float64 or not control.flags.c_contiguous \
                or control.shape[1] != self.sim._ctrl.size:
            return k, False
        stop = min(stop, (k // self.per_block + 1) * self.per_block)
        status, reached, self.done, self.segments._i = self.native.run(
            self.sim, k, stop, control, self.segments.cut_array, self.done, self.segments._i)
        if status == _record_native.NO_HANDLER:
            self.native = self.sim._native = None
        return reached, status == _record_native.CHECK

    def advance(self, k: int, nstep: int) -> bool:
        self._block(k, nstep)
        if not watched(k, self.n_samples, nstep):
            self.segments.run(self.sim, self.done, self.done + nstep)
            self.done += nstep
            return True
        for count, push in split_steps(nstep):
            self.segments.run(self.sim, self.done, self.done + count)
            self.done += count
            if push:
                self.sim.push_forces()
        return True

    def take(self) -> None:
        self.recorder.take()

    def check(self) -> None:
        self.sim.check()


class _Recorder:
    """Preallocated sample rows for one :meth:`Simulation.run`, one gather of MjData each
    (:class:`SampleRows`); channels are derived from the recorded state at the end
    (:func:`sample_channels`)."""

    def __init__(self, sim: Simulation, n: int):
        self._sim = sim
        self.rows = SampleRows(sim.data, sim.compiled, n)
        self.take = self.rows.take

    def series(self) -> TimeSeries:
        n = self._sim.compiled.n_cables
        return sample_channels(self.rows.buffers(self._sim.dt), self._sim.index,
                               self._sim.model.actuator_dynprm[:n],
                               self._sim.model.actuator_gainprm[:n])


@dataclasses.dataclass(frozen=True)
class SimulationResult:
    """A finished run.

    Attributes:
        trajectory: the recorded time series.
        peak_tension: (n_cables,) maximum load-cell tension over every step [N].
        wall_s: wall-clock time of the stepping [s].
        duration_s: simulated time [s].
        dt_s: physics step [s].
        cables: cable names, in the order of ``peak_tension``.
        peak_speed: (n_cables,) maximum line speed |dl/dt| of each motor over every step
            [m/s] (None where not tracked).
        peak_power: (n_cables,) maximum load-cell tension times line speed over every step
            [W] (None where not tracked).
    """

    trajectory: TimeSeries
    peak_tension: np.ndarray
    wall_s: float
    duration_s: float
    dt_s: float
    cables: tuple[str, ...]
    peak_speed: np.ndarray | None = None
    peak_power: np.ndarray | None = None

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.duration_s / self.wall_s if self.wall_s > 0 else math.inf

    def summary(self) -> dict[str, object]:
        """The run's headline figures, JSON-ready."""
        com = self.trajectory.matrix("pos_x", [COM])[:, 0], \
            self.trajectory.matrix("pos_y", [COM])[:, 0], \
            self.trajectory.matrix("pos_z", [COM])[:, 0]
        displacement = [float(axis[-1] - axis[0]) for axis in com]
        summary: dict[str, object] = {
            "duration_s": self.duration_s,
            "dt_s": self.dt_s,
            "wall_s": round(self.wall_s, 4),
            "real_time_factor": round(self.real_time_factor, 2),
            "max_tension_N": {c: round(float(t), 4) for c, t in
                              zip(self.cables, self.peak_tension, strict=True)},
            "max_system_tension_N": round(float(self.peak_tension.max(initial=0.0)), 4),
            "com_displacement_m": [round(v, 6) for v in displacement],
        }
        for key, peaks in (("max_line_speed_m_s", self.peak_speed),
                           ("max_power_W", self.peak_power)):
            if peaks is not None:
                summary[key] = {c: float(f"{float(v):.6g}") for c, v in
                                zip(self.cables, peaks, strict=True)}
        return summary


def simulate(compiled: CompiledModel, duration: float, *, controller: Controller | None = None,
             loads: Sequence[NodeLoad] = (), record_dt: float = 0.01, backend: str = "auto",
             progress: Callable[[float, float], None] | None = None) -> SimulationResult:
    """Simulates ``compiled`` for ``duration`` seconds from its build pose.

    Args:
        compiled: the compiled model.
        duration: simulated time [s].
        controller: sets up the cable drive; None keeps every rest length where it is.
        loads: external node forces.
        record_dt: recording period [s].
        backend: the cable law, ``"auto"``, ``"compiled"`` or ``"python"``.
        progress: called as progress(done_s, total_s) about every simulated second.

    Raises:
        SimulationError: the run became unstable.
    """
    with Simulation(compiled, controller=controller, loads=loads, record_dt=record_dt,
                    backend=backend) as sim:
        start = _time.perf_counter()
        trajectory = sim.run(duration, progress)
        wall = _time.perf_counter() - start
        return SimulationResult(trajectory, sim.drive.peak.copy(), wall, duration, sim.dt,
                                sim.index.cables, sim.drive.peak_speed.copy(),
                                sim.drive.peak_power.copy())


__all__ = ["COM", "CableSetup", "Controller", "Simulation", "SimulationError", "SimulationResult",
           "StabilityLimits", "diagnose", "simulate"]
