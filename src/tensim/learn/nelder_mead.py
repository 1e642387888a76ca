"""Nelder-Mead with an ask/tell interface: scipy's algorithm, step by step.

``scipy.optimize.minimize(method="Nelder-Mead")`` owns its loop and calls the objective one
point at a time, so it can neither hand a batch of trials to parallel workers nor be
checkpointed between trials. :class:`NelderMead` performs the same steps as scipy's
implementation (the same coefficients, the adaptive ones of Gao and Han for high dimensions,
the same clipping to the bounds, the same sorting and the same stopping test) as a small state
machine; the tests check that it visits exactly the points scipy visits. The initial simplex
and a shrink are asked as batches, the other steps one point at a time.
"""

from __future__ import annotations

import numpy as np

_LOWER, _UPPER = 0.0, 1.0  # the unit cube


class NelderMead:
    """Bounded Nelder-Mead simplex search on the unit cube, minimizing.

    Args:
        dimension: number of parameters N.
        start: (N,) the first vertex.
        step: edge of the initial simplex: vertex k moves coordinate k by ``step`` (inward
            where it would leave the cube), in unit-cube units.
        adaptive: scipy's ``adaptive`` option (coefficients scaled with N; for N > 10 or so).
        xatol, fatol: scipy's stopping tolerances on the simplex size and the cost spread.
        initial_simplex: (N + 1, N) vertices overriding ``start`` and ``step``.
    """

    name = "nelder-mead"

    def __init__(self, dimension: int, start: np.ndarray, *, step: float = 0.1,
                 adaptive: bool = True, xatol: float = 1e-4, fatol: float = 1e-4,
                 initial_simplex: np.ndarray | None = None):
        n = int(dimension)
        if n < 1:
            raise ValueError(f"dimension must be >= 1, got {dimension}")
        if not 0 < step <= 0.5:
            raise ValueError(f"step must be in (0, 0.5] of the unit cube, got {step}")
        if adaptive:
            self.rho, self.chi, self.psi, self.sigma = 1.0, 1 + 2 / n, 0.75 - 1 / (2 * n), 1 - 1 / n
        else:
            self.rho, self.chi, self.psi, self.sigma = 1.0, 2.0, 0.5, 0.5
        self.xatol, self.fatol = xatol, fatol
        if initial_simplex is None:
            x0 = np.clip(np.asarray(start, dtype=float), _LOWER, _UPPER)
            offsets = np.where(x0 + step <= _UPPER, step, -step)
            sim = np.vstack([x0, x0 + np.diag(offsets)])
        else:
            sim = np.array(initial_simplex, dtype=float)
            if sim.shape != (n + 1, n):
                raise ValueError(f"initial_simplex must be ({n + 1}, {n}), got {sim.shape}")
        # scipy: vertices above the upper bound are reflected inside, then all are clipped
        sim = np.where(sim > _UPPER, 2 * _UPPER - sim, sim)
        self.sim = np.clip(sim, _LOWER, _UPPER)
        self.fsim = np.full(n + 1, np.inf)
        self.stage = "simplex"
        self.stop_reason = ""
        self._trial = np.empty(0)  # the pending reflection / expansion / contraction point
        self._xr, self._fxr = np.empty(0), np.inf
        self._xbar = np.empty(0)

    @property
    def done(self) -> bool:
        """Whether the simplex has converged (scipy's xatol and fatol test)."""
        return self.stage == "done"

    def ask(self) -> np.ndarray:
        """(k, N) the points whose costs the next :meth:`tell` needs."""
        sim = self.sim
        if self.stage == "simplex":
            return sim.copy()
        if self.stage == "shrink":
            moved = sim[0] + self.sigma * (sim[1:] - sim[0])
            return np.clip(moved, _LOWER, _UPPER)
        if self.stage == "reflect":
            self._xbar = np.add.reduce(sim[:-1], 0) / (sim.shape[0] - 1)
            factor = self.rho
        elif self.stage == "expand":
            factor = self.rho * self.chi
        elif self.stage == "outside":
            factor = self.psi * self.rho
        elif self.stage == "inside":
            factor = -self.psi
        else:
            raise RuntimeError(f"nothing to ask: the search is {self.stage}")
        self._trial = np.clip((1 + factor) * self._xbar - factor * sim[-1], _LOWER, _UPPER)
        return self._trial[None].copy()

    def tell(self, points: np.ndarray, costs: np.ndarray) -> None:
        """Takes the costs of the points of the last :meth:`ask`, in the same order."""
        costs = np.asarray(costs, dtype=float)
        stage = self.stage
        if stage == "simplex":
            self.fsim = costs.copy()
            self._sort()  # scipy sorts the initial simplex twice
            self._end_iteration()
            return
        if stage == "shrink":
            self.sim[1:] = np.asarray(points, dtype=float)
            self.fsim[1:] = costs
            self._end_iteration()
            return
        f = float(costs[0])
        if stage == "reflect":
            self._xr, self._fxr = self._trial, f
            if f < self.fsim[0]:
                self.stage = "expand"
            elif f < self.fsim[-2]:
                self._replace_worst(self._trial, f)
            else:
                self.stage = "outside" if f < self.fsim[-1] else "inside"
        elif stage == "expand":
            better = f < self._fxr
            self._replace_worst(self._trial if better else self._xr, f if better else self._fxr)
        elif stage == "outside":
            if f <= self._fxr:
                self._replace_worst(self._trial, f)
            else:
                self.stage = "shrink"
        elif stage == "inside":
            if f < self.fsim[-1]:
                self._replace_worst(self._trial, f)
            else:
                self.stage = "shrink"

    # -- steps ---------------------------------------------------------------------------------

    def _replace_worst(self, x: np.ndarray, f: float) -> None:
        self.sim[-1], self.fsim[-1] = x, f
        self._end_iteration()

    def _sort(self) -> None:
        order = np.argsort(self.fsim)
        self.sim, self.fsim = np.take(self.sim, order, 0), np.take(self.fsim, order, 0)

    def _end_iteration(self) -> None:
        self._sort()
        spread_x = np.max(np.ravel(np.abs(self.sim[1:] - self.sim[0])))
        spread_f = np.max(np.abs(self.fsim[0] - self.fsim[1:]))
        if spread_x <= self.xatol and spread_f <= self.fatol:
            self.stage, self.stop_reason = "done", "simplex converged (xatol and fatol)"
        else:
            self.stage = "reflect"
