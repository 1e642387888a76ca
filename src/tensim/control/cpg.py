"""Central pattern generators on the impedance law's target velocity V* (paper eq. 4-6).

One phase oscillator per actuated cable (Ijspeert and Crespi's model, as in the paper):

    dθ_i/dt = 2π ν_i + Σ_j r_j w_ij sin(θ_j − θ_i − φ_ij)      (4)
    d²r_i/dt² = a_i (a_i/4 (R_i − r_i) − dr_i/dt)                (5)
    V_i = r_i cos θ_i                                            (6)

r is in m/s (V is the impedance law's V*), so w_ij is in rad/m and r_j w_ij is a rate in rad/s.
In a locked state θ_j − θ_i = φ_ij: oscillator j leads oscillator i by φ_ij.

:func:`integrate` solves the network with an adaptive Runge-Kutta method and samples it on a
time grid, so the output does not depend on a control step. :func:`spine_network` couples every
cable to the cables that share a rigid body with it (paper section II-B), and
:func:`spine_parameters` lays out the spine's learnable parameters with the symmetry rule below.

Symmetry rule (57 coupling classes for Tetraspine3). A directed coupling i <- j (i driven, j
driving) belongs to the class (d, {kind_i, kind_j}): d = joint(i) − joint(j) is the joint
offset, and the *unordered* pair of cable kinds (outer_top, inner_left, ...) ignores which of
the two cables is driven. Every coupling of a class shares one weight and one phase offset.
This is the "upper triangular" edge table of the original simulator's spine CPG controller
(NTRT BaseSpineCPGControl / tgCPGStringControl): per joint offset, a symmetric kind x kind
table, with the diagonal of offset 0 (a cable with itself) left out. With K kinds per joint
that is K(K−1)/2 classes at d = 0 and K(K+1)/2 at each of d = ±1. Tetraspine has K = 6, and
a cable couples only to cables of its own or a neighbouring joint (those share a segment), so
there are 15 + 21 + 21 = 57 classes, i.e. 114 coupling parameters, plus one shared amplitude and
one shared frequency: 116 parameters, for any spine of 3 or more segments (the classes repeat
along the spine; a 2-segment spine has only the 15 offset-0 classes). Within a class at d = 0,
a coupling and its reverse (i <- j and j <- i) share a parameter; the reverse gets the negated
phase (φ_ji = −φ_ij), so a pair of cables has one consistent phase lag. The original simulator
gave both the same phase, which can only lock at 0 or π; the negation is this package's choice.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence

import numpy as np
from scipy.integrate import solve_ivp

from tensim.control.impedance import ImpedanceController
from tensim.control.sine import (
    check_driven,
    joint_index,
    per_item,
    sample_times,
    write_target_velocity,
)
from tensim.sim import Simulation
from tensim.structure import Cable, Structure


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
    frequency: float | tuple[float, ...]
    amplitude: float | tuple[float, ...]
    convergence: float | tuple[float, ...] = 20.0
    couplings: tuple[Coupling, ...] = ()

    def __post_init__(self) -> None:
        names = tuple(str(n) for n in self.names)
        if not names or len(set(names)) != len(names) or not all(names):
            raise ValueError(f"oscillator names must be unique and non-empty, got {names}")
        n = len(names)
        object.__setattr__(self, "names", names)
        for field in ("frequency", "amplitude", "convergence"):
            object.__setattr__(self, field, _per_oscillator(getattr(self, field), n, field))
        if min(self.frequency) < 0:
            raise ValueError(f"frequency must be >= 0 Hz, got {self.frequency}")
        if min(self.amplitude) < 0:
            raise ValueError(f"amplitude must be >= 0 m/s, got {self.amplitude}")
        if min(self.convergence) <= 0:
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
        rtol, atol: relative and absolute tolerances (θ in rad, r in m/s, dr/dt in m/s²).
        max_evaluations: most right-hand side evaluations (DOP853: 12 per step, +3 per step
            for dense output); stiff, runaway coupling hits this.
        max_wall_s: most wall-clock time for one integration [s].
        max_amplitude: bound on |r| [m/s], e.g. a motor's speed limit; None: twice
            max(|r(0)|, R) (eq. 5 is critically damped, so with dr/dt(0) = 0 the amplitude
            stays between r(0) and R, and anything past that is a runaway).
    """

    method: str = "DOP853"
    rtol: float = 1e-10
    atol: float = 1e-10
    max_evaluations: int = 2_000_000
    max_wall_s: float = 60.0
    max_amplitude: float | None = None

    def __post_init__(self) -> None:
        if self.method not in ("DOP853", "RK45", "RK23"):
            raise ValueError(f"method must be 'DOP853', 'RK45' or 'RK23', got {self.method!r}")
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
    """

    times: np.ndarray
    phase: np.ndarray
    amplitude: np.ndarray

    @property
    def velocity(self) -> np.ndarray:
        """(n_samples, n_oscillators) output V = r cos θ [m/s] (eq. 6)."""
        return self.amplitude * np.cos(self.phase)


class _Abort(Exception):
    """Raised inside the right-hand side to stop the solver."""


def _right_hand_side(network: CPGNetwork, settings: SolverSettings
                     ) -> Callable[[float, np.ndarray], np.ndarray]:
    n = network.size
    omega = 2 * np.pi * np.asarray(network.frequency)
    target = np.asarray(network.amplitude)
    a = np.asarray(network.convergence)
    ci = np.array([c.i for c in network.couplings], dtype=np.intp)
    cj = np.array([c.j for c in network.couplings], dtype=np.intp)
    w = np.array([c.weight for c in network.couplings], dtype=float)
    phi = np.array([c.phase for c in network.couplings], dtype=float)
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


def _initial_state(network: CPGNetwork, initial_phase: Sequence[float] | None,
                   initial_amplitude: float | Sequence[float]) -> np.ndarray:
    n = network.size
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
    times = sample_times(duration, sample_dt)
    y0 = _initial_state(network, initial_phase, initial_amplitude)
    n = network.size
    bound = settings.max_amplitude
    if bound is None:
        bound = 2 * max(float(np.abs(y0[n:2 * n]).max()), max(network.amplitude)) + 1e-12

    def amplitude_runaway(t: float, y: np.ndarray) -> float:
        return bound - float(np.abs(y[n:2 * n]).max())

    amplitude_runaway.terminal = True  # type: ignore[attr-defined]
    try:
        sol = solve_ivp(_right_hand_side(network, settings), (0.0, max(duration, times[-1])), y0,
                        method=settings.method, t_eval=times, rtol=settings.rtol,
                        atol=settings.atol, events=amplitude_runaway)
    except _Abort as abort:
        raise GaitError(f"CPG integration stopped: {abort}") from None
    if sol.status == 1:
        raise GaitError(f"CPG amplitude |r| exceeded its bound {bound:.6g} m/s at "
                        f"t = {sol.t_events[0][0]:.6g} s")
    if sol.status != 0:
        raise GaitError(f"CPG integration failed: {sol.message}")
    if sol.y.shape[1] != times.size or not np.isfinite(sol.y).all():
        raise GaitError("CPG integration produced non-finite values")
    return CPGTrajectory(times, sol.y[:n].T.copy(), sol.y[n:2 * n].T.copy())


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


# -- spines: coupling rule and parameter layout -------------------------------------------------


def _cable_names(structure: Structure, cables: Sequence[str] | None) -> tuple[str, ...]:
    names = tuple(c.name for c in structure.cables) if cables is None else tuple(cables)
    for name in names:
        structure.cable(name)  # KeyError for an unknown cable
    if not names or len(set(names)) != len(names):
        raise ValueError(f"cables must be unique and at least one, got {names}")
    return names


def shared_body_pairs(structure: Structure, cables: Sequence[str] | None = None
                      ) -> tuple[tuple[int, int], ...]:
    """Directed pairs (i, j), i != j, of cables whose endpoints share a rigid body.

    Bodies are ``structure.rigid_groups()``; a node on no body (fixed to the world without a
    mass) couples nothing.

    Args:
        structure: the robot.
        cables: the cables, indexed in this order (None: every cable in structure order).
    """
    names = _cable_names(structure, cables)
    body = {node: g.name for g in structure.rigid_groups() for node in g.nodes}
    bodies = [{body[n] for n in structure.cable(c).nodes if n in body} for c in names]
    m = len(names)
    return tuple((i, j) for i in range(m) for j in range(m) if i != j and bodies[i] & bodies[j])


def spine_network(structure: Structure, cables: Sequence[str] | None,
                  frequency: float | Sequence[float], amplitude: float | Sequence[float],
                  weights: float | Callable[[str, str], float],
                  phases: float | Callable[[str, str], float],
                  a: float = 20.0) -> CPGNetwork:
    """One oscillator per cable, coupled to every cable that shares a rigid body with it.

    Args:
        structure: the robot.
        cables: the actuated cables (None: every cable).
        frequency: ν [Hz], shared or per cable.
        amplitude: R [m/s], shared or per cable.
        weights: w_ij [rad/m], shared or a function of (driven cable, driving cable).
        phases: φ_ij [rad], shared or a function of (driven cable, driving cable).
        a: convergence constant [1/s].
    """
    names = _cable_names(structure, cables)

    def value(spec: float | Callable[[str, str], float], i: int, j: int) -> float:
        return float(spec(names[i], names[j])) if callable(spec) else float(spec)

    couplings = tuple(Coupling(i, j, value(weights, i, j), value(phases, i, j))
                      for i, j in shared_body_pairs(structure, names))
    return CPGNetwork(names, frequency, amplitude, a, couplings)


@dataclasses.dataclass(frozen=True)
class Bounds:
    """A parameter's range and nominal value.

    Attributes:
        low: lower bound.
        high: upper bound, > low.
        nominal: default value, within the bounds.
    """

    low: float
    high: float
    nominal: float

    def __post_init__(self) -> None:
        values = (self.low, self.high, self.nominal)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"bounds must be finite, got {values}")
        if not self.low < self.high:
            raise ValueError(f"bounds need low < high, got {self.low} and {self.high}")
        if not self.low <= self.nominal <= self.high:
            raise ValueError(f"nominal {self.nominal} lies outside [{self.low}, {self.high}]")


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One named, bounded entry of a parameter vector.

    Attributes:
        name: e.g. ``weight/0/outer_top|inner_left``, ``amplitude``.
        bounds: its range and nominal value.
    """

    name: str
    bounds: Bounds


