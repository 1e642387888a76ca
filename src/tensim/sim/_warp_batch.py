"""Batches on MuJoCo Warp: one world per trial, on a GPU or on Warp's CPU device.

The same trials as :func:`tensim.sim.run_batch`: each world gets its trial's law parameters
and friction as per-world model fields, its commands through ``ctrl``, and is recorded into the
same channels. The cable law runs as a Warp kernel in MuJoCo Warp's step
(:mod:`tensim.sim._warp_law`). MuJoCo Warp computes in float32 and its constraint solver is
its own, so a world agrees with the CPU engine to a tolerance, not bit for bit (see
``docs/gpu.md``). Not yet here: per-trial compiled models and mass scaling (they need MuJoCo
Warp's ``set_const`` per world), and CUDA graph capture of the record loop.
"""

from __future__ import annotations

import copy
import logging
import time as _time
from collections.abc import Callable, Sequence

import mujoco
import numpy as np

from tensim.model import BUILD_KEY, CompiledModel
from tensim.sim._contact_check import ContactCheck
from tensim.sim._drive import InputPlan
from tensim.sim._loop import (
    RING_STEPS,
    ForceHistory,
    StabilityLimits,
    bad_acceleration,
    contact_problem,
    prestress_band,
    record_loop,
    ring_message,
    sample_time,
    stable,
    tunnel_message,
    watched,
)
from tensim.sim._samples import SampleBuffers
from tensim.sim._simulation import diagnose
from tensim.sim._trials import PhysicsScale, Trial, TrialResult, setup_trial, trial_results

