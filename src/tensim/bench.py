"""Speed benchmark: simulated seconds per wall second, controlled loop vs MuJoCo alone.

For each case the full tensim loop (cable law, motors, controller, recording at 100 Hz,
stability checks) runs from a settled state; then MuJoCo alone replays exactly the same
cable forces with ``mujoco.rollout`` on the robot with the law taken out (each cable a plain
force input, no callback, no Python per step), which is the engine's limit for that
trajectory. Both run single-threaded.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import mujoco
import numpy as np
from mujoco import rollout

from tensim.control import load_controller
from tensim.model import (
    CompiledModel,
    WorldOptions,
    compile_spec,
    compile_structure,
    without_cable_law,
)
from tensim.models import preset
from tensim.sim import Simulation, compiled_available
from tensim.terrain import Flat, Terrain

SETTLE_S = 1.0


@dataclasses.dataclass(frozen=True)
class BenchCase:
    """One benchmark figure set.

    Attributes:
        name: case name.
        real_time_factor: tensim loop, simulated s per wall s.
        engine_alone_real_time_factor: MuJoCo alone on the same inputs.
        us_per_step: tensim loop cost per physics step [us].
        engine_us_per_step: MuJoCo alone per step [us].
    """

    name: str
    real_time_factor: float
    engine_alone_real_time_factor: float
    us_per_step: float
    engine_us_per_step: float

    @property
    def ratio(self) -> float:
        """tensim rate / engine-alone rate."""
        return self.real_time_factor / self.engine_alone_real_time_factor


def _best(fn: Callable[[], float], repeats: int) -> float:
    return min(fn() for _ in range(repeats))


def bench_model(name: str, duration: float = 10.0, repeats: int = 3,
                controlled: bool = True, controller_file: str | None = None,
                terrain: Terrain | None = None) -> BenchCase:
    """Benchmarks preset ``name`` for ``duration`` simulated seconds (best of ``repeats``).

    Args:
        name: the preset.
        duration: simulated time per run [s].
        repeats: runs; the best counts.
        controlled: drive the cables with the preset's impedance controller.
        controller_file: drive them with this controller file's gait instead (its V* table
            is computed before the timed loop, as in any simulation).
        terrain: the ground (None: flat).
    """
    model = preset(name)
    structure = model.build()
    compiled = compile_structure(structure, WorldOptions(terrain=terrain or Flat()))
    m = compiled.model
    controller = model.controller() if controlled else None
    if controller_file is not None:
        config = load_controller(controller_file, structure)
        controller = config.with_duration(SETTLE_S + duration).build(m.opt.timestep)
    with Simulation(compiled, controller=controller) as sim:
        sim.step(int(SETTLE_S / sim.dt))
        state = sim.get_state()
        n_steps = round(duration / sim.dt)

        def loop() -> float:
            sim.set_state(state)
            t0 = time.perf_counter()
            sim.run(duration)
            return time.perf_counter() - t0

        # the cable forces of this run, for the engine-alone replay
        sim.set_state(state)
        forces = np.empty((1, n_steps, compiled.n_cables))
        for k in range(n_steps):
            sim.step(1)
            forces[0, k] = sim.data.actuator_force[:compiled.n_cables]
        wall = _best(loop, repeats)
    engine, start, warmstart = engine_alone(compiled, state)
    data = mujoco.MjData(engine)

    def engine_run() -> float:
        t0 = time.perf_counter()
        rollout.rollout(engine, data, start, forces, initial_warmstart=warmstart)
        return time.perf_counter() - t0

    engine_wall = _best(engine_run, repeats)
    label = f" ({controller_file})" if controller_file else "" if controlled else " (passive)"
    label += f" on {type(terrain).__name__.lower()}" if terrain else ""
    return BenchCase(f"{name}{label}", duration / wall,
                     duration / engine_wall, wall / n_steps * 1e6, engine_wall / n_steps * 1e6)


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


def run_benchmarks(duration: float = 10.0, repeats: int = 3) -> dict[str, object]:
    """The cases: Tetraspine3 under impedance control and on its CPG gait; a passive six-bar;
    the 12-segment Tetraspine sidewinding on flat ground and on its goal gait over the goal
    scenario's rough height field."""
    from tensim.experiments.goal import GOAL_TERRAIN  # 2 cm RMS bumps on a 4 cm grid

    cases = [bench_model("tetraspine3", duration, repeats),
             bench_model("tetraspine3", duration, repeats, controller_file="tetraspine3_cpg"),
             bench_model("six_bar", duration, repeats, controlled=False),
             bench_model("tetraspine", duration, repeats, controller_file="tetraspine_sidewind"),
             bench_model("tetraspine", duration, repeats, controller_file="tetraspine_goal",
                         terrain=GOAL_TERRAIN)]
    return {
        "compiled_callback": compiled_available(),
        "duration_s": duration,
        "cases": [{**dataclasses.asdict(c), "ratio_to_engine": c.ratio} for c in cases],
    }