# default ranges: r_j w_ij (the coupling rate) is R·w, so with R ~ 0.02 m/s a weight of 20 rad/m
# gives ~0.4 rad/s; the amplitude bound matches Tetraspine's 0.07 m/s motors.
DEFAULT_WEIGHT = Bounds(0.0, 100.0, 20.0)  # rad/m
DEFAULT_PHASE = Bounds(-math.pi, math.pi, 0.0)  # rad
DEFAULT_AMPLITUDE = Bounds(0.0, 0.07, 0.02)  # m/s
DEFAULT_FREQUENCY = Bounds(0.1, 2.0, 0.5)  # Hz


@dataclasses.dataclass(frozen=True)
class CPGParameters:
    """The learnable parameters of a CPG with shared couplings, one amplitude and frequency.

    The vector is ``[weight/c0, phase/c0, weight/c1, phase/c1, ..., amplitude, frequency]``
    over the coupling classes ``classes``; couplings of a class share its weight and phase.

    Attributes:
        oscillators: the oscillators' (cables') names.
        classes: coupling class labels ``<joint offset>/<kind>|<kind>``.
        edges: (i, j, class, sign) per coupling i <- j: it gets the class's weight and
            sign (±1) times its phase.
        weight, phase, amplitude, frequency: ranges [rad/m, rad, m/s, Hz].
        convergence: a [1/s] of every oscillator (not learned).
    """

    oscillators: tuple[str, ...]
    classes: tuple[str, ...]
    edges: tuple[tuple[int, int, int, int], ...]
    weight: Bounds = DEFAULT_WEIGHT
    phase: Bounds = DEFAULT_PHASE
    amplitude: Bounds = DEFAULT_AMPLITUDE
    frequency: Bounds = DEFAULT_FREQUENCY
    convergence: float = 20.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "oscillators", tuple(self.oscillators))
        object.__setattr__(self, "classes", tuple(self.classes))
        object.__setattr__(self, "edges", tuple(tuple(int(v) for v in e) for e in self.edges))
        if len(set(self.classes)) != len(self.classes):
            raise ValueError("coupling class labels must be unique")
        n, k = len(self.oscillators), len(self.classes)
        for i, j, c, sign in self.edges:
            if not (0 <= i < n and 0 <= j < n and i != j and 0 <= c < k and sign in (-1, 1)):
                raise ValueError(f"invalid edge {(i, j, c, sign)} for {n} oscillators and "
                                 f"{k} classes")
        unused = set(range(k)) - {e[2] for e in self.edges}
        if unused:
            raise ValueError(f"coupling classes {[self.classes[c] for c in sorted(unused)]} "
                             "have no coupling")
        if not (math.isfinite(self.convergence) and self.convergence > 0):
            raise ValueError(f"convergence must be > 0 1/s, got {self.convergence}")

    # -- the vector layout --------------------------------------------------------------------

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        """The entries, in vector order."""
        pairs = [(Parameter(f"weight/{c}", self.weight), Parameter(f"phase/{c}", self.phase))
                 for c in self.classes]
        return (*(p for pair in pairs for p in pair), Parameter("amplitude", self.amplitude),
                Parameter("frequency", self.frequency))

    @property
    def names(self) -> tuple[str, ...]:
        """Entry names, in vector order."""
        return tuple(p.name for p in self.parameters)

    @property
    def size(self) -> int:
        """Number of parameters: 2 per coupling class + amplitude + frequency."""
        return 2 * len(self.classes) + 2

    @property
    def low(self) -> np.ndarray:
        """(size,) lower bounds."""
        return np.array([p.bounds.low for p in self.parameters])

    @property
    def high(self) -> np.ndarray:
        """(size,) upper bounds."""
        return np.array([p.bounds.high for p in self.parameters])

    @property
    def nominal(self) -> np.ndarray:
        """(size,) nominal values."""
        return np.array([p.bounds.nominal for p in self.parameters])

    def _vector(self, values: Sequence[float] | np.ndarray, what: str) -> np.ndarray:
        v = np.asarray(values, dtype=float)
        if v.shape != (self.size,):
            raise ValueError(f"{what} must have shape ({self.size},), got {v.shape}")
        if not np.isfinite(v).all():
            raise ValueError(f"{what} must be finite")
        return v

    def _check_bounds(self, v: np.ndarray) -> None:
        slack = 1e-12 * (self.high - self.low)
        outside = (v < self.low - slack) | (v > self.high + slack)
        if outside.any():
            bad = {self.names[i]: float(v[i]) for i in np.flatnonzero(outside)}
            raise ValueError(f"parameters outside their bounds: {bad} (use clip)")

    def clip(self, values: Sequence[float] | np.ndarray) -> np.ndarray:
        """``values`` clipped into the bounds."""
        return np.clip(self._vector(values, "values"), self.low, self.high)

    def to_unit(self, values: Sequence[float] | np.ndarray) -> np.ndarray:
        """Maps values in the bounds to [0, 1] (low -> 0, high -> 1)."""
        v = self._vector(values, "values")
        self._check_bounds(v)
        return np.clip((v - self.low) / (self.high - self.low), 0.0, 1.0)

    def from_unit(self, unit: Sequence[float] | np.ndarray) -> np.ndarray:
        """Maps [0, 1] back to values in the bounds (the inverse of :meth:`to_unit`)."""
        u = self._vector(unit, "unit")
        if (u < 0).any() or (u > 1).any():
            raise ValueError("unit values must lie in [0, 1]")
        return self.low + u * (self.high - self.low)

    def as_dict(self, values: Sequence[float] | np.ndarray) -> dict[str, float]:
        """name -> value."""
        v = self._vector(values, "values")
        return {name: float(x) for name, x in zip(self.names, v, strict=True)}

    def network(self, values: Sequence[float] | np.ndarray | None = None) -> CPGNetwork:
        """The CPG for a parameter vector (None: the nominal values).

        Raises:
            ValueError: a wrong shape, or values outside the bounds.
        """
        v = self.nominal if values is None else self._vector(values, "values")
        self._check_bounds(v)
        k = len(self.classes)
        weights, phases = v[0:2 * k:2], v[1:2 * k:2]
        couplings = tuple(Coupling(i, j, weights[c], sign * phases[c])
                          for i, j, c, sign in self.edges)
        return CPGNetwork(self.oscillators, float(v[-1]), float(v[-2]), self.convergence,
                          couplings)


