"""The lab file's 3-bar rolled toward 90 degrees from its build pose and from starts jittered by
a millimetre, with the statics gait's 3-bar settings and with its motors pulling only.

``examples/rolling/three_bar_lab.xml`` is imported (``tensim.io.import_mjcf``) and rolled for
30 s at the file's 1 ms step under the implicit cable law, as `tensim experiment roll
three_bar_lab.yaml --heading 90 --duration 30 --cable-law implicit` rolls it. The 3-bar's
settings (``PRISM_SETTINGS``) pay a cable out up to 50 % above its built rest length where the
statics says so; the file's actuators only pull (with no pull its cable is the tendon spring
at its rest length), so the second setting (``lengthen=0``) keeps to what the file's motors can
do. Rolling is chaotic (docs/rolling.md): each start moves every node by up to 1 mm (uniform,
a seeded draw). Per run: body lengths per second, heading error, rolls over faces, rocks back.

Usage: python examples/rolling/lab_starts.py
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from jittered_starts import jittered_starts  # the script beside this one

from tensim.control.rolling import PRISM_SETTINGS
from tensim.experiments.roll import roll
from tensim.io import import_mjcf

XML = Path(__file__).with_name("three_bar_lab.xml")
HEADING, DURATION, JITTER = 90.0, 30.0, 1e-3  # deg, s, m
SEEDS = (0, 1)


def main() -> None:
    result = import_mjcf(XML, warn=False)
    robot, world = result.structure, dataclasses.replace(result.world, cable_law="implicit")
    starts = jittered_starts(robot, SEEDS, JITTER)
    for label, settings, runs in (("statics", PRISM_SETTINGS, starts),
                                  ("pulling only", dataclasses.replace(PRISM_SETTINGS,
                                                                       lengthen=0.0),
                                   starts[:1])):
        for start, structure in runs:
            _, s = roll(structure, DURATION, heading_deg=HEADING, world=world,
                        settings=settings)
            error = s["heading_error_deg"]
            print(f"{label}, {start}: {s['body_lengths_per_s']:.3f} body lengths/s, heading "
                  f"error {'none' if error is None else f'{error:.1f} deg'}, {s['rolls']} rolls "
                  f"over {s['faces_visited']} faces, {s['rocks_back']} back")


if __name__ == "__main__":
    main()
