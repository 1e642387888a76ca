"""Speed benchmark: simulated seconds per wall second, controlled loop vs MuJoCo alone.

For each case the full tensim loop (cable law, motors, controller, recording at 100 Hz,
stability checks) runs from a settled state, and MuJoCo alone replays exactly the same cable
forces with ``mujoco.rollout`` on the robot with the law taken out (each cable a plain force
input, no callback, no Python per step), which is the engine's limit for that trajectory.
Both run single-threaded and take turns (tensim, engine, tensim, ...), so a load on a shared
machine slows both alike; each run's CPU time is measured beside its wall time, and the ratio
comes from the best CPU times.
"""

from __future__ import annotations

import dataclasses
import statistics
import time
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
from mujoco import rollout

from tensim.benchmarks._machine import core_share, load_average
from tensim.control import ControllerConfig, load_controller
from tensim.model import (
    CompiledModel,
    WorldOptions,
    compile_spec,
    compile_structure,
    without_cable_law,
)
from tensim.model._split import MARGIN as SPLIT_MARGIN
from tensim.models import preset
from tensim.sim import Controller, Simulation, compiled_available
from tensim.sim._record_native import available as record_loop_available
from tensim.structure import CableContact
from tensim.terrain import Flat, Terrain

SETTLE_S = 1.0


@dataclasses.dataclass(frozen=True)
class Timing:
    """Repeated timings of one loop, per physics step [us].

    Attributes:
        cpu: CPU time of this process per step, one entry per run [us].
        wall: wall-clock time per step, one entry per run [us].
    """

    cpu: tuple[float, ...]
    wall: tuple[float, ...]

    def best(self, kind: str = "cpu") -> float:
        """The fastest run [us per step]."""
        return min(getattr(self, kind))

    def median(self, kind: str = "cpu") -> float:
        """The median run [us per step]."""
        return statistics.median(getattr(self, kind))

    def core_share(self, threads: int = 1) -> float:
        """Median over runs of CPU time / (wall time x threads)."""
        return core_share(self.cpu, self.wall, threads)


@dataclasses.dataclass(frozen=True)
class BenchCase:
    """One benchmark figure set; the tensim loop and MuJoCo alone ran interleaved.

    Attributes:
        name: case name.
        dt: physics step [s].
        tensim: the full tensim loop's timings.
        engine: MuJoCo alone's timings on the same inputs.
    """

    name: str
    dt: float
    tensim: Timing
    engine: Timing

    @property
    def ratio(self) -> float:
        """tensim rate / engine-alone rate, from the best CPU times (1: no overhead)."""
        return self.engine.best() / self.tensim.best()

    def figures(self) -> dict[str, float]:
        """JSON-ready figures: best and median CPU and wall time per step, real-time factors
        from the best CPU time, and the ratio."""
        out: dict[str, float] = {}
        for who, timing in (("", self.tensim), ("engine_", self.engine)):
            for kind in ("cpu", "wall"):
                out[f"{who}{kind}_us_per_step_best"] = round(timing.best(kind), 3)
                out[f"{who}{kind}_us_per_step_median"] = round(timing.median(kind), 3)
            out[f"{who}real_time_factor"] = round(self.dt * 1e6 / timing.best(), 2)
        return {**out, "ratio_to_engine": round(self.ratio, 4)}


def _interleaved(loops: dict[str, Callable[[], None]], repeats: int, steps: int
                 ) -> dict[str, Timing]:
    """Runs each loop ``repeats`` times in turn (A B A B ...), so load on a shared machine
    falls on all of them alike; CPU and wall time per step of each run [us]."""
    cpu: dict[str, list[float]] = {name: [] for name in loops}
    wall: dict[str, list[float]] = {name: [] for name in loops}
    for _ in range(repeats):
        for name, loop in loops.items():
            c0, w0 = time.process_time(), time.perf_counter()
            loop()
            cpu[name].append((time.process_time() - c0) / steps * 1e6)
            wall[name].append((time.perf_counter() - w0) / steps * 1e6)
    return {name: Timing(tuple(cpu[name]), tuple(wall[name])) for name in loops}


