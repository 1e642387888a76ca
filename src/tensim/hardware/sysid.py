"""System identification: fit named model parameters so simulated tensions match the logs.

The residual is simulated reading minus logged tension [N] at every logged sample of every
cable of every log. Physical parameters rebuild the structure and re-simulate each log;
measurement parameters only reshape the simulated signals, so the optimizer's finite
differences over them reuse a cached simulation. The optimizer is scipy's bounded
trust-region least squares on the unit cube of the bounds, with a finite-difference step large
enough to step over the small, irregular changes that contact and motor limits cause; the
uncertainty comes from the Jacobian and the residuals at the solution, allowing for their
correlation over cables and time and for model error (:mod:`tensim.hardware.uncertainty`).
A fit is judged on validation samples and is replaced by
the nominal model when it is worse there. A Jacobian's perturbed models (each a
recompiled structure) are simulated together, one batch per log, on the batch engine's threads.
(MuJoCo's ``mujoco.sysid`` toolbox makes the same physical/measurement split; tensim keeps its
own driver because its physical parameters change the structure description and recompile.)
"""

from __future__ import annotations

import collections
import dataclasses
import os
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from scipy import optimize

from tensim.control import ControllerConfig
from tensim.hardware.checklog import validate_log
from tensim.hardware.compare import Comparison, compare_tensions
from tensim.hardware.holdout import (
    MIN_EXCITATION,
    default_hold_out,
    hold_out_excitation,
)
from tensim.hardware.loads import loads_for
from tensim.hardware.logs import HardwareLog, check_items
from tensim.hardware.parameters import (
    SysidSpace,
    apply_measurement,
    apply_physical,
    apply_world,
    check_world,
)
from tensim.hardware.replay import replay_config
from tensim.hardware.sensor import SensorModel
from tensim.hardware.uncertainty import LOG_STRIDE, FitErrors, fit_stderr, interval_factor
from tensim.model import WorldOptions, compile_structure
from tensim.sim import SimulationError, TimeSeries, Trial, run_batch
from tensim.structure import Structure

_CACHE_SIZE = 16
DEFAULT_PARAMS = ("stiffness", "friction", "offset", "delay")
MEASUREMENT_STEP = 1e-3
"""Finite-difference step of a measurement parameter, as a fraction of its bound range."""


class SysidError(ValueError):
    """A fit the logs cannot support: an uninformed parameter, or windows outside a log."""


@dataclasses.dataclass(frozen=True)
class SysidSettings:
    """Budgets and steps of the fit.

    Attributes:
        max_simulations: stop after about this many simulations of the log set.
        diff_step: finite-difference step of a physical parameter, as a fraction of its bound
            range (measurement parameters take :data:`MEASUREMENT_STEP`).
        max_offset: largest time offset the cross-correlation tries [s].
        margin: simulated time past each log's end [s].
        skip: leave each log's first seconds out of the residual [s].
        threads: threads of the batch engine that runs the perturbed models (0: every core).
        fit_window: (start, end) of the samples the fit uses, from each log's start [s]
            (None: the samples after ``skip`` less a held-out quarter placed where the logs
            move (:func:`~tensim.hardware.holdout.default_hold_out`), or with a validation
            window, the samples before it, or after it if it starts at 0).
        validate_window: (start, end) of the samples that judge the fit [s] (None: samples
            the fit does not use, after or before the fit window; only a fit window over
            the whole log leaves none, and the verdict is then on the fitted data).
        force: keep a fit that is worse than the nominal model on the validation samples.
    """

    max_simulations: int = 60
    diff_step: float = 0.05
    max_offset: float = 0.5
    margin: float = 0.5
    skip: float = 0.0
    threads: int = 0
    fit_window: tuple[float, float] | None = None
    validate_window: tuple[float, float] | None = None
    force: bool = False

    def __post_init__(self) -> None:
        for name in ("fit_window", "validate_window"):
            window = getattr(self, name)
            if window is not None and not (len(window) == 2 and window[0] < window[1]):
                raise ValueError(f"{name}: expected (start, end) with start < end [s], "
                                 f"got {window!r}")


