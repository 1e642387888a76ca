"""Speed benchmark: simulated seconds per wall second, controlled loop vs MuJoCo alone.

For each case the full tensim loop (cable callback, motors, controller, recording at 100 Hz,
stability checks) runs from a settled state; then MuJoCo alone replays exactly the same
actuator inputs with ``mujoco.rollout`` (no callback, no Python per step), which is the
engine's limit for that trajectory. Both run single-threaded.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import mujoco
import numpy as np
from mujoco import rollout

from tensim.control import load_controller
from tensim.model import WorldOptions, compile_structure
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
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        start = np.empty(mujoco.mj_stateSize(m, spec))
        mujoco.mj_getState(m, sim.data, start, spec)
        warmstart = sim.data.qacc_warmstart[None].copy()
        drive, steps = sim.drive, sim._steps
        motors = (drive.rest.copy(), drive.peak.copy(), drive.last_time.copy())
        n_steps = round(duration / sim.dt)

        def restart() -> None:
            mujoco.mj_setState(m, sim.data, start, spec)
            drive.rest[:], drive.peak[:], drive.last_time[:] = motors
            sim._steps = steps

        # the actuator inputs of this run, for the engine-alone replay
        restart()
        ctrl = np.empty((1, n_steps, m.nu))
        for k in range(n_steps):
            mujoco.mj_step(m, sim.data)
            ctrl[0, k] = sim.data.ctrl

        def loop() -> float:
            restart()
            t0 = time.perf_counter()
            sim.run(duration)
            return time.perf_counter() - t0

        wall = _best(loop, repeats)
    data = mujoco.MjData(m)

    def engine() -> float:
        t0 = time.perf_counter()
        rollout.rollout(m, data, start, ctrl, initial_warmstart=warmstart)
        return time.perf_counter() - t0

    engine_wall = _best(engine, repeats)
    label = f" ({controller_file})" if controller_file else "" if controlled else " (passive)"
    label += f" on {type(terrain).__name__.lower()}" if terrain else ""
    return BenchCase(f"{name}{label}", duration / wall,
                     duration / engine_wall, wall / n_steps * 1e6, engine_wall / n_steps * 1e6)


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
