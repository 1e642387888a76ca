"""Batches on MuJoCo Warp: one world per trial, on a GPU or on Warp's CPU device.

The same trials as :func:`tensim.sim.run_batch`: each world steps its trial's model (law
parameters, friction, masses, or a whole recompiled structure of the same layout): every model
field in which any trial differs from the batch's model becomes a per-world field of MuJoCo
Warp's model, filled from the trials' own model copies (with the constants MuJoCo derived for
each, as ``mj_setConst`` leaves them). Commands go through ``ctrl`` and each world is recorded
into the same channels. The cable law runs as a Warp kernel in MuJoCo Warp's step
(:mod:`tensim.sim._warp_law`). MuJoCo Warp computes in float32 and its constraint solver is
its own, so a world agrees with the CPU engine to a tolerance, not bit for bit (see
``docs/gpu.md``).

Every world's inputs (V* commands, commanded rest lengths, node loads: its ``ctrl`` rows) are
computed on the host once per stretch of steps and held on the device, where a kernel copies
the current row into ``ctrl`` before each step, so no Python runs between the steps of a
record interval. On a CUDA device the record interval (its steps, the law and the input
copies) is captured once as a CUDA graph and replayed per record.
"""

from __future__ import annotations

import copy
import ctypes
import logging
import time as _time
from collections.abc import Callable, Sequence
from typing import Any

import mujoco
import numpy as np

from tensim.model import BUILD_KEY, CompiledModel
from tensim.sim._contact_check import ContactCheck
from tensim.sim._drive import InputPlan
from tensim.sim._loop import (
    Energy,
    EnergyHistory,
    ForceHistory,
    StabilityLimits,
    bad_acceleration,
    contact_problem,
    energy_message,
    prestress_band,
    record_loop,
    ring_message,
    sample_time,
    split_steps,
    stable,
    tunnel_message,
    watched,
)
from tensim.sim._samples import SampleBuffers
from tensim.sim._simulation import diagnose
from tensim.sim._trials import Trial, TrialResult, setup_trial, trial_models, trial_results

_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
# a trial's model may differ from the batch's in values, never in these sizes
# fields MuJoCo Warp holds once but reads only for island sleeping, which tensim leaves off
_SLEEP_ONLY = frozenset({"dof_length"})
# take() launches the next record interval before storing a sample on CUDA devices, where
# launches are asynchronous; tests turn it on for Warp's CPU device, where it must (and does)
# give the same results as stepping after the sample
PIPELINE_ON_CPU = False
_SIZES = ("nq", "nv", "nu", "na", "nbody", "ngeom", "nsite", "ntendon", "nwrap", "neq",
          "nkey")


def warp_available() -> bool:
    """Whether MuJoCo Warp (the ``tensim[gpu]`` extra) is installed."""
    try:
        import warp

        # before MuJoCo Warp initialises Warp: its banner (devices, cache folder) is logged
        # at INFO; warnings (e.g. no CUDA driver) still show
        warp.config.log_level = max(warp.config.log_level, logging.WARNING)
        import mujoco_warp  # noqa: F401
    except ImportError:
        return False
    return True


