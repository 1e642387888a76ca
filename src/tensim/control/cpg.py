"""Central pattern generators on the impedance law's target velocity V* (paper eq. 4-6).

One phase oscillator per actuated cable (Ijspeert and Crespi's model, as in the paper):

    dθ_i/dt = 2π ν_i + Σ_j r_j w_ij sin(θ_j − θ_i − φ_ij)      (4)
    d²r_i/dt² = a_i (a_i/4 (R_i − r_i) − dr_i/dt)                (5)
    V_i = r_i cos θ_i                                            (6)

r is in m/s (V is the impedance law's V*), so w_ij is in rad/m and r_j w_ij is a rate in rad/s.
In a locked state θ_j − θ_i = φ_ij: oscillator j leads oscillator i by φ_ij.

:func:`integrate` solves the network with an adaptive Runge-Kutta method and samples it on a
time grid, so the output does not depend on a control step. The default method, DOP853, runs
compiled (``_cpg.c``: scipy's algorithm step for step, about 20x faster than scipy in Python)
where tensim was built with a C compiler, and through scipy otherwise.
:mod:`tensim.control.spine` builds networks for spines and lays out their learnable
parameters."""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np

from tensim.control import _cpg_native
from tensim.control._common import check_driven, per_item, sample_times, write_target_velocity
from tensim.control.impedance import ImpedanceController
from tensim.sim import CableSetup

log = logging.getLogger(__name__)


class GaitError(RuntimeError):
    """A gait generator produced no usable output (solver failure or runaway state)."""


# -- the network ----------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Coupling:
    """The term r_j w_ij sin(θ_j − θ_i − φ_ij) of oscillator i's phase equation (eq. 4).

    Attributes:
        i: index of the driven oscillator.
        j: index of the driving oscillator.
        weight: w_ij [rad/m].
        phase: φ_ij [rad], the lag of i behind j once locked.
    """

    i: int
    j: int
    weight: float
    phase: float

    def __post_init__(self) -> None:
        for field in ("i", "j"):
            value = getattr(self, field)
            if isinstance(value, bool) or int(value) != value or value < 0:
                raise ValueError(f"coupling {field} must be an oscillator index >= 0, "
                                 f"got {value!r}")
            object.__setattr__(self, field, int(value))
        if self.i == self.j:
            raise ValueError(f"oscillator {self.i} is coupled to itself; self coupling is not "
                             "part of eq. 4")
        for field in ("weight", "phase"):
            value = float(getattr(self, field))
            if not math.isfinite(value):
                raise ValueError(f"coupling {self.i} <- {self.j}: {field} must be finite, "
                                 f"got {value}")
            object.__setattr__(self, field, value)


def _per_oscillator(value: float | Sequence[float], n: int, what: str) -> tuple[float, ...]:
    return per_item(value, n, what, "oscillator")


