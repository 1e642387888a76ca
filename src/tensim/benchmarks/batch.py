"""Batch benchmark: many Tetraspine3 CPG trials per call, against ``mujoco.rollout``.

N trials of different CPG gaits (random points of the learning layout, built once before the
clock starts, as ``mujoco.rollout`` gets its controls ready-made) run two ways, interleaved and
each timed in wall and process CPU time: through :func:`run_batch` on 1 and 2 threads
(controllers set up, stepping, recording, channels), and as ``mujoco.rollout`` replaying the
same per-step ``ctrl`` on the same per-trial models on the same thread count (the cable law
runs inside MuJoCo in both), which is the engine's batched limit for that work. The gaits'
build time is printed apart. The ratios are given from the best CPU times (the work each
does, which other programs on the machine hardly change) beside the best wall times, with a
line saying whether the machine was too busy for the wall times to mean anything.
"""

from __future__ import annotations

import copy
import functools
import resource
import statistics
import time
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
from mujoco import rollout

from tensim.benchmarks._machine import core_share, load_average, machine_note
from tensim.learn.families import default_base
from tensim.learn.problem import TrialProblem
from tensim.model import BUILD_KEY
from tensim.models import preset
from tensim.sim import Trial, install_law, run_batch
from tensim.sim._batch import setup_trial


def _problem(duration: float) -> TrialProblem:
    structure = preset("tetraspine3").build()
    return TrialProblem(structure, default_base("tetraspine3", "cpg", structure), "cpg",
                        duration, model="tetraspine3")


def _timed(fn: Callable[[], object]) -> tuple[float, float]:
    wall, cpu = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - wall, time.process_time() - cpu


def rollout_inputs(problem: TrialProblem, points: np.ndarray
                   ) -> tuple[list[mujoco.MjModel], np.ndarray, np.ndarray, int]:
    """Per-trial models (set up as a batch sets up its trials), the initial state and the
    (N, nstep, nu) ctrl of the same trials, for ``mujoco.rollout`` (with the compiled law
    installed, as it is here)."""
    install_law("compiled")
    compiled = problem.compiled()
    m, dt = compiled.model, compiled.model.opt.timestep
    nstep = round(problem.duration_s / dt) + 1
    models, controls = [], []
    for unit in points:
        model = copy.copy(m)
        plan = setup_trial(compiled, model, Trial(problem.controller(unit).build(dt)), dt)
        models.append(model)
        controls.append(plan.control(0, nstep))
    data = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, data, m.key(BUILD_KEY).id)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, data, state, spec)
    return models, state, np.stack(controls), nstep


def bench_batch(trials: int = 64, duration: float = 10.0, repeats: int = 3,
                seed: int = 0) -> dict[str, Any]:
    """Trials per second of the batch engine and of ``mujoco.rollout`` on 1 and 2 threads.

    Returns:
        per method and thread count: best and median wall and CPU time [s], trials/s and the
        core share (:func:`~tensim.benchmarks._machine.core_share`); the ratios
        batch/rollout (from wall and from CPU time) and 2-thread/1-thread scaling; peak
        resident memory [MiB]; the load average before the runs.
    """
    load = load_average()
    install_law("compiled")
    problem = _problem(duration)
    compiled = problem.compiled()
    points = np.random.default_rng(seed).random((trials, problem.dimension))
    models, state, control, nstep = rollout_inputs(problem, points)

    dt = compiled.model.opt.timestep
    built = time.process_time()
    controllers = [problem.controller(u).build(dt) for u in points]  # the CPG integrations
    build_cpu = time.process_time() - built

    def batch(threads: int) -> None:
        run_batch(compiled, [Trial(c) for c in controllers], duration, threads=threads,
                  record_dt=problem.record_dt)

    def engine(threads: int) -> None:
        datas = [mujoco.MjData(models[0]) for _ in range(threads)]
        rollout.rollout(models, datas, state, control, nstep=nstep)

    times: dict[str, list[tuple[float, float]]] = {}
    for _ in range(repeats):  # interleaved: every method once per round
        for threads in (1, 2):
            for name, fn in (("batch", batch), ("rollout", engine)):
                times.setdefault(f"{name}_{threads}", []).append(
                    _timed(functools.partial(fn, threads)))
    figures: dict[str, Any] = {}
    for key, runs in times.items():
        walls, cpus = [w for w, _ in runs], [c for _, c in runs]
        figures[key] = {"wall_best_s": min(walls), "wall_median_s": statistics.median(walls),
                        "cpu_best_s": min(cpus), "trials_per_s": trials / min(walls),
                        "core_share": core_share(cpus, walls, int(key[-1]))}
    return {
        "case": f"tetraspine3 cpg, {trials} trials of {duration:g} s",
        "load_average_before": load,
        **figures,
        "batch_over_rollout": {t: figures[f"rollout_{t}"]["wall_best_s"]
                               / figures[f"batch_{t}"]["wall_best_s"] for t in (1, 2)},
        "batch_over_rollout_cpu": {t: figures[f"rollout_{t}"]["cpu_best_s"]
                                   / figures[f"batch_{t}"]["cpu_best_s"] for t in (1, 2)},
        "scaling_2_over_1": {m: figures[f"{m}_1"]["wall_best_s"] / figures[f"{m}_2"]["wall_best_s"]
                             for m in ("batch", "rollout")},
        "peak_rss_MiB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "gait_build_cpu_s_per_trial": build_cpu / trials,
        "batch_process_peak_MiB": batch_memory_mib(trials, duration),
        "real_time_factor_2_threads": trials * duration / figures["batch_2"]["wall_best_s"],
    }


