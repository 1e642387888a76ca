"""The simulation loop: fixed-step MuJoCo with cables, recording and stability checks."""

from __future__ import annotations

import dataclasses
import math
import time as _time
from collections.abc import Callable, Sequence
from typing import Protocol

import mujoco
import numpy as np

from tensim.model import CompiledModel
from tensim.sim._drive import CableDrive
from tensim.sim._loads import NodeLoad
from tensim.sim._timeseries import TimeSeries

_CABLE_QUANTITIES = ("tension", "setpoint", "applied", "length", "velocity", "rest_length")
_POSE_QUANTITIES = ("pos_x", "pos_y", "pos_z", "quat_w", "quat_x", "quat_y", "quat_z")
_CHECK_EVERY = 5  # records between stability checks in run()
COM = "com"  # the item name of the whole robot's centre of mass in recorded pose channels


class SimulationError(RuntimeError):
    """The simulation became unstable (non-finite state or runaway energy)."""


class Controller(Protocol):
    """Anything that sets up a simulation's cable drive (gains, targets, V* table)."""

    def configure(self, sim: Simulation) -> None:
        """Writes this controller's commands into ``sim.drive``."""


@dataclasses.dataclass(frozen=True)
class StabilityLimits:
    """Bounds past which a run is declared unstable.

    Attributes:
        max_speed: largest allowed generalized velocity of any body [m/s or rad/s].
        max_tension: largest allowed cable force [N].
    """

    max_speed: float = 200.0
    max_tension: float = 1e5


class Simulation:
    """One robot simulated at a fixed step, with its cables, motors and controller state.

    The drive's arrays are the controller's explicit state; MuJoCo's ``MjData`` holds the rest.
    Use as a context manager (or call :meth:`close`) to detach the cable callback.

    Args:
        compiled: the compiled model.
        loads: external node forces.
        controller: sets up the cable drive before the first cable update; None keeps every
            rest length where it is.
        record_dt: recording period [s]; a whole number of physics steps.
        backend: ``"auto"``, ``"compiled"`` or ``"python"`` (the reference implementation).
        limits: the stability bounds.
    """

    def __init__(self, compiled: CompiledModel, *, controller: Controller | None = None,
                 loads: Sequence[NodeLoad] = (), record_dt: float = 0.01, backend: str = "auto",
                 limits: StabilityLimits | None = None):
        self.compiled = compiled
        self.model = compiled.model
        self.data = mujoco.MjData(self.model)
        self.index = compiled.index
        self.dt = float(self.model.opt.timestep)
        self.record_steps = _whole_steps(record_dt, self.dt, "record_dt")
        self.limits = limits or StabilityLimits()
        self.drive = CableDrive(compiled, self.data, loads, backend)
        self._steps = 0
        self._qvel = self.data.qvel
        self._bad_acc = self.data.warning[mujoco.mjtWarning.mjWARN_BADQACC]
        if controller is not None:
            controller.configure(self)
        mujoco.mj_forward(self.model, self.data)  # the cable update at t = 0

    # -- lifecycle ---------------------------------------------------------------------------

    def close(self) -> None:
        """Detaches the cable callback from this simulation's data."""
        self.drive.unregister()

    def __enter__(self) -> Simulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def time(self) -> float:
        """Time of the latest cable update (the state the outputs describe) [s]."""
        return self._steps * self.dt

    # -- stepping ----------------------------------------------------------------------------

    def step(self, nstep: int = 1) -> None:
        """Advances ``nstep`` physics steps inside MuJoCo, then checks stability.

        Raises:
            SimulationError: the state is non-finite or running away.
        """
        if nstep > 0:
            self._advance(nstep)
            self.check()

    def _advance(self, nstep: int) -> None:
        # the first step repeats the t = 0 cable update of mj_forward, so it does not count
        extra = 1 if self._steps == 0 and self.data.time == 0.0 else 0
        mujoco.mj_step(self.model, self.data, nstep=nstep + extra)
        self._steps += nstep

    def run(self, duration: float, progress: Callable[[float, float], None] | None = None,
            on_record: Callable[[Simulation], None] | None = None) -> TimeSeries:
        """Simulates ``duration`` seconds more, recording every ``record_dt``.

        Args:
            duration: simulated time [s].
            progress: called as progress(done_s, total_s) about every simulated second.
            on_record: called with this simulation after each sample (every ``record_dt``),
                e.g. to log extra signals or to update an external force in between.

        Returns:
            The recorded samples, the current state included as the first one.
        """
        n_samples = math.floor(duration / (self.record_steps * self.dt) + 1e-9)
        recorder = _Recorder(self, n_samples + 1)
        recorder.take(self)
        every = max(1, round(1.0 / (self.record_steps * self.dt)))
        for k in range(n_samples):
            self._advance(self.record_steps)
            if k % _CHECK_EVERY == 0 or k == n_samples - 1:
                self.check()
            recorder.take(self)
            if on_record is not None:
                on_record(self)
            if progress is not None and (k + 1) % every == 0:
                progress((k + 1) * self.record_steps * self.dt, duration)
        return recorder.series()

    # -- checks ------------------------------------------------------------------------------

    def check(self) -> None:
        """Raises :class:`SimulationError` naming the body or cable if the state ran away."""
        speed = np.abs(self._qvel).max(initial=0.0)
        force = self.drive.applied.max(initial=0.0)  # tension-only: never negative
        bad_acc = self._bad_acc.number
        if speed < self.limits.max_speed and force < self.limits.max_tension and not bad_acc:
            return  # also False for NaN, which lands below
        raise SimulationError(self._diagnose(bool(bad_acc)))

    def _diagnose(self, bad_acc: bool) -> str:
        d = self.data
        qvel = np.nan_to_num(np.abs(d.qvel), nan=np.inf)
        applied = np.nan_to_num(self.drive.applied, nan=np.inf)
        when = ""
        if bad_acc:  # the state is MuJoCo's reset one: name the dof it found, and the peak
            dof = int(d.warning[mujoco.mjtWarning.mjWARN_BADQACC].lastinfo)
            body = self._body_of(dof)
            # the running peak of each cable's tension holds the forces from before the reset
            applied = np.nan_to_num(self.drive.peak, nan=np.inf)
            what = f"MuJoCo found a non-finite acceleration of body {body!r} and reset the state"
            when = "before the reset "
        elif qvel.max(initial=0.0) >= self.limits.max_speed:
            what = (f"body {self._body_of(int(np.argmax(qvel)))!r} reached speed "
                    f"{qvel.max():.3g} (limit {self.limits.max_speed:g} m/s or rad/s)")
        else:
            what = f"a cable tension passed the limit of {self.limits.max_tension:g} N"
        cable = self.index.cables[int(np.argmax(applied))] if applied.size else "-"
        return (f"simulation unstable at t = {self.time:.3f} s: {what}; {when}the most loaded "
                f"cable was {cable!r} at {applied.max(initial=0.0):.4g} N. Try a smaller timestep "
                "(--dt), lower cable stiffness or pretension, or more cable damping.")

    def _body_of(self, dof: int) -> str:
        """The name of the body a degree of freedom moves ("-" for none)."""
        if not 0 <= dof < self.model.nv:
            return "-"
        body = int(self.model.dof_bodyid[dof])
        return mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_BODY, body) or f"#{body}"