@dataclasses.dataclass(frozen=True)
class CPGNetwork:
    """Oscillators (one per actuated cable) and their couplings, as validated data.

    Scalars are broadcast to every oscillator (after construction the per-oscillator fields
    are tuples); couplings may be given as (i, j, weight, phase) tuples.

    Attributes:
        names: oscillator names, the names of the cables they drive.
        frequency: ν_i [Hz], >= 0.
        amplitude: amplitude setpoint R_i [m/s], >= 0.
        convergence: a_i [1/s], > 0; r reaches R critically damped with time constant 2/a.
        couplings: the couplings, at most one per ordered pair (i, j).
    """

    names: tuple[str, ...]
    frequency: float | Sequence[float]
    amplitude: float | Sequence[float]
    convergence: float | Sequence[float] = 20.0
    couplings: tuple[Coupling, ...] = ()

    def __post_init__(self) -> None:
        names = tuple(str(n) for n in self.names)
        if not names or len(set(names)) != len(names) or not all(names):
            raise ValueError(f"oscillator names must be unique and non-empty, got {names}")
        n = len(names)
        object.__setattr__(self, "names", names)
        values = {field: _per_oscillator(getattr(self, field), n, field)
                  for field in ("frequency", "amplitude", "convergence")}
        for field, value in values.items():
            object.__setattr__(self, field, value)
        if min(values["frequency"]) < 0:
            raise ValueError(f"frequency must be >= 0 Hz, got {self.frequency}")
        if min(values["amplitude"]) < 0:
            raise ValueError(f"amplitude must be >= 0 m/s, got {self.amplitude}")
        if min(values["convergence"]) <= 0:
            raise ValueError(f"convergence constant a must be > 0 1/s for r to converge to R, "
                             f"got {self.convergence}")
        couplings = tuple(c if isinstance(c, Coupling) else Coupling(*c) for c in self.couplings)
        object.__setattr__(self, "couplings", couplings)
        seen: set[tuple[int, int]] = set()
        for c in couplings:
            if c.i >= n or c.j >= n:
                raise ValueError(f"coupling {c.i} <- {c.j} names an oscillator outside "
                                 f"0..{n - 1}")
            if (c.i, c.j) in seen:
                raise ValueError(f"coupling {c.i} <- {c.j} is given twice")
            seen.add((c.i, c.j))

    @property
    def size(self) -> int:
        """Number of oscillators."""
        return len(self.names)


# -- integration ----------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class SolverSettings:
    """Accuracy and the guards that turn a runaway integration into a :class:`GaitError`.

    Attributes:
        method: an adaptive explicit Runge-Kutta method of ``scipy.integrate.solve_ivp``.
        backend: ``"auto"`` (DOP853 compiled where it is built, else scipy), ``"compiled"``
            (DOP853 only; RuntimeError where it is not built) or ``"scipy"`` (the reference).
        rtol, atol: relative and absolute tolerances (θ in rad, r in m/s, dr/dt in m/s²).
        max_evaluations: most right-hand side evaluations (DOP853: 12 per step, +3 per step
            for dense output); stiff, runaway coupling hits this.
        max_wall_s: most wall-clock time for one integration [s].
        max_amplitude: bound on |r| [m/s], e.g. a motor's speed limit; None: twice
            max(|r(0)|, R) (eq. 5 is critically damped, so with dr/dt(0) = 0 the amplitude
            stays between r(0) and R, and anything past that is a runaway).
    """

    method: str = "DOP853"
    backend: str = "auto"
    rtol: float = 1e-10
    atol: float = 1e-10
    max_evaluations: int = 2_000_000
    max_wall_s: float = 60.0
    max_amplitude: float | None = None

    def __post_init__(self) -> None:
        if self.method not in ("DOP853", "RK45", "RK23"):
            raise ValueError(f"method must be 'DOP853', 'RK45' or 'RK23', got {self.method!r}")
        if self.backend not in ("auto", "compiled", "scipy"):
            raise ValueError(f"backend must be 'auto', 'compiled' or 'scipy', got "
                             f"{self.backend!r}")
        if self.backend == "compiled" and self.method != "DOP853":
            raise ValueError(f"the compiled integrator is DOP853; method {self.method!r} needs "
                             "backend 'scipy' or 'auto'")
        for field in ("rtol", "atol", "max_wall_s"):
            value = getattr(self, field)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{field} must be finite and > 0, got {value}")
        if self.max_evaluations < 1:
            raise ValueError(f"max_evaluations must be >= 1, got {self.max_evaluations}")
        if self.max_amplitude is not None and not self.max_amplitude > 0:
            raise ValueError(f"max_amplitude must be > 0 m/s, got {self.max_amplitude}")


DEFAULT_SETTINGS = SolverSettings()


