"""The one stepping and recording loop, and the rules every back-end shares.

A run takes a sample of the current state, then, record after record, steps ``record_steps``
physics steps, takes a sample and, every :data:`CHECK_EVERY` records and after the last,
checks stability. The back-ends (a single :class:`~tensim.sim.Simulation`, MuJoCo's batch
engine on threads, MuJoCo Warp's worlds) supply only how to step, sample and read the fields
the checks need (:class:`Backend`); the loop, the time convention, the sample count and the
verdicts (runaway speed or force, a bad acceleration, a contact cable through an obstacle,
a cable that rings at the step frequency) are written here once.

Ringing: a step too long for a cable (see ``tensim check``) shows as its force alternating
up and down from one physics step to the next, often between slack and taut, before speeds
run away (the tension-only clamp can even hold it there while the robot slides). A back-end
keeps the cable forces of the last :data:`RING_STEPS` steps before every :data:`RING_EVERY`-th
check (:class:`ForceHistory`; its last steps one call each only there) and :func:`ringing`
tells whether each cable rings: no resolved motion alternates at the step frequency.

Time: a sample taken when the data is about to take physics step j (``data.time`` = j dt)
describes t = (j - 1) dt: the kinematics at t and the rest lengths the motors set at t.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Protocol, overload

import mujoco
import numpy as np

from tensim.sim._contact_check import ContactCheck
from tensim.structure import Structure

CHECK_EVERY = 5  # records between stability checks
RING_STEPS = 3  # consecutive physics steps whose cable forces the ringing check compares
RING_EVERY = 4  # stability checks per ringing check (ringing lasts: every 200 ms by default)
RING_SWING = 0.5  # a step's force change, of the largest of the three forces, that rings
RING_BAND = 0.5  # a step's force change, of the cable's prestress band, that rings
RING_FLOOR = 0.01  # N: smaller force changes are round-off, not ringing
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


def ringing(force: np.ndarray, band: np.ndarray | float = 0.0) -> np.ndarray:
    """(n, n_cables) whether each cable rings: its force over :data:`RING_STEPS` consecutive
    physics steps went up then down (or down then up), each change above :data:`RING_SWING`
    of the largest of the forces, above :data:`RING_BAND` of its prestress band and above
    :data:`RING_FLOOR`.

    Args:
        force: (n, RING_STEPS, n_cables) the cables' forces, oldest first, all of one sign
            (MuJoCo's actuator forces pull: <= 0) [N].
        band: (n_cables,) each cable's prestress band (see :func:`prestress_band`) [N].
    """
    first, second = force[:, 1] - force[:, 0], force[:, 2] - force[:, 1]
    size = np.minimum(np.abs(first), np.abs(second))
    ring = size > np.maximum(RING_BAND * np.asarray(band), RING_FLOOR)
    if not ring.any():  # the common case, in few operations
        return ring
    return ring & (first * second < 0) & (size > RING_SWING * np.abs(force).max(axis=1))


def prestress_band(structure: Structure) -> np.ndarray:
    """(n_cables,) the tension scale [N] a cable's step-to-step change must pass to ring: its
    build tension, or the cables' mean build tension where that is larger (a cable slack or
    nearly slack at the build pose flickers harmlessly while its damper switches on and off at
    the slack point)."""
    tension = np.array([c.stiffness * max(0.0, structure.cable_length(c)
                                          - structure.rest_length(c))
                        for c in structure.cables])
    return np.maximum(tension, tension.mean()) if tension.size else tension


def ring_message(cables: Sequence[str], ring: np.ndarray, force: np.ndarray, time: float,
                 dt: float) -> str:
    """The error of a world whose cables ``ring`` (n_cables,) at ``time`` [s] with physics
    step ``dt`` [s]: it names the one whose force ``force`` (RING_STEPS, n_cables) [N] swings
    most."""
    swing = np.where(ring, np.ptp(np.abs(force), axis=0), -1.0)
    k = int(np.argmax(swing))
    cable = cables[k]
    low, high = float(np.abs(force[:, k]).min()), float(np.abs(force[:, k]).max())
    return (f"simulation unstable at t = {time:.3f} s: cable {cable!r} rings at the step "
            f"frequency, its tension jumping between {low:.4g} and {high:.4g} N from one "
            f"{dt * 1e3:g} ms step to the next, so the step is too long for it. Use --dt "
            f"{suggest_step(dt):g} or less (`tensim check` prints the bound), or softer cables "
            "/ heavier parts.")


def suggest_step(dt: float) -> float:
    """A step [s] to try after ringing at ``dt`` [s]: the largest of 1, 2, 5 x 10^k at most
    dt / 2 (the bound is below dt, and the step ``tensim check`` asks for is half of it)."""
    exponent = np.floor(np.log10(dt / 2))
    mantissa = next(m for m in (5.0, 2.0, 1.0) if m * 10**exponent <= dt / 2 * (1 + 1e-9))
    return float(mantissa * 10**exponent)


class ForceHistory:
    """The cable forces of each world's last :data:`RING_STEPS` steps, for :func:`ringing`.

    Args:
        n: worlds.
        band: (n_cables,) the cables' prestress bands (:func:`prestress_band`) [N].
    """

    def __init__(self, n: int, band: np.ndarray):
        self.band = np.maximum(RING_BAND * band, RING_FLOOR) / RING_BAND
        self.force = np.zeros((n, RING_STEPS, len(band)))
        self.count = np.zeros(n, dtype=int)
        self.fresh = False  # forces pushed since the last ringing test

    def push(self, ids: np.ndarray | slice, force: np.ndarray) -> None:
        """Adds the forces (k, n_cables) [N] of worlds ``ids`` after one more step."""
        self.force[ids, :-1] = self.force[ids, 1:]
        self.force[ids, -1] = force
        self.count[ids] += 1
        self.fresh = True

    def ringing(self, ids: np.ndarray | slice) -> np.ndarray:
        """(k, n_cables) :func:`ringing` of worlds ``ids`` on the forces pushed since the last
        test (False without new ones, or before RING_STEPS steps)."""
        force = self.force[ids]
        if not self.fresh:
            return np.zeros((len(force), force.shape[2]), dtype=bool)
        self.fresh = False
        return ringing(force, self.band) & (self.count[ids] >= RING_STEPS)[:, None]


def watched(k: int, n_samples: int, nstep: int) -> bool:
    """Whether record ``k`` (of ``nstep`` steps) steps its last steps one at a time for the
    ringing check: every :data:`RING_EVERY`-th record :func:`record_loop` checks after, the
    last, and every record when a record is shorter than RING_STEPS steps."""
    return nstep < RING_STEPS or k % (CHECK_EVERY * RING_EVERY) == 0 or k == n_samples - 1


def split_steps(nstep: int) -> list[tuple[int, bool]]:
    """The calls (steps, whether to push the forces after it) of a watched record of
    ``nstep`` steps: all but its last RING_STEPS - 1 steps in one call, then one call each;
    the forces after each of these calls are those of the record's last RING_STEPS steps."""
    head = nstep - (RING_STEPS - 1)
    return [(head, True), *[(1, True)] * (RING_STEPS - 1)] if head > 1 \
        else [(1, True)] * nstep


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