class _Recorder:
    """Preallocated sample buffers for one :meth:`Simulation.run`.

    The MjData and drive arrays are bound once; a sample is a handful of in-place copies.
    """

    def __init__(self, sim: Simulation, n: int):
        self.k, self._sim = 0, sim
        n_cables, n_bodies = sim.compiled.n_cables, len(sim.index.bodies)
        self.time = np.zeros(n)
        self.cables = {q: np.zeros((n, n_cables)) for q in _CABLE_QUANTITIES}
        self.pos = np.zeros((n, n_bodies + 1, 3))
        self.quat = np.zeros((n, n_bodies, 4))
        d, drive = sim.data, sim.drive
        self._copies = [(self.cables["tension"], drive.tension),
                        (self.cables["setpoint"], drive.setpoint),
                        (self.cables["applied"], drive.applied),
                        (self.cables["rest_length"], drive.rest)]
        self._takes = [(self.cables["length"], d.ten_length, drive.tendon),
                       (self.cables["velocity"], d.ten_velocity, drive.tendon),
                       (self.quat, d.xquat, sim.index.body)]
        self._xpos, self._com, self._body = d.xpos, d.subtree_com, sim.index.body

    def take(self, sim: Simulation) -> None:
        k = self.k
        self.time[k] = sim.time
        for buffer, source in self._copies:
            buffer[k] = source
        for buffer, source, ids in self._takes:
            np.take(source, ids, axis=0, out=buffer[k])
        np.take(self._xpos, self._body, axis=0, out=self.pos[k, :-1])
        self.pos[k, -1] = self._com[0]
        self.k += 1

    def series(self) -> TimeSeries:
        k, index = self.k, self._sim.index
        channels: dict[str, np.ndarray] = {}
        for q, values in self.cables.items():
            for i, name in enumerate(index.cables):
                channels[f"{q}/{name}"] = values[:k, i].copy()
        for i, name in enumerate((*index.bodies, COM)):
            for a, axis in enumerate("xyz"):
                channels[f"pos_{axis}/{name}"] = self.pos[:k, i, a].copy()
        for i, name in enumerate(index.bodies):
            for a, axis in enumerate("wxyz"):
                channels[f"quat_{axis}/{name}"] = self.quat[:k, i, a].copy()
        return TimeSeries(self.time[:k].copy(), channels)


def _whole_steps(period: float, dt: float, what: str) -> int:
    """The number of physics steps in ``period``; it must be a whole number."""
    steps = round(period / dt)
    if steps < 1 or abs(steps * dt - period) > 1e-9 * max(1.0, period):
        raise ValueError(f"{what} = {period} s must be a whole number of physics steps "
                         f"(dt = {dt} s)")
    return steps


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
    """

    trajectory: TimeSeries
    peak_tension: np.ndarray
    wall_s: float
    duration_s: float
    dt_s: float
    cables: tuple[str, ...]

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
        return {
            "duration_s": self.duration_s,
            "dt_s": self.dt_s,
            "wall_s": round(self.wall_s, 4),
            "real_time_factor": round(self.real_time_factor, 2),
            "max_tension_N": {c: round(float(t), 4) for c, t in
                              zip(self.cables, self.peak_tension, strict=True)},
            "max_system_tension_N": round(float(self.peak_tension.max(initial=0.0)), 4),
            "com_displacement_m": [round(v, 6) for v in displacement],
        }


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
        backend: cable callback, ``"auto"``, ``"compiled"`` or ``"python"``.
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
                                sim.index.cables)