@dataclasses.dataclass(frozen=True, eq=False)
class CPGTrajectory:
    """A sampled CPG solution.

    Attributes:
        times: (n_samples,) sample times [s].
        phase: (n_samples, n_oscillators) θ [rad].
        amplitude: (n_samples, n_oscillators) r [m/s].
        evaluations: right-hand side evaluations the solver made.
    """

    times: np.ndarray
    phase: np.ndarray
    amplitude: np.ndarray
    evaluations: int = 0

    @property
    def velocity(self) -> np.ndarray:
        """(n_samples, n_oscillators) output V = r cos θ [m/s] (eq. 6)."""
        return self.amplitude * np.cos(self.phase)


class _Abort(Exception):
    """Raised inside the right-hand side to stop the solver."""


class _Arrays(NamedTuple):
    """A network as arrays: (n,) 2πν [rad/s], R [m/s], a [1/s]; (m,) couplings i <- j,
    w [rad/m], φ [rad]."""

    omega: np.ndarray
    target: np.ndarray
    convergence: np.ndarray
    ci: np.ndarray
    cj: np.ndarray
    weight: np.ndarray
    phase: np.ndarray


def _network_arrays(network: CPGNetwork) -> _Arrays:
    return _Arrays(2 * np.pi * np.asarray(network.frequency), np.asarray(network.amplitude),
                   np.asarray(network.convergence),
                   np.array([c.i for c in network.couplings], dtype=np.intp),
                   np.array([c.j for c in network.couplings], dtype=np.intp),
                   np.array([c.weight for c in network.couplings], dtype=float),
                   np.array([c.phase for c in network.couplings], dtype=float))


def _right_hand_side(arrays: _Arrays, settings: SolverSettings
                     ) -> Callable[[float, np.ndarray], np.ndarray]:
    n = arrays.omega.size
    omega, target, a, ci, cj, w, phi = arrays
    start, count = time.perf_counter(), [0]

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        count[0] += 1
        if count[0] > settings.max_evaluations:
            raise _Abort(f"more than {settings.max_evaluations} right-hand side evaluations "
                         f"by t = {t:.6g} s (the coupling is too stiff or running away)")
        if count[0] % 64 == 1 and time.perf_counter() - start > settings.max_wall_s:
            raise _Abort(f"integration took longer than {settings.max_wall_s} s of wall time "
                         f"by t = {t:.6g} s")
        theta, r, dr = y[:n], y[n:2 * n], y[2 * n:]
        drive = r[cj] * w * np.sin(theta[cj] - theta[ci] - phi)
        dtheta = omega + np.bincount(ci, weights=drive, minlength=n)
        ddr = a * (a / 4 * (target - r) - dr)
        return np.concatenate([dtheta, dr, ddr])

    return rhs


def _initial_state(n: int, initial_phase: Sequence[float] | None,
                   initial_amplitude: float | Sequence[float]) -> np.ndarray:
    theta0 = np.zeros(n) if initial_phase is None else np.asarray(
        _per_oscillator(initial_phase, n, "initial_phase"))
    r0 = np.asarray(_per_oscillator(initial_amplitude, n, "initial_amplitude"))
    return np.concatenate([theta0, r0, np.zeros(n)])


def solve(network: CPGNetwork, duration: float, sample_dt: float,
          initial_phase: Sequence[float] | None = None,
          initial_amplitude: float | Sequence[float] = 0.0,
          settings: SolverSettings = DEFAULT_SETTINGS) -> CPGTrajectory:
    """Integrates eq. 4-5 from t = 0 and samples θ and r every ``sample_dt``.

    The adaptive solver chooses its own steps; samples come from its dense output, so the
    values at a given time do not depend on ``sample_dt``. dr/dt starts at 0.

    Args:
        network: the oscillators and couplings.
        duration: integrated time [s].
        sample_dt: sampling period [s]; samples at 0, dt, ... up to ``duration``.
        initial_phase: θ(0) per oscillator [rad] (None: all 0).
        initial_amplitude: r(0) [m/s], one for all or one per oscillator.
        settings: tolerances and guards.

    Raises:
        ValueError: invalid times or initial state.
        GaitError: the solver failed, or the state ran away (non-finite values, |r| past its
            bound, too many evaluations, too much wall time).
    """
    return _solve(_network_arrays(network), duration, sample_dt, initial_phase, initial_amplitude,
                  settings)


