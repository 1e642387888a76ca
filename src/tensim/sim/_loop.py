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

Energy growth: a run that goes unstable without ringing at the step frequency (a pair of the
step's eigenvalues leaving the unit circle elsewhere than at -1, or swings the tension-only
clamp keeps below the sign check's) shows as the mechanical energy of the bodies and the cable
springs running away. :class:`EnergyHistory` keeps each world's energy (:class:`Energy`) at
every check, and :func:`energy_growing` tells whether its excess over the lowest energy of the
run is above :data:`ENERGY_LIMIT` times the robot's energy scale (its prestress energy and its
weight times its size, plus what its external node loads can add:
:meth:`Energy.load_allowance`) and at least doubled over the last :data:`ENERGY_CHECKS`
checks: the inputs a run is given (a push, motors, a fall, which turns height into speed at a
constant total) do not add ten times that, and a step's instability does.

Time: a sample taken when the data is about to take physics step j (``data.time`` = j dt)
describes t = (j - 1) dt: the kinematics at t and the rest lengths the motors set at t.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Sequence
from typing import Protocol, overload

import mujoco
import numpy as np

from tensim.model import CompiledModel
from tensim.model._law_layout import implicit, is_cable
from tensim.sim._contact_check import ContactCheck
from tensim.sim._loads import NodeLoad
from tensim.structure import Structure