def run_batch_warp(compiled: CompiledModel, trials: Sequence[Trial], duration: float, *,
                   record_steps: int, n_samples: int, limits: StabilityLimits,
                   progress: Callable[[float, float], None] | None = None,
                   device: str | None = None, njmax: int | None = None,
                   nconmax: int | None = None) -> list[TrialResult]:
    """:func:`tensim.sim.run_batch` with ``backend="warp"`` (see there; ``compiled`` already
    has every trial's load nodes).

    Args:
        device: the Warp device (None: Warp's default, a GPU when there is one).
        njmax, nconmax: constraint rows and contacts MuJoCo Warp allocates per world (None:
            sized from the model by :func:`world_capacity`). A world that needs more fails
            with a message that says so (MuJoCo Warp would drop the rest and go on).

    Raises:
        ImportError: MuJoCo Warp is not installed.
        ValueError: trials the Warp backend cannot run together (models of other sizes, a
            field that differs and MuJoCo Warp holds once for all worlds, a mix of fresh and
            restored initial states).
    """
    if not warp_available():
        raise ImportError("the warp backend needs MuJoCo Warp: pip install 'tensim[gpu]'")
    import warp as wp

    restored = {t.initial_state is not None for t in trials}
    if len(restored) > 1:
        raise ValueError("on the warp backend either every trial or none has an initial state")
    rows, contacts = world_capacity(compiled.model)
    with wp.ScopedDevice(device):
        run = _WarpRun(compiled, trials, record_steps, limits, njmax or rows, nconmax or contacts)
        started = _time.perf_counter()
        run.run(n_samples, duration, progress, fresh=not restored.pop())
        wall = _time.perf_counter() - started
    return run.results(duration, wall)


def per_world_fields(batch: mujoco.MjModel, models: Sequence[mujoco.MjModel]) -> list[str]:
    """The model fields MuJoCo Warp must hold per world: those in which any of ``models``
    differs from ``batch``.

    Raises:
        ValueError: a model of other sizes, or one that differs in a field MuJoCo Warp holds
            once for all worlds.
    """
    import dataclasses

    from mujoco_warp._src import types
    from mujoco_warp._src.warp_util import is_array_spec

    sizes = np.asarray(batch._sizes)
    for i, m in enumerate(models):
        if not np.array_equal(np.asarray(m._sizes), sizes):
            other = next((s for s in _SIZES if getattr(m, s) != getattr(batch, s)), None)
            what = (f"{other} {getattr(m, other)} against {getattr(batch, other)}"
                    if other is not None else "another layout of its arrays")
            raise ValueError(f"trial {i}: its model differs in size ({what}); a batch's trials "
                             "share one layout")
    known = {f.name: f.type for f in dataclasses.fields(types.Model)}
    batched = {name for name, kind in known.items()
               if is_array_spec(kind) and getattr(kind, "shape", ("",))[0] == "*"}
    arrays = {name: value for name in dir(batch) if not name.startswith("_")
              and isinstance(value := getattr(batch, name, None), np.ndarray) and value.size}
    fields = []
    for name, differs in _differing(batch, models, arrays).items():
        if name not in known or name in _SLEEP_ONLY or name.startswith("key_"):
            continue  # a field MuJoCo Warp's step does not read; each world starts from its key
        if name not in batched:
            raise ValueError(f"trial {differs}: its model differs in {name}, which MuJoCo Warp "
                             "holds once for all worlds; run it on the CPU engine")
        fields.append(name)
    return fields


def _differing(batch: mujoco.MjModel, models: Sequence[mujoco.MjModel],
               arrays: dict[str, np.ndarray]) -> dict[str, int]:
    """Each of ``arrays`` (``batch``'s fields) in which a model differs, with the first such
    model.

    MuJoCo keeps a model's arrays in one buffer laid out by its sizes alone, so models of equal
    sizes (checked by the caller) hold each field at the same offset: one comparison of each
    model's whole buffer finds the bytes that differ, which are then mapped to their fields
    (padding between arrays maps to none). A thousand worlds' models are compared in
    milliseconds; field by field it took seconds."""
    address = {name: a.__array_interface__["data"][0] for name, a in arrays.items()}
    start = min(address.values())
    end = max(address[name] + a.nbytes for name, a in arrays.items())
    if end - start > batch.nbuffer:  # not one buffer (cannot happen in MuJoCo 3-4): compare
        return {name: i for name, value in arrays.items()  # field by field
                for i in [next((i for i, m in enumerate(models)
                                if not np.array_equal(getattr(m, name), value)), None)]
                if i is not None}
    first = next(iter(arrays))
    offset = address[first] - start

    def buffer(m: mujoco.MjModel) -> np.ndarray:
        at = getattr(m, first).__array_interface__["data"][0] - offset
        return np.ctypeslib.as_array((ctypes.c_uint8 * (end - start)).from_address(at))

    reference = buffer(batch)
    changed = np.full(end - start, -1, dtype=np.int64)  # the first model differing per byte
    for i, m in enumerate(models):
        new = (buffer(m) != reference) & (changed < 0)
        if new.any():
            changed[new] = i
    out: dict[str, int] = {}
    for name, a in arrays.items():
        span = changed[address[name] - start:address[name] - start + a.nbytes]
        hit = span[span >= 0]
        if hit.size:
            out[name] = int(hit.min())
    return out