def bench_model(name: str, duration: float = 10.0, repeats: int = 3,
                controlled: bool = True, controller_file: str | None = None,
                terrain: Terrain | None = None, contact_tags: tuple[str, ...] = (),
                config: ControllerConfig | None = None) -> BenchCase:
    """Benchmarks preset ``name`` for ``duration`` simulated seconds, ``repeats`` times,
    tensim and MuJoCo alone interleaved.

    Args:
        name: the preset.
        duration: simulated time per run [s].
        repeats: runs of each loop.
        controlled: drive the cables with the preset's impedance controller.
        controller_file: drive them with this controller file's gait instead (its V* table
            is computed before the timed loop, as in any simulation).
        terrain: the ground (None: flat).
        contact_tags: cables with any of these tags become contact cables (default beads).
        config: drive the cables with this controller instead (e.g. a scenario's).
    """
    model = preset(name)
    structure = model.build()
    if contact_tags:
        structure = dataclasses.replace(structure, cables=tuple(
            dataclasses.replace(c, contact=CableContact()) if set(c.tags) & set(contact_tags) else c
            for c in structure.cables))
    compiled = compile_structure(structure, WorldOptions(terrain=terrain or Flat()))
    m = compiled.model
    controller: Controller | None = model.controller() if controlled else None
    if controller_file is not None:
        config = load_controller(controller_file, structure)
    if config is not None:
        controller = config.with_duration(SETTLE_S + duration).build(m.opt.timestep)
    with Simulation(compiled, controller=controller) as sim:
        sim.step(int(SETTLE_S / sim.dt))
        state = sim.get_state()
        n_steps = round(duration / sim.dt)

        def loop() -> None:
            sim.set_state(state)
            sim.run(duration)

        # the cable forces of this run, for the engine-alone replay
        sim.set_state(state)
        forces = np.empty((1, n_steps, compiled.n_cables))
        for k in range(n_steps):
            sim.step(1)
            forces[0, k] = sim.data.actuator_force[:compiled.n_cables]
        engine, start, warmstart = engine_alone(compiled, state)
        data = mujoco.MjData(engine)

        def engine_run() -> None:
            rollout.rollout(engine, data, start, forces, initial_warmstart=warmstart)

        timings = _interleaved({"tensim": loop, "engine": engine_run}, repeats, n_steps)
    label = f" ({controller_file})" if controller_file else f" ({config.description})" if config \
        else "" if controlled else " (passive)"
    label += f" on {type(terrain).__name__.lower()}" if terrain else ""
    label += f", contact cables {'/'.join(contact_tags)}" if contact_tags else ""
    return BenchCase(f"{name}{label}", m.opt.timestep, timings["tensim"], timings["engine"])


DISCRETE_EXPLICIT = "explicit, discrete step"  # bench_laws' row: the integrator alone
DISCRETE_TENDONS = "tendons, discrete step"  # and with the cables as tendon springs (cost only)


def split_row(margin: float) -> str:
    """bench_laws' row of the implicit law split by cable at ``margin``."""
    return f"implicit, split {margin:g}"