def _solve(arrays: _Arrays, duration: float, sample_dt: float,
           initial_phase: Sequence[float] | None, initial_amplitude: float | Sequence[float],
           settings: SolverSettings) -> CPGTrajectory:
    """:func:`solve` on a network's arrays, compiled or through scipy as ``settings`` say."""
    n = arrays.omega.size
    times = sample_times(duration, sample_dt)
    y0 = _initial_state(n, initial_phase, initial_amplitude)
    t_bound = max(duration, times[-1])
    bound = settings.max_amplitude
    if bound is None:
        bound = 2 * max(float(np.abs(y0[n:2 * n]).max()), float(arrays.target.max())) + 1e-12
    if _use_compiled(settings):
        status, samples, stop, evaluations = _cpg_native.dop853(
            *arrays, y0, t_bound, times, max(settings.rtol, 100 * np.finfo(float).eps),
            settings.atol, bound, settings.max_evaluations, settings.max_wall_s)
        _check_compiled(status, stop, bound, settings)
        theta, r = samples[:, :n], samples[:, n:]
    else:
        theta, r, evaluations = _solve_scipy(arrays, y0, times, t_bound, bound, settings)
    if not (np.isfinite(theta).all() and np.isfinite(r).all()):
        raise GaitError("CPG integration produced non-finite values")
    return CPGTrajectory(times, np.ascontiguousarray(theta), np.ascontiguousarray(r),
                         evaluations)


_warned_scipy = False


def compiled_available() -> bool:
    """Whether the compiled DOP853 integrator is built (else CPGs integrate through scipy)."""
    return _cpg_native.available()


def _use_compiled(settings: SolverSettings) -> bool:
    """Whether ``settings`` run on the compiled DOP853 (warns once where it is missing)."""
    global _warned_scipy
    if settings.backend == "scipy" or settings.method != "DOP853":
        return False
    if settings.backend == "compiled" or _cpg_native.available():
        return True  # "compiled" where it is missing: _cpg_native raises, naming the fix
    if not _warned_scipy:
        _warned_scipy = True
        log.warning("compiled CPG integrator not built (no C compiler at install time?): "
                    "integrating CPGs with scipy in Python, about 20x slower")
    return False


def _check_compiled(status: int, stop: float, bound: float, settings: SolverSettings) -> None:
    """Raises the :class:`GaitError` of a compiled integration's guard, as the scipy path."""
    if status == _cpg_native.AMPLITUDE:
        raise GaitError(f"CPG amplitude |r| exceeded its bound {bound:.6g} m/s by "
                        f"t = {stop:.6g} s")
    if status == _cpg_native.EVALUATIONS:
        raise GaitError(f"CPG integration stopped: more than {settings.max_evaluations} "
                        f"right-hand side evaluations by t = {stop:.6g} s (the coupling is too "
                        "stiff or running away)")
    if status == _cpg_native.WALL_TIME:
        raise GaitError(f"CPG integration stopped: integration took longer than "
                        f"{settings.max_wall_s} s of wall time by t = {stop:.6g} s")
    if status == _cpg_native.STEP_TOO_SMALL:
        raise GaitError(f"CPG integration failed: the step size fell below the spacing of "
                        f"floating-point numbers at t = {stop:.6g} s")
    if status != _cpg_native.OK:
        raise GaitError(f"CPG integration failed: out of memory (status {status})")


