"""The `three_bar` preset rolled toward -30 degrees from starts jittered by a millimetre, with
the statics gait's 3-bar settings and with tips searched in simulation (``--searched-tips``).

Rolling is chaotic: one tip more or less changes a 30 s run's distance by a body length, so
one run says little about a setting. Each start moves every node by up to 1 mm (uniform, a
seeded draw); the script prints, per setting, the run from the build pose and from three
jittered starts: body lengths per second, heading error, rolls over faces and the rocks back.

Usage: python examples/rolling/jittered_starts.py
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from tensim.control.rolling import PRISM_SETTINGS, searched
from tensim.experiments.roll import roll
from tensim.models import load_model
from tensim.structure import Structure

HEADING, DURATION, JITTER = -30.0, 30.0, 1e-3  # deg, s, m
SEEDS = (0, 1, 2)


def jittered_starts(robot: Structure, seeds: Sequence[int], jitter_m: float = JITTER
                    ) -> list[tuple[str, Structure]]:
    """The robot as built, then once per seed with every node moved by a uniform draw of up
    to ``jitter_m`` [m] on each axis; each labelled for printing."""
    starts = [("build pose", robot)]
    for seed in seeds:
        rng = np.random.default_rng(seed)
        starts.append((f"jitter {seed}", dataclasses.replace(robot, nodes=tuple(
            dataclasses.replace(n, position=tuple(np.asarray(n.position)
                                                  + rng.uniform(-jitter_m, jitter_m, 3)))
            for n in robot.nodes))))
    return starts


def main() -> None:
    starts = jittered_starts(load_model("three_bar"), SEEDS)
    for label, settings in (("statics", PRISM_SETTINGS),
                            ("searched tips", searched(PRISM_SETTINGS))):
        speeds = []
        for start, structure in starts:
            _, s = roll(structure, DURATION, heading_deg=HEADING, settings=settings)
            speeds.append(s["body_lengths_per_s"])
            print(f"{label}, {start}: {s['body_lengths_per_s']:.3f} body lengths/s, heading "
                  f"error {s['heading_error_deg']:.1f} deg, {s['rolls']} rolls over "
                  f"{s['faces_visited']} faces, {s['rocks_back']} back")
        print(f"{label}: mean {np.mean(speeds):.3f} body lengths/s")


if __name__ == "__main__":
    main()
