"""The one stepping and recording loop, and the rules every back-end shares.

A run takes a sample of the current state, then, record after record, steps ``record_steps``
physics steps, takes a sample and, every :data:`CHECK_EVERY` records and after the last,
checks stability. The back-ends (a single :class:`~tensim.sim.Simulation`, MuJoCo's batch
engine on threads, MuJoCo Warp's worlds) supply only how to step, sample and read the fields
the checks need (:class:`Backend`); the loop, the time convention, the sample count and the
verdicts (runaway speed or force, a bad acceleration, a contact cable through an obstacle)
are written here once.

Time: a sample taken when the data is about to take physics step j (``data.time`` = j dt)
describes t = (j - 1) dt: the kinematics at t and the rest lengths the motors set at t.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Protocol, overload

import mujoco
import numpy as np

from tensim.sim._contact_check import ContactCheck

CHECK_EVERY = 5  # records between stability checks
TUNNEL_ADVICE = ("Try a smaller timestep (--dt) or a smaller bead spacing (the cable's "
                 "contact: spacing).")
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
_MAX_ACC = mujoco.mjMAXVAL  # MuJoCo's mj_checkAcc: a larger or non-finite qacc is bad


@dataclasses.dataclass(frozen=True)
class StabilityLimits:
    """Bounds past which a run is declared unstable.

    Attributes:
        max_speed: largest allowed generalized velocity of any body [m/s or rad/s].
        max_tension: largest allowed cable force [N].
    """

    max_speed: float = 200.0
    max_tension: float = 1e5


class Backend(Protocol):
    """What the loop needs of a back-end."""

    def advance(self, k: int, nstep: int) -> bool:
        """Steps every running world ``nstep`` physics steps (record ``k``); False when none
        is left running."""

    def take(self) -> None:
        """Samples every running world."""

    def check(self) -> None:
        """Checks every running world's stability (see :func:`stable`)."""


def record_loop(backend: Backend, n_samples: int, record_steps: int, dt: float,
                duration: float, progress: Callable[[float, float], None] | None = None,
                on_record: Callable[[], None] | None = None) -> None:
    """Runs ``n_samples`` records of ``record_steps`` steps, the first sample taken before.

    Args:
        backend: the worlds.
        n_samples: records after the first sample.
        record_steps: physics steps per record.
        dt: physics step [s].
        duration: the run's simulated time, for ``progress`` [s].
        progress: called as progress(done_s, total_s) about every simulated second.
        on_record: called after each record's sample and check.
    """
    backend.take()
    every = max(1, round(1.0 / (record_steps * dt)))
    for k in range(n_samples):
        if not backend.advance(k, record_steps):
            break
        backend.take()
        if k % CHECK_EVERY == 0 or k == n_samples - 1:
            backend.check()
        if on_record is not None:
            on_record()
        if progress is not None and (k + 1) % every == 0:
            progress((k + 1) * record_steps * dt, duration)


def whole_steps(period: float, dt: float, what: str) -> int:
    """The number of physics steps in ``period``; it must be a whole number.

    Raises:
        ValueError: it is not.
    """
    steps = round(period / dt)
    if steps < 1 or abs(steps * dt - period) > 1e-9 * max(1.0, period):
        raise ValueError(f"{what} = {period} s must be a whole number of physics steps "
                         f"(dt = {dt} s)")
    return steps


def sample_count(duration: float, record_steps: int, dt: float) -> int:
    """Records in ``duration`` seconds [s] (after the first sample); a part record is left."""
    return int(np.floor(duration / (record_steps * dt) + 1e-9))


@overload
def next_step(time: float, dt: float) -> int: ...


@overload
def next_step(time: np.ndarray, dt: float) -> np.ndarray: ...


def next_step(time: float | np.ndarray, dt: float) -> int | np.ndarray:
    """The index of the physics step that data at ``time`` [s] takes next (an int for one
    time: Python's round, like ``np.rint``, rounds halves to even)."""
    if isinstance(time, float):
        return round(time / dt)  # called every record of a single run: no array overhead
    return np.rint(np.asarray(time) / dt).astype(np.int64)


def sample_time(time: np.ndarray, dt: float) -> np.ndarray:
    """The time [s] a sample of data at ``time`` [s] describes (see the module docstring)."""
    return (np.rint(np.asarray(time) / dt) - 1) * dt


def bad_acceleration(qacc: np.ndarray) -> np.ndarray:
    """(n,) whether each world's (n, nv) ``qacc`` is one MuJoCo's mj_checkAcc rejects (for
    engines that do not check it themselves, as MuJoCo Warp)."""
    return ~(np.abs(qacc) <= _MAX_ACC).all(axis=-1)


def stable(qvel: np.ndarray, cable_force: np.ndarray, bad_acc: np.ndarray,
           limits: StabilityLimits) -> np.ndarray:
    """(n,) whether each world is within ``limits``: every speed and cable force below its
    bound (NaN is not) and no bad acceleration.

    Args:
        qvel: (n, nv) generalized velocities.
        cable_force: (n, n_cables) the cable actuators' forces (<= 0, pulling) [N].
        bad_acc: (n,) MuJoCo's bad-acceleration warnings (a count, or a flag).
        limits: the bounds.
    """
    speed = np.abs(qvel).max(axis=-1, initial=0.0)  # NaN stays NaN, and fails below
    pull = -cable_force.min(axis=-1, initial=0.0)
    return (speed < limits.max_speed) & (pull < limits.max_tension) & (bad_acc == 0)


def contact_problem(check: ContactCheck, model: mujoco.MjModel, scratch: mujoco.MjData,
                    state: np.ndarray | None = None) -> str | None:
    """What a contact cable went through, or None: the check of ``tensim.sim._contact_check``
    on ``scratch``, set to ``state`` (``mjSTATE_INTEGRATION``) first when given."""
    if state is not None:
        mujoco.mj_setState(model, scratch, state, _STATE)
        mujoco.mj_forward(model, scratch)
    return check.problem(model, scratch)


def tunnel_message(time: float, problem: str) -> str:
    """The error of a contact cable that tunnelled at ``time`` [s]."""
    return f"contact cable tunnelled at t = {time:.3f} s: {problem}. {TUNNEL_ADVICE}"
