"""Optimizers behind one ask/tell interface, on the unit cube, minimizing a cost (−score).

- :class:`NTRTSearch`: the original toolkit's procedure (paper section II-B; NTRT's learning
  scripts): Monte Carlo sampling of the whole cube for an initial estimate, then elitist hill
  climbing: each new point is the best one so far with every parameter moved, with probability
  ``mutation_rate``, by a Gaussian step of deviation ``sigma`` (NTRT's ``mutationDev``, 0.03),
  and it replaces the best only if it scores better.
- :class:`~tensim.learn.nelder_mead.NelderMead`: scipy's Nelder-Mead, step by step.
- :class:`CMAES`: CMA-ES of the ``cma`` package (ask/tell natively), bounded to the cube.

``ask()`` returns a batch of points; ``tell(points, costs)`` takes their costs in ask order,
so results never depend on which worker finished first. Every optimizer is reproducible from
its seed and the costs it is told: a run is checkpointed as the count of told evaluations, and
a fresh optimizer told the same costs asks exactly what the original would have asked next.
"""

from __future__ import annotations

import dataclasses
import sys
import warnings
from types import ModuleType
from typing import Any, Protocol

import numpy as np

from tensim._input import is_real
from tensim.learn.nelder_mead import NelderMead

OPTIMIZERS = ("ntrt", "cma", "nelder-mead")
MAX_BATCH = 10_000  # most points one ask may return
# default step in unit-cube units: NTRT's mutation deviation, CMA-ES's initial sigma and the
# Nelder-Mead initial simplex edge
DEFAULT_STEP = {"ntrt": 0.03, "cma": 0.2, "nelder-mead": 0.1}


class Optimizer(Protocol):
    """Ask/tell on the unit cube, minimizing."""

    name: str
    stop_reason: str

    @property
    def done(self) -> bool:
        """Whether the optimizer has stopped by itself (converged)."""

    def ask(self) -> np.ndarray:
        """(k, dimension) points in [0, 1] to evaluate next."""

    def tell(self, points: np.ndarray, costs: np.ndarray) -> None:
        """The costs of the last asked points, in ask order."""


class NTRTSearch:
    """Monte Carlo sampling, then elitist Gaussian hill climbing (the original procedure).

    Args:
        dimension: number of parameters.
        seed: seed of the random generator.
        start: (dimension,) point evaluated first when ``monte_carlo`` is 0 (hill climbing
            from a given gait).
        monte_carlo: number of uniform random points before hill climbing.
        batch: points per ask (a whole number of workers keeps them busy).
        sigma: deviation of a Gaussian step, in unit-cube units.
        mutation_rate: probability that a parameter is stepped (at least one always is).
        elites: how many of the best points are kept; children are spread over them.
    """

    name = "ntrt"

    def __init__(self, dimension: int, seed: int, start: np.ndarray | None = None, *,
                 monte_carlo: int = 48, batch: int = 8, sigma: float = 0.03,
                 mutation_rate: float = 0.5, elites: int = 1):
        if dimension < 1 or monte_carlo < 0 or batch < 1 or elites < 1:
            raise ValueError("need dimension >= 1, monte_carlo >= 0, batch >= 1, elites >= 1")
        if not (0 < sigma <= 1 and 0 < mutation_rate <= 1):
            raise ValueError(f"need 0 < sigma <= 1 and 0 < mutation_rate <= 1, got {sigma} "
                             f"and {mutation_rate}")
        self.dimension, self.monte_carlo, self.batch = dimension, monte_carlo, batch
        self.sigma, self.mutation_rate, self.elites = sigma, mutation_rate, elites
        self.start = np.full(dimension, 0.5) if start is None else np.asarray(start, float)
        self.rng = np.random.default_rng(seed)
        self.told = 0
        self.best_x = np.empty((0, dimension))
        self.best_f = np.empty(0)
        self.stop_reason = ""

    @property
    def done(self) -> bool:
        """Never: hill climbing goes on until the evaluation budget is spent."""
        return False

    def ask(self) -> np.ndarray:
        """Uniform points during the Monte Carlo phase, Gaussian steps from the elites after."""
        n = self.dimension
        if self.told < self.monte_carlo:
            return self.rng.random((min(self.batch, self.monte_carlo - self.told), n))
        if self.best_f.size == 0:
            return self.start[None].copy()
        parents = self.best_x[np.arange(self.batch) % self.best_x.shape[0]]
        mask = self.rng.random((self.batch, n)) < self.mutation_rate
        unmoved = np.flatnonzero(~mask.any(axis=1))
        mask[unmoved, self.rng.integers(n, size=unmoved.size)] = True
        steps = self.rng.normal(0.0, self.sigma, (self.batch, n))
        return np.clip(parents + mask * steps, 0.0, 1.0)

    def tell(self, points: np.ndarray, costs: np.ndarray) -> None:
        """Keeps the best ``elites`` points; an incumbent wins ties."""
        x = np.vstack([self.best_x, np.asarray(points, dtype=float)])
        f = np.concatenate([self.best_f, np.asarray(costs, dtype=float)])
        keep = np.argsort(f, kind="stable")[:self.elites]
        self.best_x, self.best_f = x[keep], f[keep]
        self.told += len(costs)


class _Gaussian:
    """N(0, 1) samples like ``np.random.randn(*shape)`` from a private, picklable stream."""

    def __init__(self, seed: int):
        self.state = np.random.RandomState(seed)

    def __call__(self, *shape: int) -> np.ndarray:
        return self.state.standard_normal(shape)