def bench_laws(duration: float = 10.0, repeats: int = 3, name: str = "tetraspine3",
               dt: float = 1e-3, split_margin: float = SPLIT_MARGIN) -> dict[str, Any]:
    """The cost of a step under each cable law (``WorldOptions.cable_law``): preset ``name``
    under its impedance controller (if it has one) at step ``dt``, the laws' loops taking
    turns; a row after the laws runs the implicit law split by cable at ``split_margin``
    (``WorldOptions.split_margin``).

    A further row runs the explicit law on MuJoCo's ``discrete`` step (the implicit law's
    integrator, with no cable in its metric), which separates the integrator's own cost from
    that of the cables the implicit law couples into it; a last row adds to it every cable's
    share of stiffness and damping as MuJoCo tendon springs and dampers (a spring at the settled
    length: the cost of tendon terms in the metric against actuator gains, not a law: the
    springs act while slack too). After the timed runs each loop runs
    once more from the same state, one step at a time, for what MuJoCo does per step: the
    constraint solver's iterations summed over its islands (the explicit law's free bodies
    are solved as separate islands, which the cables of the implicit law's metric join into
    one), the islands, and the cables whose terms MuJoCo's integrator takes (the taut cables
    under the implicit laws: in ``discrete``'s metric, or ``implicitfast``'s damping).

    Returns:
        JSON-ready figures: per law, the best and median CPU and wall time per step [us], the
        ratio of its best CPU time to the explicit law's, and the per-step means above.
    """
    from tensim.model._law_layout import CABLE_LAWS, LAW_EXPLICIT, LAW_IMPLICIT, implicit

    model = preset(name)
    structure = model.build()
    loops: dict[str, Callable[[], None]] = {}
    sims: dict[str, Simulation] = {}
    states: dict[str, np.ndarray] = {}
    rows = [(law, law, 0.0) for law in CABLE_LAWS] + [
        (split_row(split_margin), LAW_IMPLICIT, split_margin),
        (DISCRETE_EXPLICIT, LAW_EXPLICIT, 0.0), (DISCRETE_TENDONS, LAW_EXPLICIT, 0.0)]
    for row, law, margin in rows:
        compiled = compile_structure(structure, WorldOptions(timestep=dt, cable_law=law,
                                                             split_margin=margin))
        sim = Simulation(compiled, controller=model.controller(),
                         record_dt=max(1, round(0.01 / dt)) * dt)  # a whole number of steps
        sims[row] = sim
        if row in (DISCRETE_EXPLICIT, DISCRETE_TENDONS):
            sim.model.opt.integrator = mujoco.mjtIntegrator.mjINT_DISCRETE
        sim.step(int(SETTLE_S / sim.dt))
        if row == DISCRETE_TENDONS:
            _tendon_springs(sim)
        states[row] = state = sim.get_state()

        def loop(sim: Simulation = sim, state: np.ndarray = state) -> None:
            sim.set_state(state)
            sim.run(duration)
        loops[row] = loop
    try:
        n_steps = round(duration / dt)
        timings = _interleaved(loops, repeats, n_steps)
        per_step = {}
        for row, sim in sims.items():
            sim.set_state(states[row])
            m, d, n = sim.model, sim.data, sim.compiled.n_cables
            pull = (m.actuator_actadr + m.actuator_actnum - 1)[:n][implicit(m)[:n]]
            counts = np.zeros((n_steps, 3))
            springs = np.count_nonzero(m.tendon_damping[m.actuator_trnid[:n, 0]])
            for k in range(n_steps):
                sim.step(1)
                counts[k] = (d.solver_niter[:max(1, d.nisland)].sum(), d.nisland,
                             np.count_nonzero(d.act[pull]) + springs)
            per_step[row] = counts.mean(axis=0)
    finally:
        for sim in sims.values():
            sim.close()
    base = timings[CABLE_LAWS[0]].best()
    return {"model": name, "dt_s": dt, "duration_s": duration, "repeats": repeats,
            "laws": {row: {"cpu_us_per_step_best": round(t.best(), 3),
                           "cpu_us_per_step_median": round(t.median(), 3),
                           "wall_us_per_step_best": round(t.best("wall"), 3),
                           "ratio_to_explicit": round(t.best() / base, 3),
                           "solver_iterations_per_step": round(float(per_step[row][0]), 3),
                           "islands_per_step": round(float(per_step[row][1]), 3),
                           "integrator_cables_per_step": round(float(per_step[row][2]), 3)}
                     for row, t in timings.items()},
            "core_share": min(t.core_share() for t in timings.values())}


def _tendon_springs(sim: Simulation) -> None:
    """Gives every cable's tendon the implicit law's share of its stiffness and damping as a
    MuJoCo tendon spring (at its present length) and damper."""
    from tensim.model._law_layout import G_DAMPING, G_STIFFNESS, THETA_DISCRETE

    m, n = sim.model, sim.compiled.n_cables
    tendons = m.actuator_trnid[:n, 0]
    m.tendon_stiffness[tendons] = THETA_DISCRETE * m.actuator_gainprm[:n, G_STIFFNESS]
    m.tendon_damping[tendons] = THETA_DISCRETE * m.actuator_gainprm[:n, G_DAMPING]
    m.tendon_lengthspring[tendons] = sim.data.ten_length[tendons, None]