def world_capacity(model: mujoco.MjModel) -> tuple[int, int]:
    """(constraint rows, contacts) to allocate per MuJoCo Warp world for ``model``: two
    contacts per geom (a rod's two end caps, each on the ground and on one other part),
    each taking the rows of its friction cone, plus the tendon and equality rows."""
    contacts = max(64, 2 * model.ngeom)
    cone = 2 * 2 if model.opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL else 3
    return max(256, cone * contacts + model.ntendon + 6 * model.neq), contacts


class _WarpRun:
    """The state of one Warp batch."""

    def __init__(self, compiled: CompiledModel, trials: Sequence[Trial], record_steps: int,
                 limits: StabilityLimits, njmax: int, nconmax: int):
        import mujoco_warp as mjw

        from tensim.sim._warp_law import install_warp_law, warp_host_model

        self.compiled, self.trials, self.limits = compiled, trials, limits
        self.record_steps, self.dt = record_steps, float(compiled.model.opt.timestep)
        n = len(trials)
        self.error: list[str | None] = [None] * n
        self.compileds = trial_models(compiled, trials)
        # each trial steps its own copy of its model: its controller's gains, its physics
        self.models = [copy.copy(c.model) for c in self.compileds]
        self.plans = [self._setup(i, t) for i, t in enumerate(trials)]
        host = warp_host_model(compiled.model)
        data = mujoco.MjData(host)
        mujoco.mj_resetDataKeyframe(host, data, host.key(BUILD_KEY).id)
        fields = per_world_fields(compiled.model, self.models)
        self.m = mjw.put_model(host, batch_sizes=dict.fromkeys(fields, n))
        for name in fields:
            rows = np.stack([getattr(m, name) for m in self.models])
            try:
                target = getattr(self.m, name)
                target.assign(rows.reshape(target.numpy().shape))
            except (ValueError, RuntimeError) as exc:
                raise ValueError(f"the trials' models differ in {name}, which MuJoCo Warp "
                                 f"cannot hold per world here ({exc}); run them on the CPU "
                                 "engine") from None
        install_warp_law(self.m)
        self.m.opt.warn_overflow = 0  # overflows fail their world in check(), with a message
        self.d = mjw.put_data(host, data, nworld=n, nconmax=nconmax, njmax=njmax)
        self._restore(host, trials)
        self._step = mjw.step
        self._graphs: dict[int, Any] = {}  # captured launches, by their number of steps
        self.taken = 0  # samples taken
        self._ahead = False  # the next record interval is running (launched by take())
        self.state: dict[str, np.ndarray] | None = None
        self.samples = SampleBuffers.empty(compiled, 0, (n,))
        self.count = np.zeros(n, dtype=int)
        self.steps = np.zeros(n, dtype=np.int64)
        self._contact = ContactCheck(compiled) \
            if any(c.contact for c in compiled.structure.cables) else None
        self._scratch = mujoco.MjData(compiled.model) if self._contact is not None else None

    def _setup(self, i: int, trial: Trial) -> InputPlan | None:
        try:
            return setup_trial(self.compileds[i], self.models[i], trial, self.dt)
        except (ValueError, KeyError, TypeError) as exc:
            self.error[i] = f"trial {i}: {exc}"
            # a failed trial's world still steps (worlds cannot be left out): keep it harmless
            self.models[i] = copy.copy(self.compiled.model)
            return None

    def _restore(self, host: mujoco.MjModel, trials: Sequence[Trial]) -> None:
        """Each world's initial state (the build keyframe, or the trial's own)."""
        fields = ("qpos", "qvel", "act", "qacc_warmstart")
        rows: dict[str, list[np.ndarray]] = {f: [] for f in fields}
        times = []
        data = mujoco.MjData(host)
        for model, trial in zip(self.models, trials, strict=True):
            mujoco.mj_resetDataKeyframe(host, data, host.key(BUILD_KEY).id)
            # the trial's own build pose (a recompiled structure may stand otherwise)
            data.qpos[:] = model.key(BUILD_KEY).qpos
            data.act[:] = model.key(BUILD_KEY).act
            if trial.initial_state is not None and trial.initial_state.shape == (
                    mujoco.mj_stateSize(host, _STATE),):
                mujoco.mj_setState(host, data, trial.initial_state, _STATE)
            for f in fields:
                rows[f].append(getattr(data, f).copy())
            times.append(data.time)
        for f in fields:
            getattr(self.d, f).assign(np.stack(rows[f]))
        self.d.time.assign(np.array(times))
        self.steps = np.rint(np.array(times) / self.dt).astype(np.int64)

    # -- stepping ----------------------------------------------------------------------------

    def _groups(self) -> tuple[np.ndarray, list[int]]:
        """Each world's input group and each group's first world: worlds that share a gait,
        loads and clock (:meth:`InputPlan.sharing_key`) share their rows, computed and held
        once; failed trials (no plan) share one group of zeros."""
        keys: dict[tuple[object, ...], int] = {}
        group = np.empty(len(self.plans), dtype=np.int64)
        for i, plan in enumerate(self.plans):
            key = ("failed",) if plan is None else (int(self.steps[i]), *plan.sharing_key())
            group[i] = keys.setdefault(key, len(keys))
        first = [int(i) for i in np.unique(group, return_index=True)[1]]
        return group, first

    def _control(self, count: int) -> None:
        """Stages every group's inputs for the next ``count`` steps (all worlds step on
        together, so a group's worlds stay on one clock)."""
        out = self.inputs.staging(count)
        nu = self.compiled.model.nu
        for g, i in enumerate(self.leaders):
            plan = self.plans[i]
            out[g, :, :nu] = 0.0 if plan is None else plan.control(int(self.steps[i]), count)

    def _advance(self, nstep: int) -> None:
        """Steps every world ``nstep`` steps on its held inputs and waits for them."""
        self._start(nstep)
        self._finish(nstep)

    def _start(self, nstep: int) -> None:
        """Launches ``nstep`` steps of every world on its held inputs, without waiting: a
        replay of the captured launches where there are (a record interval, or a part of a
        watched one), else one launch sequence per step."""
        import warp as wp

        if self.inputs.left() < nstep:
            rows = self.inputs.next_rows(nstep)
            self._control(rows)
            self.inputs.load(rows)
        if self.inputs.device.is_cuda:
            graph = self._graphs.get(nstep)
            if graph is None:
                with wp.ScopedCapture() as capture:
                    self._launch(nstep)
                graph = self._graphs[nstep] = capture.graph
            wp.capture_launch(graph)
        else:
            self._launch(nstep)

    def _finish(self, nstep: int) -> None:
        """Waits for the launched steps and books them."""
        import warp as wp

        wp.synchronize()
        self.inputs.consumed(nstep)
        self.steps += nstep

    def _launch(self, nstep: int) -> None:
        for _ in range(nstep):
            self.inputs.apply(self.d.ctrl)
            self._step(self.m, self.d)

    def run(self, n_samples: int, duration: float,
            progress: Callable[[float, float], None] | None, fresh: bool) -> None:
        import warp as wp

        from tensim.sim._warp_inputs import HeldInputs

        self.samples = SampleBuffers.empty(self.compiled, n_samples + 1, (len(self.trials),))
        self.n_samples = n_samples
        self.forces = ForceHistory(len(self.trials), prestress_band(self.compiled.structure))
        self.energy = Energy(self.compiled)
        allowance = max((self.energy.load_allowance(t.loads) for t in self.trials),
                        default=0.0)
        self.energies = EnergyHistory(len(self.trials), self.energy.scale + allowance)
        group, self.leaders = self._groups()
        self.pipeline = wp.get_device().is_cuda or PIPELINE_ON_CPU
        self.inputs = HeldInputs(group, self.compiled.model.nu, self.record_steps,
                                 n_samples * self.record_steps + int(fresh))
        if fresh:
            self._advance(1)  # the motor update at t = 0
        else:
            import mujoco_warp as mjw

            mjw.forward(self.m, self.d)
        record_loop(self, n_samples, self.record_steps, self.dt, duration, progress)

    # the back-end of record_loop: every world steps (worlds cannot be left out); failed
    # trials are no longer sampled or checked

    def advance(self, k: int, nstep: int) -> bool:
        if self._ahead:  # launched by take(), while the host stored the last sample
            self._ahead = False
            self._finish(nstep)
            return any(e is None for e in self.error)
        if not watched(k, self.n_samples, nstep):
            self._advance(nstep)
            return any(e is None for e in self.error)
        for count, push in split_steps(nstep):  # the last steps' cable forces, for ringing
            self._advance(count)
            if push:
                self.forces.push(slice(None),
                                 self.d.actuator_force.numpy()[:, :self.compiled.n_cables])
        return any(e is None for e in self.error)

    def take(self) -> None:
        """Samples every live world. On a CUDA device it then launches the next record
        interval before storing the sample (unless that interval is watched for ringing or
        there is none), so the GPU steps while the host stores and checks: the state the
        check reads is copied with the sample."""
        live = np.array([e is None for e in self.error])
        k = int(self.taken) - 1  # the record this sample ends (-1: the first sample)
        self.taken += 1
        names = ("ten_length", "ten_velocity", "act", "ctrl", "xpos", "xquat", "subtree_com")
        host = {name: self._host(name) for name in names}
        ahead = (self.pipeline and k + 1 < self.n_samples
                 and not watched(k + 1, self.n_samples, self.record_steps))
        if ahead:
            self.state = {**{name: self._host(name)
                             for name in ("qvel", "actuator_force", "qacc", "qpos", "overflow")},
                          **host}
            self._start(self.record_steps)
            self._ahead = True
        else:
            self.state = None
        if live.all() and (self.count == self.count[0]).all():  # the usual case: no gathers
            self.samples.put(slice(None), int(self.count[0]),
                             sample_time(self.steps * self.dt, self.dt), host,
                             self.compiled.index)
            self.count += 1
            return
        fields = {name: value[live] for name, value in host.items()}
        time = sample_time(self.steps[live] * self.dt, self.dt)  # the worlds' clocks
        self.samples.put(np.flatnonzero(live), self.count[live], time, fields,
                         self.compiled.index)
        self.count[live] += 1

    def _host(self, name: str) -> np.ndarray:
        """A host copy of the worlds' MjData field ``name`` (on the CPU device, where
        ``numpy()`` is a view of the device's memory, copied when the next steps may run
        before it is read)."""
        value = getattr(self.d, name).numpy()
        return value.copy() if self.pipeline and not self.inputs.device.is_cuda else value

    def _read(self, name: str) -> np.ndarray:
        """The worlds' field ``name`` as of the last sample: from the copy taken with it
        when the next steps are already running, else from the device."""
        return self.state[name] if self.state is not None else getattr(self.d, name).numpy()

    def check(self) -> None:
        """The stability check of the CPU engines; MuJoCo Warp does not check accelerations
        itself, so the check applies MuJoCo's rule to ``qacc``."""
        n = self.compiled.n_cables
        qvel, force = self._read("qvel"), self._read("actuator_force")
        bad_acc = bad_acceleration(self._read("qacc"))
        fine = stable(qvel, force[:, :n], bad_acc, self.limits)
        for i in np.flatnonzero(~fine):
            if self.error[i] is not None:
                continue
            d = mujoco.MjData(self.compiled.model)
            d.qvel[:], d.actuator_force[:] = qvel[i], force[i]
            time = float(self.samples.time[i, self.count[i] - 1])
            self.error[i] = f"trial {i}: " + diagnose(self.compiled.model, d,
                                                      self.compiled.index, self.limits, time,
                                                      bool(bad_acc[i]), reset=False)
        fresh = self.forces.fresh  # the energy on the ringing check's schedule
        ring = self.forces.ringing(slice(None))
        for i in np.flatnonzero(fine & ring.any(axis=1)):
            if self.error[i] is None:
                time = float(self.samples.time[i, self.count[i] - 1])
                self.error[i] = f"trial {i}: " + ring_message(
                    self.compiled.index.cables, ring[i], self.forces.force[i], time, self.dt)
        if fresh:
            self._check_energy(qvel, fine)
        self._check_room(fine)  # after: a diverging world also overflows; instability first
        if self._contact is not None:
            self._check_contact(np.flatnonzero(fine))

    def _check_energy(self, qvel: np.ndarray, fine: np.ndarray) -> None:
        """Fails the worlds whose mechanical energy runs away (see
        :func:`tensim.sim._loop.energy_growing`), as the CPU engines do."""
        parts = [qvel, *(self._read(name) for name in ("xpos", "ten_length", "act"))]
        growing = self.energies.push(slice(None), self.energy.total(*parts)) & fine
        for i in np.flatnonzero(growing):
            if self.error[i] is None:
                time = float(self.samples.time[i, self.count[i] - 1])
                what = self.energy.largest(*(part[i:i + 1] for part in parts))
                self.error[i] = f"trial {i}: " + energy_message(
                    what, self.energies.energy[i] - self.energies.lowest[i], time, self.dt,
                    self.energy.remedy)

    def _check_room(self, fine: np.ndarray) -> None:
        """Fails the worlds MuJoCo Warp ran out of room for (contacts or constraint rows
        dropped: their physics is wrong from then on)."""
        overflow = self._read("overflow")
        for i in np.flatnonzero(overflow != 0):
            fine[i] = False
            if self.error[i] is None:
                time = float(self.samples.time[i, self.count[i] - 1])
                self.error[i] = (f"trial {i}: at t = {time:.3f} s MuJoCo Warp ran out of room "
                                 f"for contacts or constraint rows (overflow flags "
                                 f"{int(overflow[i])}); rerun with more (njmax, nconmax)")

    def _check_contact(self, worlds: np.ndarray) -> None:
        """Fails the worlds whose contact cables went through an obstacle: each world's
        positions and activations on a CPU copy of its model, checked as the CPU engines do."""
        assert self._contact is not None and self._scratch is not None
        qpos, act = self._read("qpos"), self._read("act")
        for i in map(int, worlds):
            if self.error[i] is not None:
                continue
            model, d = self.models[i], self._scratch
            d.qpos[:], d.act[:] = qpos[i], act[i]
            mujoco.mj_fwdPosition(model, d)
            problem = contact_problem(self._contact, model, d)
            if problem is not None:
                time = float(self.samples.time[i, self.count[i] - 1])
                self.error[i] = f"trial {i}: " + tunnel_message(time, problem)

    def results(self, duration: float, wall: float) -> list[TrialResult]:
        return trial_results(self.samples, self.count, self.models, self.error,
                             self.compiled.index.cable_peaks(self.d.act.numpy()),
                             self.compiled.index, self.dt, duration, wall)

