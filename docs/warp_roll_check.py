"""Prints how the rolling 3-bar rolls on the MuJoCo Warp back-end beside the CPU engine
(docs/gpu.md).

    python docs/warp_roll_check.py [--device cpu|cuda] [--worlds 256] [--duration 10]

The motorised ``three_bar`` on its learned rolling gait (``three_bar_roll``, learned toward
-30 degrees), one world per friction coefficient spread over 0.8-1.2, run for ``--duration``
seconds on both back-ends (the CPU engine on every core). Rolling is chaotic (a tip's timing
moves every later one), so worlds are not compared one by one: each back-end's speed along the
heading in body lengths per second (centre of mass, from the recorded trajectories) is printed
as its mean, spread and range over the worlds, with the wall time of each batch.
"""

from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np

from tensim.control import load_controller
from tensim.model import compile_structure
from tensim.models import preset
from tensim.sim import PhysicsScale, Trial, run_batch
from tensim.structure import body_length

HEADING_DEG = -30.0  # the heading the shipped gait was learned toward


def speeds(results: list, length: float, duration: float) -> np.ndarray:
    """Each finished world's speed along the heading [body lengths/s] (NaN where it failed)."""
    heading = np.array([math.cos(math.radians(HEADING_DEG)), math.sin(math.radians(HEADING_DEG))])
    out = np.full(len(results), np.nan)
    for i, r in enumerate(results):
        if r.result is not None:
            t = r.result.trajectory
            moved = np.array([t["pos_x/com"][-1] - t["pos_x/com"][0],
                              t["pos_y/com"][-1] - t["pos_y/com"][0]])
            out[i] = moved @ heading / length / duration
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--worlds", type=int, default=256)
    parser.add_argument("--duration", type=float, default=10.0)
    args = parser.parse_args()
    structure = preset("three_bar").build()
    compiled = compile_structure(structure)
    gait = load_controller("three_bar_roll", structure).with_duration(args.duration).build(
        compiled.model.opt.timestep)
    n = args.worlds
    trials = [Trial(gait, physics=PhysicsScale(friction=0.8 + 0.4 * i / max(n - 1, 1)))
              for i in range(n)]
    run_batch(compiled, trials[:1], 0.01, backend="warp", device=args.device)  # compile
    length = body_length(structure)
    for name, kwargs in (("warp", {"backend": "warp", "device": args.device}),
                         ("cpu", {"threads": os.cpu_count() or 1})):
        start = time.perf_counter()
        results = run_batch(compiled, trials, args.duration, **kwargs)
        wall = time.perf_counter() - start
        v = speeds(results, length, args.duration)
        ok = v[np.isfinite(v)]
        print(f"{name}: {n} worlds, {n - ok.size} failed; along {HEADING_DEG:g} deg "
              f"{ok.mean():.3f} +- {ok.std():.3f} body lengths/s (range {ok.min():.3f} to "
              f"{ok.max():.3f}); {wall:.1f} s wall")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