@dataclasses.dataclass(frozen=True)
class SysidResult:
    """A finished fit.

    Attributes:
        space: the fitted parameters (names, bounds, starting values).
        fitted: (n,) fitted values.
        stderr: (n,) standard errors: the larger of the independent-sample and per-reading
            errors times sqrt(samples / effective samples) of the residuals' correlation time,
            and each parameter's long-run score error
            (:func:`~tensim.hardware.uncertainty.fit_stderr`; inf: not determined).
        naive_stderr: (n,) the textbook s^2 (J^T J)^-1 errors, which assume independent
            residuals (kept for comparison; too small on autocorrelated residuals).
        before, after: per log, the comparison with the nominal model (time offset
            estimated) and with the fitted one.
        structure: the fitted structure.
        sensor: the fitted measurement model.
        vstar_scale: the fitted (or nominal) V* scale.
        simulations: simulations run.
        optimizer: scipy's result (x in unit coordinates).
        validation: RMSE [N] on the validation samples of the nominal and the fitted model,
            the windows, and the validation samples' excitation as a share of the logs'
            (``excited``: enough to tell fits apart; ``nominal_rmse_N``, ``fitted_rmse_N``,
            ...).
        kept_nominal: the fit was worse than nominal on the validation samples, so
            ``structure``, ``sensor`` and ``vstar_scale`` are the nominal ones.
        world: the fitted world options (torsional and rolling friction; else as given).
        uncertainty: how ``stderr`` was found: the samples, the effective samples, each
            log's correlation time [s], the factor and each estimate's errors.
    """

    space: SysidSpace
    fitted: np.ndarray
    stderr: np.ndarray
    naive_stderr: np.ndarray
    before: tuple[Comparison, ...]
    after: tuple[Comparison, ...]
    structure: Structure
    sensor: SensorModel
    vstar_scale: float
    simulations: int
    optimizer: optimize.OptimizeResult
    validation: dict[str, Any] = dataclasses.field(default_factory=dict)
    kept_nominal: bool = False
    world: WorldOptions | None = None
    uncertainty: dict[str, Any] = dataclasses.field(default_factory=dict)

    def parameters(self) -> dict[str, dict[str, Any]]:
        """name -> nominal, start, fitted, stderr, 95 % interval half-width, bounds, unit.

        A refused fit (``kept_nominal``) has no interval (``ci95`` None): its values are
        reported, but they are not the model written, and no claim is made on them."""
        from tensim.hardware.parameters import definition

        out = {}
        for k, p in enumerate(self.space.parameters):
            d = definition(p.name)
            out[p.name] = {"unit": d.unit, "kind": d.kind,
                           "nominal": float(self.space.structure_values()[k]),
                           "start": p.bounds.nominal, "fitted": float(self.fitted[k]),
                           "stderr": _finite(self.stderr[k]),
                           "ci95": None if self.kept_nominal
                           else _finite(interval_factor(len(self.before))
                                        * self.stderr[k]),
                           "naive_stderr": _finite(self.naive_stderr[k]),
                           "bounds": [p.bounds.low, p.bounds.high]}
        return out

    def summary(self) -> dict[str, Any]:
        """JSON-ready: parameters, errors before and after per log, and their change."""
        before = [c.summary() for c in self.before]
        after = [c.summary() for c in self.after]
        return {"parameters": self.parameters(), "simulations": self.simulations,
                "validation": self.validation, "kept_nominal": self.kept_nominal,
                "uncertainty": self.uncertainty,
                "optimizer": {"status": int(self.optimizer.status),
                              "message": str(self.optimizer.message),
                              "cost": float(self.optimizer.cost)},
                "rmse_before_N": _mean_of(before, "rmse_N"),
                "rmse_after_N": _mean_of(after, "rmse_N"),
                "max_system_tension_error_before_percent": _mean_of(
                    before, "max_system_tension_error_percent", absolute=True),
                "max_system_tension_error_after_percent": _mean_of(
                    after, "max_system_tension_error_percent", absolute=True),
                "max_settled_system_tension_error_before_percent": _mean_of(
                    before, "max_settled_system_tension_error_percent", absolute=True),
                "max_settled_system_tension_error_after_percent": _mean_of(
                    after, "max_settled_system_tension_error_percent", absolute=True),
                "logs": [{"before": b, "after": a} for b, a in zip(before, after, strict=True)]}


