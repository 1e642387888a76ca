"""The hopper's feet on MuJoCo's soft contacts under a small sideways load, against the statics.

``tensim design loads`` and ``tensim design pull`` hold the feet as pins. A real foot sticks
while its friction holds; MuJoCo's soft friction instead lets a loaded foot creep. This script
stands the hopper on the ground, pushes t0 sideways with 0.6 N (the statics says each foot then
needs less than half its friction) for 3 s, and prints how far the feet and t0 moved with the
default contacts and with MuJoCo's no-slip solver (``WorldOptions(noslip_iterations=20)``, on
the command line ``--contact noslip=20``), beside the statics' answer.

Usage: python examples/design/creep.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import tensim
from tensim.design.inverse import on_ground
from tensim.design.loading import load_response
from tensim.hardware import node_positions
from tensim.model import WorldOptions
from tensim.sim import NodeLoad

FORCE = np.array([0.0, 0.6, 0.0])  # N at t0, from 2 s (after standing) ramped over 1 s
FEET = ("b0", "b1", "b2")


def main() -> None:
    robot = on_ground(tensim.load_structure(Path(__file__).with_name("hopper.yaml")))
    statics = load_response(robot, {"t0": tuple(FORCE)})
    used = max(np.hypot(*f[1, :2]) / f[1, 2] for f in statics.ground.values())
    print(f"statics (pinned feet): t0 moves {1e3 * np.linalg.norm(statics.exact['t0']):.2f} mm; "
          f"the feet use up to {used:.2f} of their friction")
    for label, world in (("default contacts", WorldOptions()),
                         ("noslip_iterations=20", WorldOptions(noslip_iterations=20))):
        compiled = tensim.compile_structure(robot, world, load_nodes=("t0",))
        run = tensim.simulate(compiled, 6.0, record_dt=0.01, loads=[
            NodeLoad("t0", [0.0, 2.0, 3.0], [np.zeros(3), np.zeros(3), FORCE])])
        pos = node_positions(run.trajectory, compiled, ("t0", *FEET))
        start = int(np.searchsorted(run.trajectory.time, 2.0))
        moved = {n: 1e3 * np.linalg.norm(p[-1] - p[start]) for n, p in pos.items()}
        print(f"{label}: in 4 s the feet moved up to {max(moved[f] for f in FEET):.1f} mm, "
              f"t0 {moved['t0']:.1f} mm")


if __name__ == "__main__":
    main()
