"""Prints how the MuJoCo Warp back-end compares with the CPU engine (docs/gpu.md).

    python docs/warp_check.py [--device cpu|cuda] [--duration 1.0]

Tetraspine3 under an 8 N push, on its CPG gait, and on the gait with doubled friction and
10 % stiffer cables, run for ``--duration`` seconds on both back-ends; prints the largest
differences of tension, peak tension and centre of mass, and the Warp batch's wall time per
physics step.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from tensim.control import load_controller
from tensim.model import compile_structure
from tensim.models import preset
from tensim.sim import PhysicsScale, Trial, ramp_hold_release, run_batch


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--duration", type=float, default=1.0)
    args = parser.parse_args()
    p = preset("tetraspine3")
    structure = p.build()
    compiled = compile_structure(structure)
    gait = load_controller("tetraspine3_cpg", structure).with_duration(args.duration).build(
        compiled.model.opt.timestep)
    push = ramp_hold_release("s2_tip", (0.0, 1.0, 0.5), 8.0, 0.2, 0.3, 0.4, 0.1)
    trials = [Trial(p.controller(), loads=(push,)), Trial(gait),
              Trial(gait, physics=PhysicsScale(stiffness=1.1, friction=2.0))]
    run_batch(compiled, trials[:1], 0.01, backend="warp", device=args.device)  # compile
    start = time.perf_counter()
    warp = run_batch(compiled, trials, args.duration, backend="warp", device=args.device)
    wall = time.perf_counter() - start
    cpu = run_batch(compiled, trials, args.duration)
    for name, w, c in zip(("push", "CPG gait", "gait, friction x2, stiffness x1.1"), warp, cpu,
                          strict=True):
        a, b = c.result.trajectory, w.result.trajectory
        tension = np.abs(a.matrix("tension") - b.matrix("tension")).max()
        peak = np.abs(w.result.peak_tension - c.result.peak_tension).max()
        com = max(np.abs(a[f"pos_{x}/com"] - b[f"pos_{x}/com"]).max() for x in "xyz")
        print(f"{name}: tension within {tension:.2f} N (max {a.matrix('tension').max():.1f} N), "
              f"peak within {peak:.2f} N, centre of mass within {com:.1e} m")
    steps = round(args.duration / compiled.model.opt.timestep)
    print(f"warp on {args.device}: {wall / steps * 1e3:.1f} ms per step for {len(trials)} "
          f"worlds ({args.duration:g} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
