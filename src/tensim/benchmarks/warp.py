"""GPU throughput: many tensegrities at once on MuJoCo Warp, beside the CPU batch engine.

For each case, batches of N worlds (each a trial with its own gait or physics) run through
:func:`tensim.sim.run_batch` with ``backend="warp"``: the whole tensim loop (cable law as a
kernel, held inputs, a CUDA graph per record interval, recording at 100 Hz, stability checks).
The aggregate figure is physics steps of all worlds per second of the stepping loop (the
batch's set-up, the per-world model copies and the gaits' input tables, is timed apart). The
CPU engine (:func:`run_batch` on every core of the host) runs the same kind of trials beside
it. A first short batch per case compiles the kernels and is not counted.

MuJoCo Warp's own limit for the same work is measured beside (engine ``mjwarp``): the same
model with the cable law's kernel, the same number of worlds, its step captured as one CUDA
graph per record interval and replayed, with nothing else: no inputs, recording or checks.
tensim's figure over this one is the share of the GPU's time its loop leaves to physics.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from tensim.control import load_controller
from tensim.model import CompiledModel, WorldOptions, compile_structure
from tensim.models import preset
from tensim.sim import PhysicsScale, Trial, install_law, run_batch

if TYPE_CHECKING:
    from tensim.learn import TrialProblem

DISTINCT_GAITS = 64  # CPG gaits built per case; worlds beyond reuse them with other physics
CASES = ("tetraspine3_cpg", "tetraspine_sidewind", "three_bar_roll", "superball_roll")
# also selectable: the passive prism and SUPERball with their rest lengths held
ALL_CASES = (*CASES, "superball", "prism3")


def _case(name: str, duration: float) -> tuple[str, CompiledModel, Callable[[int], list[Trial]]]:
    """(description, model, trials(n)) of a benchmark case."""
    rng = np.random.default_rng(0)
    if name == "tetraspine3_cpg":
        from tensim.benchmarks.batch import _problem

        problem = _problem(duration)
        return ("Tetraspine3, CPG gaits (12 cables, 18 DoF)", problem.compiled(),
                _drawn_gaits(problem, rng, 1.0, 0.2))
    if name in ("three_bar_roll", "superball_roll"):
        return _rolling_case(name, duration, rng)
    if name == "tetraspine_sidewind":
        structure = preset("tetraspine").build()
        compiled = compile_structure(structure, WorldOptions())
        gait = load_controller("tetraspine_sidewind", structure).with_duration(duration) \
            .build(compiled.model.opt.timestep)
        return ("12-segment Tetraspine sidewinding (66 cables, 72 DoF)", compiled,
                lambda n: [Trial(gait, physics=PhysicsScale(friction=0.8 + 0.4 * i / n))
                           for i in range(n)])
    model = preset(name)
    compiled = compile_structure(model.build(), WorldOptions())
    controller = model.controller()
    return (f"{name}: {model.summary}; no gait (rest lengths held)", compiled,
            lambda n: [Trial(controller, physics=PhysicsScale(stiffness=0.9 + 0.2 * i / n))
                       for i in range(n)])


def _rolling_case(name: str, duration: float, rng: np.random.Generator
                  ) -> tuple[str, CompiledModel, Callable[[int], list[Trial]]]:
    """A motorised rolling robot on rolling gaits: the 3-bar on its learned rolling gait (each
    world another friction), SUPERball on rolling waves drawn at random over its 24 motors."""
    from tensim.learn import TrialProblem, default_base

    robot = name.removesuffix("_roll")
    structure = preset(robot).build()
    problem = TrialProblem(structure, default_base(robot, "roll", structure), "roll", duration,
                           model=robot)
    compiled = problem.compiled()
    dt = compiled.model.opt.timestep
    if robot == "three_bar":
        gait = load_controller("three_bar_roll", structure).with_duration(duration).build(dt)
        return ("motorised 3-bar on its learned rolling gait (9 cables, 6 motorised, 18 DoF)",
                compiled, lambda n: [Trial(gait, physics=PhysicsScale(
                    friction=0.8 + 0.4 * i / n)) for i in range(n)])
    return ("SUPERball on rolling waves (24 motorised cables, 36 DoF)", compiled,
            _drawn_gaits(problem, rng, 0.8, 0.4))


def _drawn_gaits(problem: TrialProblem, rng: np.random.Generator, friction: float,
                 spread: float) -> Callable[[int], list[Trial]]:
    """trials(n) of :data:`DISTINCT_GAITS` gaits drawn at random from ``problem``'s family,
    each reused across worlds with a friction factor from ``friction`` to ``friction +
    spread``."""
    dt = problem.compiled().model.opt.timestep
    points = rng.random((DISTINCT_GAITS, problem.dimension))
    gaits = [problem.controller(u).build(dt) for u in points]
    return lambda n: [Trial(gaits[i % len(gaits)], physics=PhysicsScale(
        friction=friction + spread * (i // len(gaits)) / n)) for i in range(n)]


def engine_alone(compiled: CompiledModel, worlds: int, duration: float,
                 record_steps: int) -> float:
    """Seconds MuJoCo Warp alone takes to step ``worlds`` copies of the model (with the cable
    law's kernel, held at the build pose's commands) for ``duration``: its step captured as a
    graph of ``record_steps`` steps on a CUDA device and replayed, a plain loop elsewhere."""
    import mujoco
    import mujoco_warp as mjw
    import warp as wp

    from tensim.model import BUILD_KEY
    from tensim.sim._warp_batch import world_capacity
    from tensim.sim._warp_law import install_warp_law, warp_host_model

    host = warp_host_model(compiled.model)
    data = mujoco.MjData(host)
    mujoco.mj_resetDataKeyframe(host, data, host.key(BUILD_KEY).id)
    m = mjw.put_model(host)
    install_warp_law(m)
    m.opt.warn_overflow = 0
    rows, contacts = world_capacity(host)
    d = mjw.put_data(host, data, nworld=worlds, nconmax=contacts, njmax=rows)

    def interval() -> None:
        for _ in range(record_steps):
            mjw.step(m, d)

    interval()  # compiles (cached after the tensim batch) and warms up
    graph = None
    if wp.get_device().is_cuda:
        with wp.ScopedCapture() as capture:
            interval()
        graph = capture.graph
    wp.synchronize()
    repeats = max(1, round(duration / (record_steps * host.opt.timestep)))
    started = time.perf_counter()
    for _ in range(repeats):
        if graph is not None:
            wp.capture_launch(graph)
        else:
            interval()
    wp.synchronize()
    return time.perf_counter() - started


def _timed_batch(compiled: CompiledModel, trials: list[Trial], duration: float,
                 **kwargs: Any) -> tuple[float, float, int]:
    """(whole call [s], stepping loop [s], failed trials) of one batch."""
    started = time.perf_counter()
    results = run_batch(compiled, trials, duration, force=True, **kwargs)
    whole = time.perf_counter() - started
    finished = [r.result for r in results if r.result is not None]
    loop = sum(r.wall_s for r in finished) if finished else whole
    return whole, loop, len(results) - len(finished)


def bench_warp(worlds: Sequence[int] = (256, 1024, 4096, 16384), duration: float = 1.0,
               cases: Sequence[str] = CASES, device: str | None = None, cpu_trials: int = 256,
               report: Callable[[dict[str, Any]], None] | None = None,
               max_worlds: dict[str, int] | None = None, record_dt: float = 0.01,
               alone: bool = True) -> dict[str, Any]:
    """Aggregate physics steps per second on MuJoCo Warp against the number of worlds.

    Args:
        worlds: batch sizes to run.
        duration: simulated time of each batch [s].
        cases: names from :data:`CASES`.
        device: the Warp device (None: Warp's default, a GPU where there is one).
        cpu_trials: trials of the CPU engine's batch on all the host's cores.
        report: called with each row as it is measured (progress for long runs).
        max_worlds: per case, the largest batch to run (the 12-segment spine's recorded
            channels fill host memory fastest).
        record_dt: recording period [s] (each record copies the worlds' state to the host).
        alone: beside each Warp batch, time MuJoCo Warp alone on the same model and worlds
            (:func:`engine_alone`; rows of engine ``mjwarp``).

    Returns:
        ``device``, ``host_cores`` and ``rows``: per case and batch size the whole call and
        the stepping loop [s], steps/s and real-time factor of all worlds together; a Warp
        row's ``of_alone`` is its steps/s over MuJoCo Warp's alone.
    """
    import warp as wp

    install_law("compiled")
    threads = os.cpu_count() or 1
    rows: list[dict[str, Any]] = []
    max_worlds = {"tetraspine_sidewind": 4096} if max_worlds is None else max_worlds

    def add(row: dict[str, Any]) -> None:
        rows.append(row)
        if report is not None:
            report(row)

    for name in cases:
        what, compiled, trials = _case(name, duration)
        dt = float(compiled.model.opt.timestep)
        steps = round(duration / dt)
        # the first batch compiles the kernels (cached afterwards) and is not counted
        run_batch(compiled, trials(min(worlds)), 0.02, backend="warp", device=device)
        for n in worlds:
            if n > max_worlds.get(name, n):
                continue
            whole, loop, failed = _timed_batch(compiled, trials(n), duration, backend="warp",
                                               device=device, record_dt=record_dt)
            row = {"case": name, "what": what, "engine": "warp", "worlds": n, "whole_s": whole,
                   "loop_s": loop, "failed": failed, "steps_per_s": n * steps / loop,
                   "real_time_factor": n * duration / loop}
            if alone:
                with wp.ScopedDevice(device):
                    bare = engine_alone(compiled, n, duration, max(1, round(record_dt / dt)))
                row["of_alone"] = bare / loop
                add(row)
                add({"case": name, "what": what, "engine": "mjwarp", "worlds": n,
                     "whole_s": bare, "loop_s": bare, "failed": 0,
                     "steps_per_s": n * steps / bare, "real_time_factor": n * duration / bare})
            else:
                add(row)
        n = cpu_trials
        whole, loop, failed = _timed_batch(compiled, trials(n), duration, backend="cpu",
                                           threads=threads, record_dt=record_dt)
        add({"case": name, "what": what, "engine": f"cpu x{threads}", "worlds": n,
             "whole_s": whole, "loop_s": loop, "failed": failed, "steps_per_s": n * steps / loop,
             "real_time_factor": n * duration / loop})
    dev = wp.get_device(device)
    return {"device": dev.name if not dev.is_cuda else f"{dev.name} ({dev.alias})",
            "host_cores": threads, "duration_s": duration, "record_dt_s": record_dt,
            "rows": rows}


def format_row(row: dict[str, Any]) -> str:
    """One measured batch as a printed line."""
    return (f"{row['case']:<20} {row['engine']:<8} {row['worlds']:>6} worlds: "
            f"{row['steps_per_s']:>12,.0f} steps/s, {row['real_time_factor']:>10,.0f}x real time "
            f"(loop {row['loop_s']:.2f} s, whole call {row['whole_s']:.2f} s"
            + (f", {row['failed']} failed" if row["failed"] else "")
            + (f"; {row['of_alone']:.2f} of MuJoCo Warp alone" if "of_alone" in row else "")
            + ")")
