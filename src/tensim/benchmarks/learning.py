"""Learning throughput: evaluations per second of CMA-ES on Tetraspine3 CPG gaits.

The points of a CMA-ES run are evaluated as a whole ``tensim learn`` run, as bare batches on
threads, on a warm process pool, one plain simulation after another, and replayed by
``mujoco.rollout`` on the same threads (the engine's batched limit for the same work). Each
is timed in wall time and in CPU time (its worker processes' included), taking turns, and the
ratios to the rollout are given in both: on a shared machine the wall times stretch with other
programs' load, and a line says when the machine was too busy for them to mean anything.
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import os
import tempfile
import time
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from tensim.benchmarks._machine import core_share, load_average, machine_note
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


Clock = tuple[float, float]  # (wall, CPU) time of one run [s]


def _plain_simulation_s(problem: TrialProblem, points: np.ndarray) -> Clock:
    """Wall and CPU time of the trials as plain simulations in this process [s]."""
    compiled = problem.compiled()
    start, cpu = time.perf_counter(), time.process_time()
    for unit in points:
        controller = problem.controller(unit).build(compiled.model.opt.timestep)
        simulate(compiled, problem.duration_s, controller=controller, record_dt=problem.record_dt)
    return time.perf_counter() - start, time.process_time() - cpu


def _workers_cpu_s() -> float:
    """CPU time of this process's live worker processes so far [s] (Linux's /proc; 0
    elsewhere)."""
    total = 0.0
    for child in multiprocessing.active_children():
        try:
            fields = Path(f"/proc/{child.pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime, stime
    return total


def _pool_s(problem: TrialProblem, points: np.ndarray, workers: int) -> Clock:
    """Wall and CPU time (the workers' included) of the trials through a warm pool of
    ``workers`` [s]."""
    tasks = list(enumerate(points))
    with ProcessPoolExecutor(problem, workers) as pool:
        pool.warm_up()
        start, cpu = time.perf_counter(), time.process_time() + _workers_cpu_s()
        done = sum(1 for _ in pool.run(tasks))
        clock = time.perf_counter() - start, time.process_time() + _workers_cpu_s() - cpu
    if done != len(points):
        raise RuntimeError("the pool lost trials")
    return clock


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


def _threads_s(problem: TrialProblem, points: np.ndarray, workers: int) -> Clock:
    """Wall and CPU time of the trials as batches on ``workers`` threads [s]."""
    start, cpu = time.perf_counter(), _cpu_s()
    with ThreadBatchExecutor(problem, workers) as executor:  # any gait builders start here
        done = sum(1 for _ in executor.run(list(enumerate(points))))
    if done != len(points):
        raise RuntimeError("the batch lost trials")
    return time.perf_counter() - start, _cpu_s() - cpu


def _rollout_s(problem: TrialProblem, points: np.ndarray, workers: int) -> Clock:
    """Wall and CPU time of ``mujoco.rollout`` replaying the same trials' ctrl on ``workers``
    threads, the engine's batched limit for the same work [s]."""
    from mujoco import rollout

    from tensim.benchmarks.batch import rollout_inputs

    models, state, control, nstep = rollout_inputs(problem, points)
    datas = [mujoco.MjData(models[0]) for _ in range(workers)]
    start, cpu = time.perf_counter(), time.process_time()
    rollout.rollout(models, datas, state, control, nstep=nstep)
    return time.perf_counter() - start, time.process_time() - cpu


def _cpu_s() -> float:
    """CPU time of this process and its finished child processes [s]."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def _learn_run_s(problem: TrialProblem, evaluations: int, workers: int
                 ) -> tuple[Clock, np.ndarray]:
    """Wall and CPU time of a whole CMA-ES ``learn`` run on ``workers`` threads, from the call
    to the written run folder, and the points it evaluated."""
    from tensim.learn.run import LearningSettings, learn
    from tensim.learn.store import RunStore

    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "run"
        settings = LearningSettings(OptimizerSettings("cma"), evaluations, seed=0)
        start, cpu = time.perf_counter(), _cpu_s()
        learn(problem, settings, out, executor=lambda p: ThreadBatchExecutor(p, workers))
        clock = time.perf_counter() - start, _cpu_s() - cpu
        points = np.array([e.unit for _, e in sorted(RunStore(out).evaluations().items())])
    return clock, points


def bench_learning(duration: float = 10.0, evaluations: int = 20, repeats: int = 2
                   ) -> dict[str, Any]:
    """Evaluations per second of CMA-ES learning on Tetraspine3 CPG gaits, 2 threads.

    A whole ``learn`` run (run folder, optimizer, batches on threads, learning curve) is timed;
    then its evaluated points again as bare batches on threads, on a process pool of 2 workers
    (the earlier engine), and as ``mujoco.rollout`` of the same inputs on 2 threads (the
    engine's limit). Interleaved, best of ``repeats``, in wall and in CPU time.

    Returns:
        evaluations per second of each (wall) and CPU seconds per evaluation, the ratios to
        the rollout limit from each, the core shares
        (:func:`~tensim.benchmarks._machine.core_share`) and the load average before the runs.
    """
    load = load_average()
    problem = _problem(duration)
    clocks: dict[str, list[Clock]] = {"learn": [], "threads": [], "processes": [],
                                      "rollout": []}
    points = np.empty((0, problem.dimension))
    for _ in range(repeats):
        clock, points = _learn_run_s(problem, evaluations, 2)
        clocks["learn"].append(clock)
        clocks["threads"].append(_threads_s(problem, points, 2))
        clocks["processes"].append(_pool_s(problem, points, 2))
        clocks["rollout"].append(_rollout_s(problem, points, 2))
    clocks["plain_1_thread"] = [_plain_simulation_s(problem, points)]
    # the gaits: what the rollout's ready-made controls cost to make (CPU time)
    build = min(_build_cpu_s(problem, points, "auto") for _ in range(3))
    n = len(points)
    wall = {k: min(w for w, _ in v) for k, v in clocks.items()}
    cpu = {k: min(c for _, c in v) for k, v in clocks.items()}
    wall["rollout_with_gaits"] = wall["rollout"] + build * n
    cpu["rollout_with_gaits"] = cpu["rollout"] + build * n
    rate = {k: n / v for k, v in wall.items()}
    threads = {"plain_1_thread": 1}
    return {
        "machine_scaling_2_over_1": machine_scaling(),
        "load_average_before": load,
        "case": f"tetraspine3 cpg, CMA-ES, {n} evaluations of {duration:g} s",
        "evaluations": n,
        "evaluations_per_s": rate,
        "cpu_s_per_evaluation": {k: v / n for k, v in cpu.items()},
        "core_share": {k: core_share([c for _, c in v], [w for w, _ in v], threads.get(k, 2))
                       for k, v in clocks.items()},
        **{f"{k}_over_rollout": rate[k] / rate["rollout"]
           for k in ("learn", "threads", "processes")},
        **{f"{k}_over_rollout_cpu": cpu["rollout"] / cpu[k]
           for k in ("learn", "threads", "processes")},
        "learn_over_rollout_with_gaits": rate["learn"] / rate["rollout_with_gaits"],
        "learn_over_rollout_with_gaits_cpu": cpu["rollout_with_gaits"] / cpu["learn"],
        "gait_build_cpu_s": build,
        "gait_build_scipy_cpu_s": _build_cpu_s(problem, points, "scipy"),
        "learn_cpu_s_per_evaluation": cpu["learn"] / n,
    }


def format_learning(report: dict[str, Any]) -> str:
    """The learning figures as a few printed lines."""
    rate, cpu = report["evaluations_per_s"], report["cpu_s_per_evaluation"]
    # the verdict on the machine comes from the runs that keep their threads busy throughout
    # (a learn run has serial stretches: the optimizer, the run folder)
    shares = {k: report["core_share"][k] for k in ("threads", "rollout", "plain_1_thread")}
    return (f"learning ({report['case']}, 2 threads or workers):\n"
            f"  evaluations/s: tensim learn {rate['learn']:.2f}, mujoco.rollout "
            f"{rate['rollout']:.2f}, bare batches {rate['threads']:.2f}, process pool "
            f"{rate['processes']:.2f}, one plain simulation after another "
            f"{rate['plain_1_thread']:.2f}\n"
            f"  CPU time per evaluation: tensim learn {cpu['learn']:.3f} s, mujoco.rollout "
            f"{cpu['rollout']:.3f} s, bare batches {cpu['threads']:.3f} s, process pool "
            f"{cpu['processes']:.3f} s\n"
            f"  of mujoco.rollout's rate, in CPU time (wall time): tensim learn "
            f"{report['learn_over_rollout_cpu']:.2f} ({report['learn_over_rollout']:.2f}), "
            f"bare batches {report['threads_over_rollout_cpu']:.2f} "
            f"({report['threads_over_rollout']:.2f}), process pool "
            f"{report['processes_over_rollout_cpu']:.2f} ({report['processes_over_rollout']:.2f})"
            f"\n"
            f"  building a CPG gait takes {report['gait_build_cpu_s'] * 1e3:.1f} ms of CPU "
            f"(through scipy in Python {report['gait_build_scipy_cpu_s'] * 1e3:.1f} ms, "
            f"{report['gait_build_scipy_cpu_s'] / report['gait_build_cpu_s']:.0f}x as much); "
            f"against mujoco.rollout plus those builds tensim learn runs at "
            f"{report['learn_over_rollout_with_gaits_cpu']:.2f} in CPU time "
            f"({report['learn_over_rollout_with_gaits']:.2f} in wall time)\n"
            f"  (a pure-Python busy loop scales {report['machine_scaling_2_over_1']:.2f}x on 2 "
            f"processes on this machine now)\n"
            f"  {machine_note(shares, report['load_average_before'])}")