def _finite(value: float) -> float | None:
    return float(value) if np.isfinite(value) else None


def _mean_of(summaries: list[dict[str, Any]], key: str, absolute: bool = False) -> float | None:
    values = [abs(s[key]) if absolute else s[key] for s in summaries if s[key] is not None]
    return round(float(np.mean(values)), 6) if values else None


def _keep(c: Comparison, window: tuple[float, float] | None,
          hold_out: tuple[float, float] | None = None) -> np.ndarray:
    """(S, n) the logged samples inside ``window`` [s] (None: all) and not in ``hold_out``
    (a sample on a boundary the two windows share is a validation sample)."""
    keep = np.isfinite(c.hardware)
    if window is not None:
        keep &= ((c.time >= window[0]) & (c.time <= window[1]))[:, None]
    if hold_out is not None:
        keep &= ~((c.time >= hold_out[0]) & (c.time <= hold_out[1]))[:, None]
    return keep


class _Problem:
    """Residuals of parameter vectors over the logs, with a cache of simulations."""

    def __init__(self, space: SysidSpace, logs: Sequence[HardwareLog], config: ControllerConfig,
                 sensor: SensorModel, world: WorldOptions | None, settings: SysidSettings,
                 progress: Callable[[float, float], None] | None):
        self.space, self.logs, self.config, self.sensor = space, logs, config, sensor
        self.world, self.settings, self.progress = world, settings, progress
        self.cache: collections.OrderedDict[tuple[float, ...], list[TimeSeries]] = \
            collections.OrderedDict()
        self.simulations = 0
        self.offsets = [0.0] * len(logs)  # per-log lag used while 'delay' is not fitted

    def simulate(self, values: np.ndarray, snap: bool = True) -> list[TimeSeries]:
        """Each log replayed with the physical parameters in ``values`` (cached).

        With ``snap`` the physical values are first rounded to the space's grid (see
        :meth:`SysidSpace.snap`); the nominal model is simulated exactly as given.
        """
        return self.simulate_many([values], snap)[0]

    def simulate_many(self, values: Sequence[np.ndarray], snap: bool = True
                      ) -> list[list[TimeSeries]]:
        """:meth:`simulate` for several parameter vectors, the uncached ones as one batch per
        log on the batch engine's threads."""
        values = [self.space.snap(v) if snap else v for v in values]
        keys = [self.space.physical_key(v) for v in values]
        todo = {k: v for k, v in zip(keys, values, strict=True) if k not in self.cache}
        if todo:
            runs = self._run(list(todo.values()))
            for key, run in zip(todo, runs, strict=True):
                self.cache[key] = run
        for key in keys:
            self.cache.move_to_end(key)
        out = [self.cache[key] for key in keys]
        while len(self.cache) > max(_CACHE_SIZE, len(set(keys))):
            self.cache.popitem(last=False)
        return out

    def _run(self, values: list[np.ndarray]) -> list[list[TimeSeries]]:
        """Replays every log for every parameter vector: per vector, a list over the logs."""
        named = [self.space.as_dict(v) for v in values]
        compiled = [compile_structure(apply_physical(self.space.structure, n),
                                      apply_world(self.world, n)) for n in named]
        out: list[list[TimeSeries]] = [[] for _ in values]
        for log in self.logs:
            check_items(log, compiled[0].structure)
            loads = loads_for(log, compiled[0].structure)
            trials = [Trial(replay_config(log, self.config, vstar_scale=n.get("vstar_scale", 1.0),
                                          margin=self.settings.margin
                                          ).build(c.model.opt.timestep), loads=loads,
                            compiled=c)
                      for n, c in zip(named, compiled, strict=True)]
            results = run_batch(compiled[0], trials, self.horizon(log) + self.settings.margin,
                                threads=self.settings.threads or os.cpu_count() or 1)
            for k, trial in enumerate(results):
                if trial.result is None:
                    raise SimulationError(f"replaying {log.source}: {trial.error}")
                series = trial.result.trajectory
                out[k].append(TimeSeries(series.time, {c: series[c] for c in series.channels
                                                       if c.startswith("tension/")}))
            self.simulations += len(trials)
            if self.progress is not None:
                self.progress(self.simulations, self.settings.max_simulations)
        return out

    def horizon(self, log: HardwareLog) -> float:
        """How much of ``log`` to simulate: up to the last window's end [s]."""
        fit, validate = self.settings.fit_window, self.settings.validate_window
        if fit is None:
            return log.duration
        return min(log.duration, max(fit[1], validate[1] if validate else fit[1]))

    def span(self, log: HardwareLog) -> tuple[float, float]:
        """The samples of ``log`` the comparisons cover: from ``skip`` (or the first window's
        start) to the simulated horizon [s], so no sample past the simulation is scored."""
        windows = [w for w in (self.settings.fit_window, self.settings.validate_window) if w]
        start = min(w[0] for w in windows) if windows else 0.0
        return max(start, self.settings.skip), self.horizon(log)

    def comparisons(self, values: np.ndarray) -> list[Comparison]:
        """Per log, the logged tensions against the simulated readings for ``values`` (on the
        samples of :meth:`span`)."""
        named = self.space.as_dict(values)
        sensor = apply_measurement(self.sensor, named)
        return [compare_tensions(log, run, sensor=sensor,
                                 offset=sensor.delay if "delay" in named else self.offsets[i],
                                 skip=self.span(log)[0], end=self.span(log)[1])
                for i, (log, run) in enumerate(zip(self.logs, self.simulate(values),
                                                   strict=True))]

    def residuals(self, unit: np.ndarray, window: tuple[float, float] | None = None
                  ) -> np.ndarray:
        """Simulated minus logged tension [N] at every logged sample in ``window`` (default:
        the fit samples), all logs; ordered by log, then time, then cable."""
        parts = []
        for c in self.comparisons(self.space.from_unit(unit)):
            parts.append((c.simulated - c.hardware)[self.keep(c, window)])
        return np.concatenate(parts)

    def keep(self, c: Comparison, window: tuple[float, float] | None = None) -> np.ndarray:
        """(S, n) the samples of ``window``, or by default the fit samples: the fit window's,
        less any validation sample."""
        if window is not None:
            return _keep(c, window)
        return _keep(c, self.settings.fit_window, self.settings.validate_window)

    def sample_cells(self, unit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For each entry of :meth:`residuals`, a label of its (log, sample time) row and the
        index of its cable."""
        labels, cables = [], []
        for i, c in enumerate(self.comparisons(self.space.from_unit(unit))):
            keep = self.keep(c)
            rows = np.broadcast_to(np.arange(c.time.size)[:, None], c.hardware.shape)
            labels.append(i * LOG_STRIDE + rows[keep])
            cables.append(np.broadcast_to(np.arange(len(c.cables))[None, :],
                                          c.hardware.shape)[keep])
        return np.concatenate(labels), np.concatenate(cables)

    def periods(self) -> np.ndarray:
        """(logs,) each log's time between tension samples [s] (the median spacing)."""
        times = [log.samples("tension")[0] for log in self.logs]
        return np.array([float(np.median(np.diff(t))) if t.size > 1 else 1.0 for t in times])

    def errors(self, unit: np.ndarray) -> tuple[FitErrors, np.ndarray]:
        """The standard errors of a fit ending at ``unit`` (unit coordinates), from the
        central-difference Jacobian and the residuals there; and those residuals [N]."""
        jac, residual = self.jacobian(unit, central=True), self.residuals(unit)
        return fit_stderr(jac, residual, *self.sample_cells(unit), self.periods()), residual

    def jacobian(self, unit: np.ndarray, central: bool = False) -> np.ndarray:
        """Finite differences in unit coordinates.

        A physical column takes a fixed, fairly large step of ``diff_step`` of its bound
        range, which steps over the small irregular changes that contacts and motor limits
        make in a simulated tension: forward while fitting, central (two more simulations
        per physical parameter) with ``central``, for the uncertainty at the solution, where a
        one-sided step of that size would tilt each column by the residuals' curvature. A
        measurement column reshapes the cached run, so it costs no simulation and has no
        contact noise: a central difference over :data:`MEASUREMENT_STEP` of its range (a
        large step would take the delay's slope over 20 ms of a 10 ms-sampled log).
        """
        steps, points, backs = [], [], []
        for k in range(unit.size):
            physical = bool(self.space.physical[k])
            step = self.settings.diff_step if physical else MEASUREMENT_STEP
            if unit[k] + step > 1.0:
                step = -step
            moved, back = unit.copy(), unit.copy()
            moved[k] += step
            back[k] -= step
            two_sided = (central or not physical) and 0.0 <= back[k] <= 1.0
            steps.append(step)
            points.append(moved)
            backs.append(back if two_sided else None)
        # every perturbed model at once, one batch per log
        self.simulate_many([self.space.from_unit(u) for u in
                            [unit, *points, *(b for b in backs if b is not None)]])
        base = self.residuals(unit)
        columns = [(self.residuals(moved) - base) / step if back is None
                   else (self.residuals(moved) - self.residuals(back)) / (2.0 * step)
                   for moved, step, back in zip(points, steps, backs, strict=True)]
        jac = np.stack(columns, axis=1)
        flat = [p.name for p, col in zip(self.space.parameters, jac.T, strict=True)
                if not np.any(col)]
        if flat:
            raise SysidError(f"the logs do not inform {flat}: changing them leaves every "
                             "simulated reading unchanged (an ill-posed fit); leave them out "
                             "of the parameters")
        return jac


def identify(logs: Sequence[HardwareLog], structure: Structure, config: ControllerConfig,
             names: Sequence[str] = DEFAULT_PARAMS, *,
             bounds: Mapping[str, tuple[float, float]] | None = None,
             start: Mapping[str, float] | None = None, sensor: SensorModel | None = None,
             world: WorldOptions | None = None, settings: SysidSettings | None = None,
             progress: Callable[[float, float], None] | None = None) -> SysidResult:
    """Fits the named parameters to one or more logs, and keeps the nominal model unless the
    fit is better on the validation samples (or ``settings.force``).

    Args:
        logs: hardware logs with tensions in N (convert ADC first).
        structure: the nominal robot.
        config: impedance laws (and the gait for logs without V*).
        names: parameters to fit (:data:`~tensim.hardware.parameters.DEFINITIONS`).
        bounds: name -> (low, high), replacing the defaults.
        start: name -> starting value (default: nominal; ``delay`` starts at the
            cross-correlation estimate where that is well posed).
        sensor: the fixed part of the measurement model (e.g. a known offset).
        world: world options.
        settings: budgets, steps and windows.
        progress: called as progress(simulations_done, budget).

    Raises:
        KeyError: an unknown parameter name.
        ValueError: bad bounds or start, or no logs.
        SysidError: a parameter the logs cannot inform (``vstar_scale`` without V*, or one
            that leaves every reading unchanged), or a window with no samples of some log.
    """
    if not logs:
        raise ValueError("system identification needs at least one log")
    for log in logs:
        validate_log(log)
    settings = _windows(settings or SysidSettings(), logs)
    _check_informed(logs, names, settings)
    try:
        check_world(names, world)
    except ValueError as err:
        raise SysidError(str(err)) from None
    start = dict(start or {})
    nominal = SysidSpace.build(structure, names, bounds=bounds, world=world)
    problem = _Problem(nominal, logs, config, sensor or SensorModel(), world, settings, progress)
    before = _nominal_comparisons(problem, nominal)
    problem.offsets = [c.offset_s for c in before]
    if "delay" in names and "delay" not in start:
        delay = nominal.parameters[list(names).index("delay")].bounds
        start["delay"] = float(np.clip(np.median(problem.offsets), delay.low, delay.high))
    space = SysidSpace.build(structure, names, bounds=bounds, start=start, world=world)
    problem.space = space
    physical = int(space.physical.sum())
    fit = optimize.least_squares(
        problem.residuals, space.to_unit(space.start), jac=problem.jacobian, bounds=(0.0, 1.0),
        method="trf", x_scale=1.0, max_nfev=max(3, settings.max_simulations // (physical + 1)))
    fitted = space.snap(space.from_unit(fit.x))  # the values the last runs simulated
    errors, _ = problem.errors(space.to_unit(fitted))
    scale = space.high - space.low
    stderr, naive = errors.stderr * scale, errors.naive * scale
    uncertainty = {
        "samples": int(errors.samples), "effective_samples": round(errors.effective, 3),
        "correlation_time_s": [round(t, 6) for t in errors.correlation_time],
        "factor": round(errors.factor, 6),
        **{f"{key}_stderr": {p.name: _finite(v * s) for p, v, s in
                             zip(space.parameters, values, scale, strict=True)}
           for key, values in (("naive", errors.naive), ("row", errors.row),
                               ("score", errors.score))}}
    validation = _validation(problem, nominal, space, fitted, before)
    kept = validation["fitted_rmse_N"] > validation["nominal_rmse_N"] and not settings.force
    named = nominal.as_dict(nominal.structure_values()) if kept else space.as_dict(fitted)
    return SysidResult(space, fitted, stderr, naive, tuple(before),
                       tuple(problem.comparisons(fitted)), apply_physical(structure, named),
                       apply_measurement(problem.sensor, named), named.get("vstar_scale", 1.0),
                       problem.simulations, fit, validation, kept, apply_world(world, named),
                       uncertainty)


def errors_at(logs: Sequence[HardwareLog], structure: Structure, config: ControllerConfig,
              values: Mapping[str, float], *, sensor: SensorModel | None = None,
              world: WorldOptions | None = None, settings: SysidSettings | None = None
              ) -> tuple[dict[str, float], FitErrors, float]:
    """The standard errors :func:`identify` would report for a fit that ended at ``values``
    (no fit is run): the Jacobian and the residuals at that point, on the fit samples.

    Args:
        logs, structure, config, sensor, world, settings: as :func:`identify`.
        values: parameter name -> value (the names are the parameters).

    Returns:
        Name -> standard error [the parameter's unit] (inf: not determined), the estimate's
        parts in unit coordinates, and the RMS of the residuals there [N].
    """
    for log in logs:
        validate_log(log)
    settings = _windows(settings or SysidSettings(), logs)
    space = SysidSpace.build(structure, list(values), start=values, world=world)
    problem = _Problem(space, logs, config, sensor or SensorModel(), world, settings, None)
    errors, residual = problem.errors(space.to_unit(space.snap(space.start)))
    scale = space.high - space.low
    return ({p.name: float(v * s) for p, v, s in
             zip(space.parameters, errors.stderr, scale, strict=True)}, errors,
            float(np.sqrt(np.mean(residual**2))))


def _windows(settings: SysidSettings, logs: Sequence[HardwareLog]) -> SysidSettings:
    """The fit and validation windows, clipped to the logs (an open end such as ``0:inf``
    ends with the longest log), with samples held out to judge the fit when no validation
    window is given: those after the fit window (or before it), or without a fit window a
    quarter of the logs placed where they move (the fit takes the rest: its window then
    holds the validation window, whose samples it leaves out). Only a fit window over the
    whole log leaves none (``on_fit_data``). A validation window alone fits on the samples
    before it (or after it, when it starts at 0): validation samples are never fitted unless
    asked for. Given windows that overlap are refused; a window past the logs' end is left
    as given, for :func:`_check_informed` to refuse.
    """
    end = max(log.duration for log in logs)
    start = settings.skip

    def clip(window: tuple[float, float] | None) -> tuple[float, float] | None:
        if window is None:
            return None
        clipped = (max(window[0], 0.0), min(window[1], end))
        # a window past the logs' end is left for _check_informed to refuse by name
        return clipped if clipped[0] < clipped[1] else window

    fit = clip(settings.fit_window)
    validate = clip(settings.validate_window)
    _check_windows(fit, validate)
    if validate is None and fit is None:
        fit, validate = (start, end), default_hold_out(logs, start, end)
    elif validate is None and fit is not None:
        if fit[1] < end:
            validate = (fit[1], end)
        elif fit[0] > start:
            validate = (start, fit[0])
    elif fit is None and validate is not None:
        fit = (0.0, validate[0]) if validate[0] > 0 else (validate[1], end)
    return dataclasses.replace(settings, fit_window=fit, validate_window=validate)


def _check_windows(fit: tuple[float, float] | None, validate: tuple[float, float] | None
                   ) -> None:
    """Refuses given fit and validation windows that share samples: that is no hold-out."""
    if fit is None or validate is None or not (fit[0] < validate[1] and validate[0] < fit[1]):
        return
    raise SysidError(f"--fit-window {fit[0]:g}:{fit[1]:g} and --validate-window "
                     f"{validate[0]:g}:{validate[1]:g} s overlap ({max(fit[0], validate[0]):g}-"
                     f"{min(fit[1], validate[1]):g} s): the fit would see the validation "
                     "samples, so the verdict would be no hold-out; expected disjoint windows "
                     "(their ends may touch), or no --validate-window to judge the fit on its "
                     "own samples")


def _check_informed(logs: Sequence[HardwareLog], names: Sequence[str],
                    settings: SysidSettings) -> None:
    """Refuses parameters and windows the logs cannot inform (before any simulation)."""
    if "vstar_scale" in names:
        without = [log.source for log in logs if not log.cables("vstar")]
        if without:
            raise SysidError(f"vstar_scale scales the logged V*, but {without} log no V* "
                             "('vstar_mps/<cable>' columns); leave vstar_scale out")
    for label, window in (("--fit-window", settings.fit_window),
                          ("--validate-window", settings.validate_window)):
        for log in logs:
            if window is None:
                continue
            times, _ = log.samples("tension")
            inside = (times >= max(window[0], settings.skip)) & (times <= window[1])
            if not inside.any():
                raise SysidError(f"{log.source}: {label} {window[0]:g}:{window[1]:g} s holds "
                                 f"no tension sample; the log's samples span "
                                 f"{times[0]:g}-{times[-1]:g} s from its start")


def _validation(problem: _Problem, nominal: SysidSpace, space: SysidSpace,
                fitted: np.ndarray, before: Sequence[Comparison]) -> dict[str, Any]:
    """RMSE of the nominal and the fitted model on the validation samples [N]."""
    window = problem.settings.validate_window or problem.settings.fit_window
    excited = 1.0 if window is None else hold_out_excitation(problem.logs, window)
    nominal_residual = np.concatenate([(c.simulated - c.hardware)[problem.keep(c, window)]
                                       for c in before])
    fitted_residual = problem.residuals(space.to_unit(fitted), window)
    return {"window_s": list(window) if window else "all samples",
            "on_fit_data": problem.settings.validate_window is None,
            "fit_window_s": list(problem.settings.fit_window or ()) or "all samples",
            "excitation": round(excited, 4),
            "excited": excited >= MIN_EXCITATION,
            "nominal_rmse_N": round(float(np.sqrt(np.mean(nominal_residual**2))), 6),
            "fitted_rmse_N": round(float(np.sqrt(np.mean(fitted_residual**2))), 6)}


def _nominal_comparisons(problem: _Problem, space: SysidSpace) -> list[Comparison]:
    """The nominal model against each log, the time offset estimated as ``compare`` does."""
    runs = problem.simulate(space.structure_values(), snap=False)
    return [compare_tensions(log, run, max_offset=problem.settings.max_offset,
                             skip=problem.span(log)[0], end=problem.span(log)[1])
            for log, run in zip(problem.logs, runs, strict=True)]