_MEMORY_PROBE = """
import resource, sys
import numpy as np
from tensim.benchmarks.batch import _problem
from tensim.sim import Trial, run_batch
trials, duration = int(sys.argv[1]), float(sys.argv[2])
problem = _problem(duration)
compiled = problem.compiled()
points = np.random.default_rng(0).random((trials, problem.dimension))
controllers = [problem.controller(u).build(compiled.model.opt.timestep) for u in points]
run_batch(compiled, [Trial(c) for c in controllers], duration, threads=2)
# VmHWM: this process's own peak (ru_maxrss would carry the parent's over the fork)
with open("/proc/self/status") as status:
    peak = [line for line in status if line.startswith("VmHWM:")]
own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print((int(peak[0].split()[1]) if peak else own) / 1024)
"""


def batch_memory_mib(trials: int, duration: float) -> float:
    """Peak resident memory [MiB] of a fresh process that runs one batch on 2 threads
    (Python, tensim, MuJoCo and the recorded channels of every trial included)."""
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", _MEMORY_PROBE, str(trials), str(duration)],
                         check=True, capture_output=True, text=True).stdout
    return float(out.split()[-1])


def format_batch(report: dict[str, Any]) -> str:
    """The batch figures as a few printed lines."""
    lines = [f"batch ({report['case']}):"]
    for threads in (1, 2):
        b, r = report[f"batch_{threads}"], report[f"rollout_{threads}"]
        lines.append(f"  {threads} thread(s): batch {b['trials_per_s']:.2f} trials/s "
                     f"(wall best {b['wall_best_s']:.2f} s, median {b['wall_median_s']:.2f} s, "
                     f"CPU {b['cpu_best_s']:.2f} s); mujoco.rollout {r['trials_per_s']:.2f} "
                     f"trials/s (CPU {r['cpu_best_s']:.2f} s); batch/rollout "
                     f"{report['batch_over_rollout_cpu'][threads]:.3f} in CPU time, "
                     f"{report['batch_over_rollout'][threads]:.3f} in wall time")
    s = report["scaling_2_over_1"]
    lines.append(f"  2 threads / 1: batch {s['batch']:.2f}x, rollout {s['rollout']:.2f}x; "
                 f"{report['real_time_factor_2_threads']:.0f}x real time in all; peak memory "
                 f"of this process {report['peak_rss_MiB']:.0f} MiB (rollout's outputs "
                 f"included)")
    lines.append(f"  building a trial's CPG gait (before the batch, not timed above): "
                 f"{report['gait_build_cpu_s_per_trial'] * 1e3:.0f} ms of CPU; a process "
                 f"that runs just the batch peaks at {report['batch_process_peak_MiB']:.0f} MiB")
    shares = {f"{m} on {t} thread(s)": report[f"{m}_{t}"]["core_share"]
              for t in (1, 2) for m in ("batch", "rollout")}
    lines.append("  " + machine_note(shares, report["load_average_before"]))
    return "\n".join(lines)


if __name__ == "__main__":
    print(format_batch(bench_batch()))