def format_laws(report: dict[str, Any]) -> str:
    """The per-law table of :func:`bench_laws`."""
    lines = [f"cable laws, {report['model']} at {report['dt_s'] * 1e3:g} ms, "
             f"{report['repeats']} runs each taking turns: us per step (CPU best / median, "
             "wall best), ratio to the explicit law from the best CPU times; per step: the "
             "constraint solver's iterations (all islands), its islands, the taut cables "
             "whose terms MuJoCo's integrator takes"]
    for law, f in report["laws"].items():
        lines.append(f"  {law:<23} {f['cpu_us_per_step_best']:7.1f} / "
                     f"{f['cpu_us_per_step_median']:<7.1f} {f['wall_us_per_step_best']:7.1f}"
                     f" {f['ratio_to_explicit']:6.2f}x   {f['solver_iterations_per_step']:5.2f}"
                     f" it {f['islands_per_step']:4.2f} isl {f['integrator_cables_per_step']:5.2f}"
                     " cables")
    return "\n".join(lines)


CONTACT_TAGS = ("outer_left", "outer_right")  # the spine's lowest cables: they meet the wall


def climb_cases(duration: float = 10.0, repeats: int = 3) -> list[BenchCase]:
    """The 12-segment Tetraspine's wall climb with straight cables and with its lowest cables
    (``CONTACT_TAGS``) as contact cables, interleaved in one set of runs' conditions."""
    from tensim.experiments.climb import CLIMB_TERRAIN, climb_controller

    config = climb_controller(SETTLE_S + duration)
    return [bench_model("tetraspine", duration, repeats, config=config, terrain=CLIMB_TERRAIN,
                        contact_tags=tags) for tags in ((), CONTACT_TAGS)]


def engine_alone(compiled: CompiledModel, state: np.ndarray
                 ) -> tuple[mujoco.MjModel, np.ndarray, np.ndarray]:
    """The same robot with the cable law taken out: each cable a plain force input (ctrl =
    actuator force [N]), and a tensim state (``mjSTATE_INTEGRATION``) moved onto it.

    Returns:
        (model, full-physics initial state, (1, nv) warm start).
    """
    engine = compile_spec(without_cable_law(compiled))
    data = mujoco.MjData(compiled.model)
    mujoco.mj_setState(compiled.model, data, state, mujoco.mjtState.mjSTATE_INTEGRATION)
    full = mujoco.mjtState.mjSTATE_FULLPHYSICS
    bare = mujoco.MjData(engine)
    bare.time, bare.qpos[:], bare.qvel[:] = data.time, data.qpos, data.qvel
    start = np.empty(mujoco.mj_stateSize(engine, full))
    mujoco.mj_getState(engine, bare, start, full)
    return engine, start, data.qacc_warmstart[None].copy()


def run_benchmarks(duration: float = 10.0, repeats: int = 3) -> dict[str, Any]:
    """The cases: Tetraspine3 under impedance control and on its CPG gait; a passive six-bar;
    the 12-segment Tetraspine sidewinding on flat ground and on its goal gait over the goal
    scenario's rough height field; its wall climb with straight and with contact cables."""
    from tensim.experiments.goal import GOAL_TERRAIN  # 2 cm RMS bumps on a 4 cm grid

    load = load_average()
    cases = [bench_model("tetraspine3", duration, repeats),
             bench_model("tetraspine3", duration, repeats, controller_file="tetraspine3_cpg"),
             bench_model("six_bar", duration, repeats, controlled=False),
             bench_model("tetraspine", duration, repeats, controller_file="tetraspine_sidewind"),
             bench_model("tetraspine", duration, repeats, controller_file="tetraspine_goal",
                         terrain=GOAL_TERRAIN)]
    cases += climb_cases(duration, repeats)
    return {
        "compiled_callback": compiled_available(),
        "compiled_record_loop": record_loop_available(),
        "load_average_before": load,
        "core_share": {c.name: min(c.tensim.core_share(), c.engine.core_share()) for c in cases},
        "duration_s": duration,
        "repeats": repeats,
        "cases": [{"name": c.name, **c.figures()} for c in cases],
    }
