"""Learning throughput: evaluations per second with 1 and 2 worker processes.

The same Monte Carlo sample of Tetraspine3 CPG gaits (10 s trials) is run three ways: each
trial as a plain simulation in this process (gait generation + :func:`tensim.simulate`, the
work of one ``tensim simulate`` without its file output), then through the learning
executor's process pool with 1 and with 2 workers (trial, scoring and result transfer). The
pools are started and their robots compiled before the clock starts, as in a long run.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from tensim.learn.executors import ProcessPoolExecutor
from tensim.learn.families import default_base
from tensim.learn.problem import TrialProblem
from tensim.models import preset
from tensim.sim import simulate


def _problem(duration: float) -> TrialProblem:
    structure = preset("tetraspine3").build()
    return TrialProblem(structure, default_base("tetraspine3", "cpg", structure), "cpg",
                        duration, model="tetraspine3")


def _plain_simulation_s(problem: TrialProblem, points: np.ndarray, repeats: int) -> float:
    """Wall time of the trials as plain simulations in this process, best of ``repeats`` [s]."""
    compiled = problem.compiled()

    def once() -> float:
        start = time.perf_counter()
        for unit in points:
            controller = problem.controller(unit).build(compiled.model.opt.timestep)
            simulate(compiled, problem.duration_s, controller=controller,
                     record_dt=problem.record_dt)
        return time.perf_counter() - start

    return min(once() for _ in range(repeats))


def _pool_s(problem: TrialProblem, points: np.ndarray, workers: int, repeats: int) -> float:
    """Wall time of the trials through a warm pool of ``workers``, best of ``repeats`` [s]."""
    tasks = list(enumerate(points))
    with ProcessPoolExecutor(problem, workers) as pool:
        pool.warm_up()
        walls = []
        for _ in range(repeats):
            start = time.perf_counter()
            done = sum(1 for _ in pool.run(tasks))
            walls.append(time.perf_counter() - start)
    if done != len(points):
        raise RuntimeError("the pool lost trials")
    return min(walls)


def _busy(n: int) -> int:
    total = 0
    for i in range(n):
        total += i
    return total


def machine_scaling(repeats: int = 3, n: int = 4_000_000) -> float:
    """How much faster 2 processes do 4 pure-Python busy loops than 1 does: what this
    machine offers right now (below 2 when other programs hold a core)."""
    import concurrent.futures as cf

    def wall(workers: int) -> float:
        with cf.ProcessPoolExecutor(workers) as pool:
            list(pool.map(_busy, [1] * workers))  # start the workers
            best = float("inf")
            for _ in range(repeats):
                start = time.perf_counter()
                list(pool.map(_busy, [n] * 4))
                best = min(best, time.perf_counter() - start)
        return best

    return wall(1) / wall(2)


def bench_learning(duration: float = 10.0, trials: int = 8, repeats: int = 2,
                   seed: int = 0) -> dict[str, Any]:
    """Evaluations per second for ``trials`` trials of ``duration`` seconds (best of
    ``repeats``).

    Returns:
        ``evaluations_per_s`` for 1 and 2 workers, ``scaling_2_over_1``,
        ``machine_scaling_2_over_1`` (the same for a busy loop: the machine's free cores),
        ``trial_cost_ratio`` (1-worker wall per trial / plain simulation per trial) and the
        underlying times.
    """
    problem = _problem(duration)
    points = np.random.default_rng(seed).random((trials, problem.dimension))
    plain = _plain_simulation_s(problem, points, repeats)
    one = _pool_s(problem, points, 1, repeats)
    two = _pool_s(problem, points, 2, repeats)
    return {
        "machine_scaling_2_over_1": machine_scaling(),
        "case": f"tetraspine3 cpg, {duration:g} s trials",
        "trials": trials,
        "plain_simulation_s_per_trial": plain / trials,
        "evaluations_per_s": {"1": trials / one, "2": trials / two},
        "scaling_2_over_1": one / two,
        "trial_cost_ratio": one / plain,
    }


def format_learning(report: dict[str, Any]) -> str:
    """The learning figures as a few printed lines."""
    rate = report["evaluations_per_s"]
    return (f"learning ({report['case']}, {report['trials']} trials): "
            f"{rate['1']:.2f} evaluations/s with 1 worker, {rate['2']:.2f} with 2 "
            f"(scaling {report['scaling_2_over_1']:.2f}x; a pure-Python busy loop scales "
            f"{report['machine_scaling_2_over_1']:.2f}x on this machine now)\n"
            f"  a trial through the pool costs {report['trial_cost_ratio']:.3f}x a plain "
            f"simulation of the same length ({report['plain_simulation_s_per_trial']:.3f} s)")