class CMAES:
    """CMA-ES (the ``cma`` package) on the unit cube.

    cma draws its samples through its ``randn`` option; this wrapper gives it a private
    stream seeded from ``seed``, so runs are reproducible (and rebuilt by telling the same
    costs again), and numpy's global random state is left alone.

    Args:
        dimension: number of parameters (>= 2).
        seed: seed of the sample stream.
        start: (dimension,) initial mean in [0, 1].
        sigma: initial step size in unit-cube units.
        batch: population size (None: cma's default 4 + 3 ln N).
    """

    name = "cma"

    def __init__(self, dimension: int, seed: int, start: np.ndarray, *, sigma: float = 0.2,
                 batch: int | None = None):
        cma = import_cma()
        if dimension < 2:
            raise ValueError("CMA-ES needs at least 2 parameters; use ntrt or nelder-mead")
        # seed NaN: cma must not reseed numpy's global state (it samples from randn only)
        options: dict[str, Any] = {"bounds": [0.0, 1.0], "seed": np.nan,
                                   "randn": _Gaussian(seed), "verbose": -9, "verb_log": 0,
                                   "verb_disp": 0}
        if batch is not None:
            options["popsize"] = batch
        self.es = cma.CMAEvolutionStrategy(np.clip(np.asarray(start, float), 0.0, 1.0), sigma,
                                           options)
        self._asked: list[np.ndarray] = []
        self.stop_reason = ""

    @property
    def done(self) -> bool:
        """Whether one of cma's stopping criteria holds (tolerances reached)."""
        stop = self.es.stop()
        if stop:
            self.stop_reason = "cma stopped: " + ", ".join(f"{k}={v}" for k, v in stop.items())
        return bool(stop)

    def ask(self) -> np.ndarray:
        """A population of points (cma maps them into the bounds)."""
        self._asked = self.es.ask()
        return np.clip(np.array(self._asked), 0.0, 1.0)

    def tell(self, points: np.ndarray, costs: np.ndarray) -> None:
        """Updates the distribution with the population's costs."""
        self.es.tell(self._asked, [float(c) for c in costs])


@dataclasses.dataclass(frozen=True)
class OptimizerSettings:
    """Which optimizer and its knobs, as saved with a run.

    Attributes:
        name: ``ntrt``, ``cma`` or ``nelder-mead``.
        step: unit-cube step: NTRT's mutation deviation, CMA-ES's initial sigma, or the
            Nelder-Mead initial simplex edge (None: :data:`DEFAULT_STEP`).
        batch: points per ask for ntrt (default 8) and cma (default 4 + 3 ln N); Nelder-Mead
            asks what its steps need.
        monte_carlo: ntrt's number of Monte Carlo samples.
    """

    name: str = "ntrt"
    step: float | None = None
    batch: int | None = None
    monte_carlo: int = 48

    def __post_init__(self) -> None:
        for field in ("batch", "monte_carlo"):
            value = getattr(self, field)
            if value is not None and (isinstance(value, bool) or not isinstance(value, int)):
                raise ValueError(f"{field} must be a whole number, got {value!r}")
        if self.step is not None and not is_real(self.step):
            raise ValueError(f"step must be a number, got {self.step!r}")
        if not isinstance(self.name, str) or self.name not in OPTIMIZERS:
            raise ValueError(f"unknown optimizer {self.name!r}; expected one of "
                             f"{list(OPTIMIZERS)}")
        if self.step is not None and not 0 < self.step <= 1:
            raise ValueError(f"step must be in (0, 1] of the unit cube, got {self.step}")
        if self.batch is not None and not 1 <= self.batch <= MAX_BATCH:
            raise ValueError(f"batch must be in [1, {MAX_BATCH}], got {self.batch}")
        if self.monte_carlo < 0:
            raise ValueError(f"monte_carlo must be >= 0, got {self.monte_carlo}")

    def build(self, dimension: int, seed: int, start: np.ndarray) -> Optimizer:
        """A fresh optimizer for a problem of ``dimension`` parameters."""
        step = DEFAULT_STEP[self.name] if self.step is None else self.step
        if self.name == "ntrt":
            return NTRTSearch(dimension, seed, start, monte_carlo=self.monte_carlo,
                              batch=self.batch or 8, sigma=step)
        if self.name == "cma":
            return CMAES(dimension, seed, start, sigma=step, batch=self.batch)
        return NelderMead(dimension, start, step=min(step, 0.5))


# What cma imports at its own import for features tensim never uses: plotting (pyplot, which
# also chooses a plotting backend for the whole process, which a library must not) and its
# surrogate fitness models' rank correlation (scipy.stats; cma has a fallback of its own).
_CMA_UNUSED = ("matplotlib.pyplot", "scipy.stats")


def import_cma() -> ModuleType:
    """The ``cma`` package, imported without :data:`_CMA_UNUSED` (over a second of CPU per
    learning run): while cma loads they are made unimportable, which cma accepts (the warning
    it gives is silenced here); they import normally afterwards.
    """
    if "cma" in sys.modules:
        return sys.modules["cma"]
    blocked = [name for name in _CMA_UNUSED if name not in sys.modules]
    for name in blocked:
        sys.modules[name] = None  # type: ignore[assignment]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import cma
    finally:
        for name in blocked:
            del sys.modules[name]
    return cma