_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
_PER_WORLD = ("actuator_dynprm", "actuator_biasprm", "geom_friction")


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
                   device: str | None = None, njmax: int = 256, nconmax: int = 64
                   ) -> list[TrialResult]:
    """:func:`tensim.sim.run_batch` with ``backend="warp"`` (see there; ``compiled`` already
    has every trial's load nodes).

    Args:
        device: the Warp device (None: Warp's default, a GPU when there is one).
        njmax, nconmax: constraint rows and contacts MuJoCo Warp allocates per world.

    Raises:
        ImportError: MuJoCo Warp is not installed.
        ValueError: a trial the Warp backend cannot run (its own compiled model, a mass
            scale, a mix of fresh and restored initial states).
    """
    if not warp_available():
        raise ImportError("the warp backend needs MuJoCo Warp: pip install 'tensim[gpu]'")
    import warp as wp

    for i, trial in enumerate(trials):
        if trial.compiled is not None and trial.compiled is not compiled:
            raise ValueError(f"trial {i}: per-trial compiled models are not supported on the "
                             "warp backend; use PhysicsScale multipliers")
        if trial.physics.mass != PhysicsScale().mass:
            raise ValueError(f"trial {i}: mass scaling is not supported on the warp backend")
    restored = {t.initial_state is not None for t in trials}
    if len(restored) > 1:
        raise ValueError("on the warp backend either every trial or none has an initial state")
    with wp.ScopedDevice(device):
        run = _WarpRun(compiled, trials, record_steps, limits, njmax, nconmax)
        started = _time.perf_counter()
        run.run(n_samples, duration, progress, fresh=not restored.pop())
        wall = _time.perf_counter() - started
    return run.results(duration, wall)


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
        self.models = [copy.copy(compiled.model) for _ in trials]
        self.plans = [self._setup(i, t) for i, t in enumerate(trials)]
        host = warp_host_model(compiled.model)
        data = mujoco.MjData(host)
        mujoco.mj_resetDataKeyframe(host, data, host.key(BUILD_KEY).id)
        self.m = mjw.put_model(host, batch_sizes=dict.fromkeys(_PER_WORLD, n))
        for name in _PER_WORLD:
            getattr(self.m, name).assign(np.stack([getattr(m, name) for m in self.models]))
        install_warp_law(self.m)
        self.d = mjw.put_data(host, data, nworld=n, nconmax=nconmax, njmax=njmax)
        self._restore(host, trials)
        self._step = mjw.step
        self.samples = SampleBuffers.empty(compiled, 0, (n,))
        self.count = np.zeros(n, dtype=int)
        self.steps = np.zeros(n, dtype=np.int64)
        self._contact = ContactCheck(compiled) \
            if any(c.contact for c in compiled.structure.cables) else None
        self._scratch = mujoco.MjData(compiled.model) if self._contact is not None else None

    def _setup(self, i: int, trial: Trial) -> InputPlan | None:
        try:
            return setup_trial(self.compiled, self.models[i], trial, self.dt)
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
        for trial in trials:
            mujoco.mj_resetDataKeyframe(host, data, host.key(BUILD_KEY).id)
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

    def _control(self, first: np.ndarray, count: int) -> np.ndarray:
        """(n, count, nu) every world's inputs; failed trials hold zeros."""
        out = np.zeros((len(self.trials), count, self.compiled.model.nu))
        for i, plan in enumerate(self.plans):
            if plan is not None:
                out[i] = plan.control(int(first[i]), count)
        return out

    def _advance(self, control: np.ndarray, watch_from: int | None = None) -> None:
        """Steps every world through ``control``'s rows, one ``mjw.step`` per step; keeps the
        cable forces of the steps from ``watch_from`` on for the ringing check."""
        import warp as wp

        ctrl, n = self.d.ctrl, self.compiled.n_cables
        for k in range(control.shape[1]):
            if k == 0 or (control[:, k] != control[:, k - 1]).any():
                ctrl.assign(control[:, k])
            self._step(self.m, self.d)
            if watch_from is not None and k >= watch_from:
                self.forces.push(slice(None), self.d.actuator_force.numpy()[:, :n])
        wp.synchronize()
        self.steps += control.shape[1]

    def run(self, n_samples: int, duration: float,
            progress: Callable[[float, float], None] | None, fresh: bool) -> None:
        self.samples = SampleBuffers.empty(self.compiled, n_samples + 1, (len(self.trials),))
        self.n_samples = n_samples
        self.forces = ForceHistory(len(self.trials), prestress_band(self.compiled.structure))
        if fresh:
            self._advance(self._control(self.steps, 1))  # the motor update at t = 0
        else:
            import mujoco_warp as mjw

            mjw.forward(self.m, self.d)
        record_loop(self, n_samples, self.record_steps, self.dt, duration, progress)

    # the back-end of record_loop: every world steps (worlds cannot be left out); failed
    # trials are no longer sampled or checked

    def advance(self, k: int, nstep: int) -> bool:
        watch = max(0, nstep - RING_STEPS) if watched(k, self.n_samples, nstep) else None
        self._advance(self._control(self.steps, nstep), watch)
        return any(e is None for e in self.error)

    def take(self) -> None:
        live = np.array([e is None for e in self.error])
        fields = {name: getattr(self.d, name).numpy()[live] for name in
                  ("ten_length", "ten_velocity", "act", "ctrl", "xpos", "xquat", "subtree_com")}
        time = sample_time(self.steps[live] * self.dt, self.dt)  # the worlds' clocks
        self.samples.put(np.flatnonzero(live), self.count[live], time, fields,
                         self.compiled.index)
        self.count[live] += 1

    def check(self) -> None:
        """The stability check of the CPU engines; MuJoCo Warp does not check accelerations
        itself, so the check applies MuJoCo's rule to ``qacc``."""
        n = self.compiled.n_cables
        qvel, force = self.d.qvel.numpy(), self.d.actuator_force.numpy()
        bad_acc = bad_acceleration(self.d.qacc.numpy())
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
        ring = self.forces.ringing(slice(None))
        for i in np.flatnonzero(fine & ring.any(axis=1)):
            if self.error[i] is None:
                time = float(self.samples.time[i, self.count[i] - 1])
                self.error[i] = f"trial {i}: " + ring_message(
                    self.compiled.index.cables, ring[i], self.forces.force[i], time, self.dt)
        if self._contact is not None:
            self._check_contact(np.flatnonzero(fine))

    def _check_contact(self, worlds: np.ndarray) -> None:
        """Fails the worlds whose contact cables went through an obstacle: each world's
        positions and activations on a CPU copy of its model, checked as the CPU engines do."""
        assert self._contact is not None and self._scratch is not None
        qpos, act = self.d.qpos.numpy(), self.d.act.numpy()
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
                             self.compiled.index.cable_act(self.d.act.numpy(), 1),
                             self.compiled.index, self.dt, duration, wall)
