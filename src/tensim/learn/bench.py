"""Learning throughput: evaluations per second of CMA-ES on Tetraspine3 CPG gaits.

The points of a CMA-ES run are evaluated as a whole ``tensim learn`` run, as bare batches on
threads, on a warm process pool, one plain simulation after another, and replayed by
``mujoco.rollout`` on the same threads (the engine's batched limit for the same work).
"""

from __future__ import annotations

import dataclasses
import os
import tempfile
import time
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from tensim.control import SolverSettings, SpineCPG
from tensim.learn.executors import ProcessPoolExecutor, ThreadBatchExecutor
from tensim.learn.families import default_base
from tensim.learn.optimizers import OptimizerSettings
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


def _build_cpu_s(problem: TrialProblem, points: np.ndarray, backend: str) -> float:
    """CPU time to build one point's gait, its CPG integrated by ``backend`` (``"auto"``: as
    learning does, compiled where built; ``"scipy"``), averaged over ``points`` [s]."""
    dt = problem.compiled().model.opt.timestep
    settings = SolverSettings(backend=backend)
    start = time.process_time()
    for unit in points:
        config = problem.controller(unit)
        if not isinstance(config.gait, SpineCPG):
            raise TypeError(f"a CPG problem's gait is a SpineCPG, got {type(config.gait)}")
        config.with_gait(dataclasses.replace(config.gait, settings=settings)).build(dt)
    return (time.process_time() - start) / len(points)


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


def _threads_s(problem: TrialProblem, points: np.ndarray, workers: int) -> float:
    """Wall time of the trials as batches on ``workers`` threads [s]."""
    start = time.perf_counter()
    with ThreadBatchExecutor(problem, workers) as executor:  # any gait builders start here
        done = sum(1 for _ in executor.run(list(enumerate(points))))
    if done != len(points):
        raise RuntimeError("the batch lost trials")
    return time.perf_counter() - start


def _rollout_s(problem: TrialProblem, points: np.ndarray, workers: int) -> float:
    """Wall time of ``mujoco.rollout`` replaying the same trials' ctrl on ``workers`` threads,
    the engine's batched limit for the same work [s]."""
    from mujoco import rollout

    from tensim.bench_batch import rollout_inputs

    models, state, control, nstep = rollout_inputs(problem, points)
    datas = [mujoco.MjData(models[0]) for _ in range(workers)]
    start = time.perf_counter()
    rollout.rollout(models, datas, state, control, nstep=nstep)
    return time.perf_counter() - start


def _cpu_s() -> float:
    """CPU time of this process and its finished child processes [s]."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def _learn_run_s(problem: TrialProblem, evaluations: int, workers: int
                 ) -> tuple[float, float, np.ndarray]:
    """Wall and CPU time of a whole CMA-ES ``learn`` run on ``workers`` threads, from the call
    to the written run folder, and the points it evaluated."""
    from tensim.learn.run import LearningSettings, learn
    from tensim.learn.store import RunStore

    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "run"
        settings = LearningSettings(OptimizerSettings("cma"), evaluations, seed=0)
        start, cpu = time.perf_counter(), _cpu_s()
        learn(problem, settings, out, executor=lambda p: ThreadBatchExecutor(p, workers))
        wall, cpu = time.perf_counter() - start, _cpu_s() - cpu
        points = np.array([e.unit for _, e in sorted(RunStore(out).evaluations().items())])
    return wall, cpu, points


def bench_learning(duration: float = 10.0, evaluations: int = 20, repeats: int = 2
                   ) -> dict[str, Any]:
    """Evaluations per second of CMA-ES learning on Tetraspine3 CPG gaits, 2 threads.

    A whole ``learn`` run (run folder, optimizer, batches on threads, learning curve) is timed;
    then its evaluated points again as bare batches on threads, on a process pool of 2 workers
    (the earlier engine), and as ``mujoco.rollout`` of the same inputs on 2 threads (the
    engine's limit). Interleaved, best of ``repeats``.

    Returns:
        evaluations per second of each, and the ratios to the rollout limit.
    """
    problem = _problem(duration)
    walls: dict[str, list[float]] = {"learn": [], "threads": [], "processes": [],
                                     "rollout": [], "plain_1_thread": []}
    points = np.empty((0, problem.dimension))
    cpus = []
    for _ in range(repeats):
        wall, cpu, points = _learn_run_s(problem, evaluations, 2)
        walls["learn"].append(wall)
        cpus.append(cpu)
        walls["threads"].append(_threads_s(problem, points, 2))
        walls["processes"].append(_pool_s(problem, points, 2, 1))
        walls["rollout"].append(_rollout_s(problem, points, 2))
    walls["plain_1_thread"].append(_plain_simulation_s(problem, points, 1))
    # the gaits: what the rollout's ready-made controls cost to make
    build = min(_build_cpu_s(problem, points, "auto") for _ in range(3))
    n = len(points)
    walls["rollout_with_gaits"] = [min(walls["rollout"]) + build * n]
    rate = {k: n / min(v) for k, v in walls.items()}
    return {
        "machine_scaling_2_over_1": machine_scaling(),
        "case": f"tetraspine3 cpg, CMA-ES, {n} evaluations of {duration:g} s",
        "evaluations": n,
        "evaluations_per_s": rate,
        "learn_over_rollout": rate["learn"] / rate["rollout"],
        "threads_over_rollout": rate["threads"] / rate["rollout"],
        "processes_over_rollout": rate["processes"] / rate["rollout"],
        "learn_over_rollout_with_gaits": rate["learn"] / rate["rollout_with_gaits"],
        "gait_build_cpu_s": build,
        "gait_build_scipy_cpu_s": _build_cpu_s(problem, points, "scipy"),
        "learn_cpu_s_per_evaluation": min(cpus) / n,
    }


def format_learning(report: dict[str, Any]) -> str:
    """The learning figures as a few printed lines."""
    rate = report["evaluations_per_s"]
    return (f"learning ({report['case']}, 2 threads or workers):\n"
            f"  tensim learn {rate['learn']:.2f} evaluations/s "
            f"({report['learn_cpu_s_per_evaluation']:.2f} s of CPU each; "
            f"{report['learn_over_rollout']:.2f} of mujoco.rollout's "
            f"{rate['rollout']:.2f}); bare batches {rate['threads']:.2f} "
            f"({report['threads_over_rollout']:.2f}); process pool {rate['processes']:.2f} "
            f"({report['processes_over_rollout']:.2f}); one plain simulation after another "
            f"{rate['plain_1_thread']:.2f}\n"
            f"  building a CPG gait takes {report['gait_build_cpu_s'] * 1e3:.1f} ms of CPU "
            f"(through scipy in Python {report['gait_build_scipy_cpu_s'] * 1e3:.1f} ms, "
            f"{report['gait_build_scipy_cpu_s'] / report['gait_build_cpu_s']:.0f}x as much); "
            f"against "
            f"mujoco.rollout plus those builds ({rate['rollout_with_gaits']:.2f}/s) tensim "
            f"learn runs at {report['learn_over_rollout_with_gaits']:.2f}\n"
            f"  (a pure-Python busy loop scales {report['machine_scaling_2_over_1']:.2f}x on 2 "
            f"processes on this machine now)")