def _default_kind(cable: Cable) -> str:
    """The cable name without its ``_<joint>`` suffix (``outer_top_2`` -> ``outer_top``)."""
    suffix = f"_{joint_index(cable)}"
    return cable.name.removesuffix(suffix)


def _offset_label(offset: int) -> str:
    return f"{offset:+d}" if offset else "0"


def spine_parameters(structure: Structure, cables: Sequence[str] | None = None, *,
                     weight: Bounds = DEFAULT_WEIGHT, phase: Bounds = DEFAULT_PHASE,
                     amplitude: Bounds = DEFAULT_AMPLITUDE,
                     frequency: Bounds = DEFAULT_FREQUENCY, convergence: float = 20.0,
                     kind: Callable[[Cable], str] = _default_kind,
                     joint: Callable[[Cable], int] = joint_index) -> CPGParameters:
    """The parameter layout of a spine CPG with the module's symmetry rule.

    The couplings are those of :func:`spine_network`; coupling i <- j belongs to the class
    (joint(i) − joint(j), {kind(i), kind(j)}); see the module docstring. Tetraspine3 gives 57
    classes, 116 parameters.

    Args:
        structure: the spine.
        cables: the actuated cables (None: every cable).
        weight, phase, amplitude, frequency: ranges [rad/m, rad, m/s, Hz].
        convergence: a [1/s].
        kind: a cable's kind (default: its name without the ``_<joint>`` suffix).
        joint: a cable's joint index (default: from its ``joint_<j>`` tag).
    """
    names = _cable_names(structure, cables)
    kinds = [kind(structure.cable(n)) for n in names]
    joints = [joint(structure.cable(n)) for n in names]
    rank = {k: r for r, k in enumerate(dict.fromkeys(kinds))}
    keyed = []
    for i, j in shared_body_pairs(structure, names):
        offset = joints[i] - joints[j]
        first, second = sorted((i, j), key=lambda c: (rank[kinds[c]], c))
        sign = -1 if offset == 0 and first != i else 1
        keyed.append(((abs(offset), -offset, rank[kinds[first]], rank[kinds[second]]),
                      f"{_offset_label(offset)}/{kinds[first]}|{kinds[second]}", i, j, sign))
    labels = dict.fromkeys(label for _, label, *_ in sorted(keyed, key=lambda e: e[0]))
    index = {label: c for c, label in enumerate(labels)}
    edges = tuple((i, j, index[label], sign) for _, label, i, j, sign in keyed)
    return CPGParameters(names, tuple(labels), edges, weight, phase, amplitude, frequency,
                         convergence)


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

    def configure(self, sim: Simulation) -> None:
        """Writes the impedance gains and the sampled CPG output into ``sim.drive``.

        Raises:
            GaitError: the CPG integration failed or ran away.
        """
        self.impedance.configure(sim)
        table_dt = self.sample_steps * sim.dt
        _, velocity = integrate(self.network, self.duration, table_dt, self.initial_phase,
                                self.initial_amplitude, self.settings)
        write_target_velocity(sim, self.network.names, velocity, table_dt)
