"""Prints the effect of each engine option on the disturbance test: speed and maximum tensions.

Each option set runs the 60 s disturbance test (``tensim experiment disturbance``) several
times, interleaved with the others so that a loaded machine slows them all alike; the table
gives the best and median CPU time per physics step of the whole simulation loop and the
largest change of any cable's maximum tension against the defaults, and whether the recorded
tensions are bit-identical to the defaults'.

Usage: python benchmarks/engine_options.py [--repeats N] [--duration S]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import mujoco
import numpy as np

from tensim.experiments.disturbance import DURATION, disturbance_loads, record_period
from tensim.model import WorldOptions, compile_structure
from tensim.models import preset
from tensim.sim import SimulationResult, simulate


def _set(**fields: object) -> Callable[[object], None]:
    def apply(opt: object) -> None:
        for name, value in fields.items():
            setattr(opt, name, value)
    return apply


# name -> (world options, a change to MuJoCo's options after compiling, for options that
# WorldOptions does not carry)
OPTIONS: dict[str, tuple[WorldOptions, Callable[[object], None]]] = {
    "defaults (midphase off, self-collision on)": (WorldOptions(), _set()),
    "midphase on (MuJoCo's default)": (WorldOptions(midphase=True), _set()),
    "self_collision=False": (WorldOptions(self_collision=False), _set()),
    "solver tolerance 1e-5 (default 1e-8)": (WorldOptions(), _set(tolerance=1e-5)),
    "CG solver (default Newton)": (WorldOptions(), _set(solver=mujoco.mjtSolver.mjSOL_CG)),
    "PGS solver": (WorldOptions(), _set(solver=mujoco.mjtSolver.mjSOL_PGS)),
    "cone='elliptic' (default pyramidal)": (WorldOptions(cone="elliptic"), _set()),
    "noslip_iterations=10 (default 0)": (WorldOptions(noslip_iterations=10), _set()),
    "condim=4 (torsional friction 0.005 m)": (WorldOptions(condim=4), _set()),
    "condim=6 (and rolling friction 1e-4 m)": (WorldOptions(condim=6), _set()),
    "condim=6, elliptic, noslip_iterations=10": (
        WorldOptions(condim=6, cone="elliptic", noslip_iterations=10), _set()),
    "sparse Jacobians (default dense here)": (
        WorldOptions(), _set(jacobian=mujoco.mjtJacobian.mjJAC_SPARSE)),
}


def run(world: WorldOptions, change: Callable[[object], None],
        duration: float) -> SimulationResult:
    """The disturbance test (``tensim experiment disturbance``) under these options."""
    model, loads = preset("tetraspine3"), disturbance_loads()
    # compiled with the loads' force inputs, so the run uses this model as changed
    compiled = compile_structure(model.build(), world,
                                 load_nodes=tuple(load.node for load in loads))
    change(compiled.model.opt)
    return simulate(compiled, duration, controller=model.controller(), loads=loads,
                    record_dt=record_period(world.timestep))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--duration", type=float, default=DURATION, help="simulated time [s]")
    args = parser.parse_args()
    cpu: dict[str, list[float]] = {name: [] for name in OPTIONS}
    peaks: dict[str, np.ndarray] = {}
    tensions: dict[str, np.ndarray] = {}
    for _ in range(args.repeats):
        for name, (world, change) in OPTIONS.items():
            start = time.process_time()
            result = run(world, change, args.duration)
            cpu[name].append(time.process_time() - start)
            peaks[name] = result.peak_tension
            tensions[name] = result.trajectory.matrix("tension")
    steps = round(args.duration / 1e-3)
    base = peaks[next(iter(OPTIONS))]
    print(f"{'option set':<44} {'us/step best':>12} {'median':>7} {'speed-up':>8} "
          f"{'max tension change':>19}  tensions")
    reference = min(cpu[next(iter(OPTIONS))])
    for name in OPTIONS:
        change = float(np.max(np.abs(peaks[name] - base) / base)) * 100
        same = np.array_equal(tensions[name], tensions[next(iter(OPTIONS))])
        print(f"{name:<44} {min(cpu[name]) / steps * 1e6:>12.1f} "
              f"{statistics.median(cpu[name]) / steps * 1e6:>7.1f} "
              f"{reference / min(cpu[name]):>7.2f}x {change:>18.4f}%  "
              f"{'bit-identical' if same else 'differ'}")


if __name__ == "__main__":
    main()