def _solve_scipy(arrays: _Arrays, y0: np.ndarray, times: np.ndarray, t_bound: float,
                 bound: float, settings: SolverSettings) -> tuple[np.ndarray, np.ndarray, int]:
    """θ and r at ``times`` by ``scipy.integrate.solve_ivp``, and its evaluation count."""
    n = arrays.omega.size

    def amplitude_runaway(t: float, y: np.ndarray) -> float:
        return bound - float(np.abs(y[n:2 * n]).max())

    amplitude_runaway.terminal = True  # type: ignore[attr-defined]
    from scipy.integrate import solve_ivp  # ~0.3 s to import: only when scipy integrates

    try:
        sol = solve_ivp(_right_hand_side(arrays, settings), (0.0, t_bound), y0,
                        method=settings.method, t_eval=times, rtol=settings.rtol,
                        atol=settings.atol, events=amplitude_runaway)
    except _Abort as abort:
        raise GaitError(f"CPG integration stopped: {abort}") from None
    if sol.status == 1:
        raise GaitError(f"CPG amplitude |r| exceeded its bound {bound:.6g} m/s at "
                        f"t = {sol.t_events[0][0]:.6g} s")
    if sol.status != 0:
        raise GaitError(f"CPG integration failed: {sol.message}")
    if sol.y.shape[1] != times.size:
        raise GaitError("CPG integration produced non-finite values")
    return sol.y[:n].T, sol.y[n:2 * n].T, int(sol.nfev)


def integrate(network: CPGNetwork, duration: float, sample_dt: float,
              initial_phase: Sequence[float] | None = None,
              initial_amplitude: float | Sequence[float] = 0.0,
              settings: SolverSettings = DEFAULT_SETTINGS) -> tuple[np.ndarray, np.ndarray]:
    """The CPG output V = r cos θ (eq. 6) sampled every ``sample_dt``; see :func:`solve`.

    Returns:
        (times, V): (n_samples,) times [s] and (n_samples, n_oscillators) V [m/s].
    """
    trajectory = solve(network, duration, sample_dt, initial_phase, initial_amplitude, settings)
    return trajectory.times, trajectory.velocity


# -- the controller -------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class CPGController:
    """A CPG on top of impedance laws.

    ``configure`` sets the impedance gains, integrates the CPG over ``duration`` and writes
    its output as the V* table, sampled every ``sample_steps`` physics steps (the impedance
    controller's constant target velocity is replaced; cables without an oscillator get
    V* = 0). Past ``duration`` the drive holds the last row, so simulate at most ``duration``.

    Attributes:
        network: the CPG; its oscillator names are cable names.
        impedance: the impedance laws; every oscillator's cable must have gains.
        duration: integrated time [s].
        sample_steps: table period in physics steps (1: V* sampled at every step).
        initial_phase: θ(0) per oscillator [rad] (None: all 0).
        initial_amplitude: r(0) [m/s].
        settings: solver tolerances and guards.
    """

    network: CPGNetwork
    impedance: ImpedanceController
    duration: float
    sample_steps: int = 1
    initial_phase: tuple[float, ...] | None = None
    initial_amplitude: float = 0.0
    settings: SolverSettings = DEFAULT_SETTINGS

    def __post_init__(self) -> None:
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise ValueError(f"duration must be a finite time > 0 s, got {self.duration}")
        if int(self.sample_steps) != self.sample_steps or self.sample_steps < 1:
            raise ValueError(f"sample_steps must be an integer >= 1, got {self.sample_steps}")
        if self.initial_phase is not None:
            object.__setattr__(self, "initial_phase", _per_oscillator(
                self.initial_phase, self.network.size, "initial_phase"))
        check_driven(self.impedance, self.network.names)

    def configure(self, sim: CableSetup) -> None:
        """Writes the impedance gains and the sampled CPG output into ``sim.drive``.

        Raises:
            GaitError: the CPG integration failed or ran away.
        """
        self.impedance.configure(sim)
        table_dt = self.sample_steps * sim.dt
        _, velocity = integrate(self.network, self.duration, table_dt, self.initial_phase,
                                self.initial_amplitude, self.settings)
        write_target_velocity(sim, self.network.names, velocity, table_dt)