CHECK_EVERY = 5  # records between stability checks
RING_STEPS = 3  # consecutive physics steps whose cable forces the ringing check compares
RING_EVERY = 4  # stability checks per ringing check (ringing lasts: every 200 ms by default)
RING_SWING = 0.5  # a step's force change, of the largest of the three forces, that rings
RING_BAND = 0.5  # a step's force change, of the cable's prestress band, that rings
RING_FLOOR = 0.01  # N: smaller force changes are round-off, not ringing
ENERGY_LIMIT = 10.0  # energy excess, in the robot's energy scale (Energy.scale), that runs away
ENERGY_GROWTH = 2.0  # ... while growing at least this factor
ENERGY_CHECKS = 2  # ... over this many checks
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

    A back-end may also offer ``records(k, stop) -> (next k, check)``: records k .. stop - 1
    taken at once, each advanced and sampled and, where the loop checks after it, checked
    for what needs no Python; it stops early after a record whose check does (``check``: the
    loop then calls ``check``), and takes none (next k = k) where it cannot, which leaves the
    rest of the run to ``advance`` and ``take``. The loop uses it where no ``on_record`` is
    given.

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
    stretch = getattr(backend, "records", None) if on_record is None else None
    k = 0
    while k < n_samples:
        if stretch is not None:  # records at once, up to the next progress report at most
            stop = n_samples if progress is None else min(n_samples, (k // every + 1) * every)
            reached, check = stretch(k, stop)
            if reached == k:  # it cannot: the rest of the run one record at a time
                stretch = None
            else:
                if check:
                    backend.check()
                k = reached
                if progress is not None and k % every == 0:
                    progress(k * record_steps * dt, duration)
                continue
        if not backend.advance(k, record_steps):
            break
        backend.take()
        if k % CHECK_EVERY == 0 or k == n_samples - 1:
            backend.check()
        if on_record is not None:
            on_record()
        if progress is not None and (k + 1) % every == 0:
            progress((k + 1) * record_steps * dt, duration)
        k += 1


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


_STRETCH: dict[int, tuple[Structure, tuple[float, ...]]] = {}  # see build_stretch
_STRETCH_KEPT = 16  # structures whose stretches are kept


def build_stretch(structure: Structure) -> tuple[float, ...]:
    """Each cable's stretch past its rest length in the build pose, max(0, length - rest)
    [m]; computed once per structure (frozen, so never changed in place) and kept for the next
    simulations of it: a batch starts one per trial, and the cables' lookups cost more than a
    short trial's other Python."""
    hit = _STRETCH.get(id(structure))
    if hit is not None and hit[0] is structure:
        return hit[1]
    stretch = tuple(max(0.0, structure.cable_length(c) - structure.rest_length(c))
                    for c in structure.cables)
    if len(_STRETCH) >= _STRETCH_KEPT:
        _STRETCH.clear()
    _STRETCH[id(structure)] = (structure, stretch)
    return stretch


def prestress_band(structure: Structure) -> np.ndarray:
    """(n_cables,) the tension scale [N] a cable's step-to-step change must pass to ring: its
    build tension, or the cables' mean build tension where that is larger (a cable slack or
    nearly slack at the build pose flickers harmlessly while its damper switches on and off at
    the slack point)."""
    tension = np.array([c.stiffness * s
                        for c, s in zip(structure.cables, build_stretch(structure), strict=True)])
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


class Energy:
    """The mechanical energy of a compiled robot's worlds: kinetic energy of its bodies, their
    weight's potential energy and the cables' spring energy k max(0, x - l)^2 / 2, from the
    fields a back-end samples (the base model's masses and stiffnesses).

    Args:
        compiled: the compiled robot.
    """

    def __init__(self, compiled: CompiledModel):
        m, index = compiled.model, compiled.index
        self.remedy = law_remedy(m)  # the cable law's part of a blow-up's advice
        free = np.flatnonzero(m.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
        self.body = m.jnt_bodyid[free]
        self.dof = m.jnt_dofadr[free]
        self.mass = m.body_mass[self.body]
        # each free body's inertia in its own frame (MuJoCo's principal axes turned back)
        flat = np.zeros((len(free), 9))
        for k, b in enumerate(self.body):
            mujoco.mju_quat2Mat(flat[k], m.body_iquat[b])
        rot = flat.reshape(-1, 3, 3)
        self.inertia = np.einsum("kij,kj,klj->kil", rot, m.body_inertia[self.body], rot)
        slide = np.flatnonzero(m.jnt_type == mujoco.mjtJoint.mjJNT_SLIDE)  # contact beads
        self.slide_dof, self.slide_mass = m.jnt_dofadr[slide], m.body_mass[m.jnt_bodyid[slide]]
        # total's fast path: each dof's share of the kinetic energy as one quadratic form
        n = len(free)
        self._lin = np.concatenate([(self.dof[:, None] + np.arange(3)).ravel(), self.slide_dof])
        self._lin_mass = 0.5 * np.concatenate([np.repeat(self.mass, 3), self.slide_mass])
        self._ang = (self.dof[:, None] + np.arange(3, 6)).ravel()
        self._ang_inertia = np.zeros((3 * n, 3 * n))
        for k in range(n):
            self._ang_inertia[3 * k:3 * k + 3, 3 * k:3 * k + 3] = 0.5 * self.inertia[k]
        self.gravity = np.asarray(m.opt.gravity, dtype=float).copy()
        self.tendon = index.tendon
        self.rest = np.asarray(index.rest_act)  # each cable's rest length in act
        self.stiffness = m.actuator_gainprm[index.actuator, 1].copy()
        self.bodies = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(b)) or str(b)
                       for b in self.body]
        self.cables = index.cables
        structure = compiled.structure
        weight = float(self.mass.sum() * np.linalg.norm(self.gravity))
        points = np.array([n.position for n in structure.nodes]) if structure.nodes else \
            np.zeros((1, 3))
        build = np.array([c.stiffness * s ** 2 / 2
                          for c, s in zip(structure.cables, build_stretch(structure),
                                          strict=True)])
        # the energy a run of this robot moves about in: its prestress and its weight over
        # its size (J)
        self.size = max(float(np.ptp(points, axis=0).max()), 1e-3)  # [m]
        self.total_mass = float(self.mass.sum() + self.slide_mass.sum())  # [kg]
        self.scale = float(build.sum() + weight * self.size) or 1.0

    def load_allowance(self, loads: Iterable[NodeLoad]) -> float:
        """The energy external node loads may add to a run [J]: for each load, its peak force
        over the robot's size, or the kinetic energy its peak force held over its knots gives
        the whole robot, whichever is larger. A run's own inputs are not a step's instability,
        so :class:`EnergyHistory`'s limit grows by this much."""
        total = 0.0
        for load in loads:
            force = float(np.linalg.norm(load.forces, axis=1).max())
            span = float(load.times[-1] - load.times[0]) if load.times.size > 1 else 0.0
            impulse = force * span
            total += max(force * self.size, impulse**2 / (2 * max(self.total_mass, 1e-9)))
        return total

    def parts(self, qvel: np.ndarray, xpos: np.ndarray, ten_length: np.ndarray,
              act: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each world's (n, n_free) body kinetic energies, (n,) potential energy of the
        weights [J] and (n, n_cables) cable spring energies [J], from (n, ...) fields."""
        v = qvel[:, self.dof[:, None] + np.arange(3)]
        w = qvel[:, self.dof[:, None] + np.arange(3, 6)]  # in each body's frame
        kinetic = 0.5 * self.mass * (v**2).sum(-1) \
            + 0.5 * np.einsum("nki,kij,nkj->nk", w, self.inertia, w)
        if self.slide_dof.size:
            kinetic = np.concatenate(
                [kinetic, 0.5 * self.slide_mass * qvel[:, self.slide_dof] ** 2], axis=1)
        height = -(xpos[:, self.body] @ self.gravity)  # the bodies' origins are their centres
        stretch = np.maximum(ten_length[:, self.tendon] - act[:, self.rest], 0.0)
        return kinetic, height @ self.mass, 0.5 * self.stiffness * stretch**2

    def total(self, qvel: np.ndarray, xpos: np.ndarray, ten_length: np.ndarray,
              act: np.ndarray) -> np.ndarray:
        """(n,) each world's mechanical energy [J]: the sum of :meth:`parts`, in few
        operations (a single run checks it every few records)."""
        w = qvel[:, self._ang]
        stretch = np.maximum(ten_length[:, self.tendon] - act[:, self.rest], 0.0)
        return (qvel[:, self._lin] ** 2 @ self._lin_mass + ((w @ self._ang_inertia) * w).sum(1)
                - xpos[:, self.body] @ self.gravity @ self.mass
                + stretch**2 @ (0.5 * self.stiffness))

    def largest(self, qvel: np.ndarray, xpos: np.ndarray, ten_length: np.ndarray,
                act: np.ndarray) -> str:
        """The body or cable of one world (fields of shape (1, ...)) that holds the most
        kinetic or spring energy, named."""
        kinetic, _, spring = self.parts(qvel, xpos, ten_length, act)
        names = [f"body {b!r}" for b in self.bodies] \
            + [f"bead {k}" for k in range(self.slide_dof.size)] \
            + [f"cable {c!r}" for c in self.cables]
        return names[int(np.argmax(np.concatenate([kinetic[0], spring[0]])))]


class EnergyHistory:
    """Each world's mechanical energy at its last :data:`ENERGY_CHECKS` + 1 checks and the
    lowest of its run, for :func:`energy_growing`.

    Args:
        n: worlds.
        scale: the robot's energy scale (:attr:`Energy.scale`) [J].
    """

    def __init__(self, n: int, scale: float):
        self.energy = np.full((n, ENERGY_CHECKS + 1), np.nan)
        self.lowest = np.full(n, np.inf)
        self.limit = ENERGY_LIMIT * scale

    def push(self, ids: np.ndarray | slice, energy: np.ndarray) -> np.ndarray:
        """Adds worlds ``ids``' energies (k,) [J] at a check; returns (k,) whether each grows
        (:func:`energy_growing`)."""
        self.energy[ids, :-1] = self.energy[ids, 1:]
        self.energy[ids, -1] = energy
        self.lowest[ids] = np.fmin(self.lowest[ids], energy)
        return energy_growing(self.energy[ids] - self.lowest[ids][:, None], self.limit)

    def reset(self, ids: np.ndarray | slice) -> None:
        """Forgets worlds ``ids``' energies (a state set from elsewhere)."""
        self.energy[ids] = np.nan
        self.lowest[ids] = np.inf


def energy_growing(excess: np.ndarray, limit: float) -> np.ndarray:
    """(n,) whether each world's energy runs away: its excess over its run's lowest energy,
    (n, ENERGY_CHECKS + 1) at its last checks, oldest first [J], ends above ``limit`` [J] and
    grew at least :data:`ENERGY_GROWTH`-fold over those checks (NaN, not yet checked that
    often: False)."""
    return (excess[:, -1] > limit) & (excess[:, -1] >= ENERGY_GROWTH * excess[:, 0])


def energy_message(what: str, excess: np.ndarray, time: float, dt: float,
                   law: str = "--cable-law implicit, ") -> str:
    """The error of a world whose energy grows at ``time`` [s] with physics step ``dt`` [s]:
    ``what`` holds most of it (:meth:`Energy.largest`); ``excess`` (ENERGY_CHECKS + 1,) [J];
    ``law`` the cable law's remedy (:func:`law_remedy`)."""
    return (f"simulation unstable at t = {time:.3f} s: the mechanical energy of the bodies "
            f"and cables runs away, from {excess[0]:.3g} to {excess[-1]:.3g} J above its lowest "
            f"over the last {ENERGY_CHECKS} checks, most of it in {what}, so the "
            f"{dt * 1e3:g} ms step is too long. Use --dt {suggest_step(dt):g} or less "
            f"(`tensim check` prints the bound), {law}or softer cables / heavier parts.")


def law_remedy(model: mujoco.MjModel) -> str:
    """What the cable law can still do for a run that blows up, as :func:`energy_message`
    words it: the implicit law where every cable is explicit, more cables on it where it is
    split by cable, nothing where every cable is on it already."""
    on_implicit = implicit(model)[is_cable(model)]
    if not on_implicit.any():
        return "--cable-law implicit, "
    if not on_implicit.all():
        return "a larger --split-margin (more cables on the implicit law), "
    return ""
