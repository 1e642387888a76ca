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
import dataclasses
import statistics
import time

import numpy as np

from tensim.experiments import run_disturbance
from tensim.model import WorldOptions

OPTIONS = {
    "defaults (midphase off, self-collision on)": WorldOptions(),
    "midphase on (MuJoCo's default)": WorldOptions(midphase=True),
    "self_collision=False": WorldOptions(self_collision=False),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--duration", type=float, default=60.0, help="simulated time [s]")
    args = parser.parse_args()
    cpu: dict[str, list[float]] = {name: [] for name in OPTIONS}
    peaks: dict[str, np.ndarray] = {}
    tensions: dict[str, np.ndarray] = {}
    for _ in range(args.repeats):
        for name, world in OPTIONS.items():
            start = time.process_time()
            result, _ = run_disturbance(duration=args.duration,
                                        world=dataclasses.replace(world))
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
