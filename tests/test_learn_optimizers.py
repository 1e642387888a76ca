"""Ask/tell optimizers: Nelder-Mead equals scipy's, each improves on a sphere, seeds reproduce."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from scipy.optimize import Bounds, minimize

from tensim.learn import (
    CMAES,
    InlineExecutor,
    LearningSettings,
    NelderMead,
    NTRTSearch,
    OptimizerSettings,
    SphereProblem,
    learn,
)


def _rosenbrock(x: np.ndarray) -> float:
    # shifted and scaled into the unit cube: minimum at (0.7, 0.49, ...) after the map x -> 2x
    y = 2 * np.asarray(x) - 0.6
    return float(np.sum(100 * (y[1:] - y[:-1] ** 2) ** 2 + (1 - y[:-1]) ** 2))


def _scipy_points(fun, simplex: np.ndarray, adaptive: bool, maxfev: int) -> list[np.ndarray]:
    visited: list[np.ndarray] = []

    def recorded(x: np.ndarray) -> float:
        visited.append(np.array(x, copy=True))
        return fun(x)

    n = simplex.shape[1]
    minimize(recorded, simplex[0], method="Nelder-Mead", bounds=Bounds(np.zeros(n), np.ones(n)),
             options={"initial_simplex": simplex, "adaptive": adaptive, "maxfev": maxfev,
                      "xatol": 1e-12, "fatol": 1e-12})
    return visited


def _ask_tell_points(fun, simplex: np.ndarray, adaptive: bool, maxfev: int
                     ) -> list[np.ndarray]:
    n = simplex.shape[1]
    search = NelderMead(n, simplex[0], adaptive=adaptive, xatol=1e-12, fatol=1e-12,
                        initial_simplex=simplex)
    visited: list[np.ndarray] = []
    while len(visited) < maxfev and not search.done:
        points = search.ask()
        visited.extend(points)
        search.tell(points, np.array([fun(p) for p in points]))
    return visited[:maxfev]


@pytest.mark.parametrize("adaptive", [False, True])
def test_nelder_mead_visits_exactly_the_points_scipy_visits(adaptive):
    # a start near the upper corner makes scipy's reflection into the bounds and its clipping
    # of trial points take part, as well as reflections, expansions, contractions and shrinks
    start = np.array([0.9, 0.95, 0.2, 0.6])
    simplex = np.vstack([start, start + 0.1 * np.eye(4)])  # 0.95 + 0.1 > 1: reflected inside
    scipy_points = _scipy_points(_rosenbrock, simplex, adaptive, 400)
    ours = _ask_tell_points(_rosenbrock, simplex, adaptive, 400)
    assert len(ours) == len(scipy_points) == 400
    # the same arithmetic in the same order: bit-identical points
    np.testing.assert_array_equal(np.array(ours), np.array(scipy_points))


def test_nelder_mead_stops_when_the_simplex_has_converged():
    search = NelderMead(2, np.array([0.5, 0.5]), step=0.1)
    for _ in range(2000):
        if search.done:
            break
        points = search.ask()
        search.tell(points, np.sum((points - 0.25) ** 2, axis=1))
    assert search.done and "converged" in search.stop_reason
    # xatol = 1e-4 bounds the simplex around the best vertex; the optimum is 0.25, 0.25
    np.testing.assert_allclose(search.sim[0], [0.25, 0.25], atol=1e-3)


@pytest.mark.parametrize("name", ["ntrt", "cma", "nelder-mead"])
def test_each_optimizer_improves_on_a_shifted_sphere(tmp_path, name):
    problem = SphereProblem(6, center=0.3)
    start_score = problem.evaluate(problem.start()).score  # 6 x 0.2² = -0.24
    settings = LearningSettings(OptimizerSettings(name, monte_carlo=24), 200, seed=3)
    result = learn(problem, settings, tmp_path / name, executor=InlineExecutor)
    assert result.nfev == 200
    # uniform random points score -6 (1/12 + 0.04) = -0.74 on average; a tenth of the start's
    # cost is well beyond what 200 random points give (their best is about -0.15)
    assert result.best_score > 0.1 * start_score
    np.testing.assert_allclose(result.x, 0.3, atol=0.12)


def _drive(optimizer, rounds: int) -> list[np.ndarray]:
    asked = []
    for _ in range(rounds):
        points = optimizer.ask()
        asked.append(points)
        optimizer.tell(points, np.sum((points - 0.3) ** 2, axis=1))
    return asked


@pytest.mark.parametrize("make", [
    lambda seed: NTRTSearch(5, seed, monte_carlo=8, batch=4),
    lambda seed: CMAES(5, seed, np.full(5, 0.5)),
    lambda seed: NelderMead(5, np.full(5, 0.5)),
], ids=["ntrt", "cma", "nelder-mead"])
def test_optimizers_repeat_from_the_seed_and_from_a_pickled_checkpoint(make):
    first, second = make(7), make(7)
    a, b = _drive(first, 6), _drive(second, 3)
    copy = pickle.loads(pickle.dumps(second))  # a checkpoint taken after 3 tells
    b += _drive(copy, 3)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


def test_ntrt_samples_the_cube_then_climbs_from_the_best_point():
    search = NTRTSearch(3, 0, monte_carlo=8, batch=4, sigma=0.03)
    samples = np.vstack([search.ask() for _ in range(2)])  # the Monte Carlo phase
    assert samples.shape == (8, 3) and (samples >= 0).all() and (samples <= 1).all()
    costs = np.arange(8.0)
    costs[5] = -1.0  # the best Monte Carlo point
    search.tell(samples[:4], costs[:4])
    search.tell(samples[4:], costs[4:])
    children = search.ask()
    moved = children != samples[5]
    assert moved.any(axis=1).all()  # every child differs from the best in >= 1 parameter
    # Gaussian steps of deviation 0.03: none beyond 6 deviations (probability ~1e-9)
    assert np.abs(children - samples[5]).max() < 6 * 0.03
    # elitist: worse children never replace the best
    search.tell(children, np.full(4, 10.0))
    np.testing.assert_array_equal(search.best_x[0], samples[5])


def test_cma_leaves_numpy_global_random_state_alone():
    np.random.seed(123)  # noqa: NPY002  (the legacy state cma uses)
    expected = np.random.random()  # noqa: NPY002
    np.random.seed(123)  # noqa: NPY002
    optimizer = CMAES(4, 0, np.full(4, 0.5))
    points = optimizer.ask()
    optimizer.tell(points, np.sum(points**2, axis=1))
    assert np.random.random() == expected  # noqa: NPY002


def test_cma_loads_without_pyplot_or_scipy_stats_and_leaves_them_importable():
    """Importing cma for CMA-ES neither chooses a plotting backend (pyplot) nor pays for
    scipy.stats; both import normally afterwards (a fresh interpreter: this one may hold them)."""
    import subprocess
    import sys

    code = ("import sys\nfrom tensim.learn.optimizers import import_cma\ncma = import_cma()\n"
            "assert cma.CMAEvolutionStrategy\n"
            "assert 'matplotlib.pyplot' not in sys.modules and 'scipy.stats' not in sys.modules\n"
            "import scipy.stats, matplotlib.pyplot\n")
    subprocess.run([sys.executable, "-c", code], check=True)
