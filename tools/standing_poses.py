"""Writes the stored standing poses of the shipped rolling presets,
``src/tensim/models/standing/<preset>.json``, solved by the design tools from the current code.

``three_bar``, ``six_bar`` and ``superball`` built with their default arguments read their
static pose on the ground from these files instead of solving it at every load (their rolling
runs are chaotic: a solve that moved the pose by round-off moved every rolling figure). Run
this after changing such a preset's parameters (``tests/test_standing_poses.py`` fails until
you do), then rerun the rolling figures of docs/rolling.md and docs/rl.md: they move with it.

Without ``--write`` it only compares each stored pose with a fresh solve on this machine:
bit-identical, or the largest difference.

Usage: python tools/standing_poses.py [--write]
"""

from __future__ import annotations

import argparse
import json

from tensim._files import write_text
from tensim.models import six_bar, superball, three_bar
from tensim.models._standing import STORED, pose_record, standing, stored_standing
from tensim.structure import Structure

PRESETS = (three_bar, six_bar, superball)


def solved(build) -> Structure:
    """The preset's static pose, solved now (what its default arguments read from its file)."""
    return standing(build(standing=False))


def pose_text(pose: Structure) -> str:
    """The file's JSON: a node or a cable a line, each float its exact repr."""
    record = pose_record(pose)

    def block(key: str) -> str:
        rows = [f"    {json.dumps(k)}: {json.dumps(v)}" for k, v in record[key].items()]
        return f'  "{key}": {{\n' + ",\n".join(rows) + "\n  }"

    head = [f"  {json.dumps(k)}: {json.dumps(record[k])}" for k in ("about", "structure")]
    return "{\n" + ",\n".join([*head, block("nodes"), block("rest_lengths")]) + "\n}\n"


def difference(stored: Structure, fresh: Structure) -> float:
    """The largest difference of a node coordinate or a rest length [m]."""
    nodes = max(abs(a - b) for m, n in zip(stored.nodes, fresh.nodes, strict=True)
                for a, b in zip(m.position, n.position, strict=True))
    rest = max(abs(stored.rest_length(a) - fresh.rest_length(b))
               for a, b in zip(stored.cables, fresh.cables, strict=True))
    return max(nodes, rest)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true", help="write the files")
    args = parser.parse_args()
    for build in PRESETS:
        fresh = solved(build)
        path = STORED / f"{fresh.name}.json"
        if args.write:
            STORED.mkdir(exist_ok=True)
            write_text(path, pose_text(fresh))
            print(f"wrote {path.name}")
            continue
        stored = stored_standing(build(standing=False))
        same = pose_record(stored) == pose_record(fresh)
        print(f"{fresh.name}: " + ("bit-identical to a fresh solve" if same else
                                   f"{difference(stored, fresh):.3g} m from a fresh solve"))


if __name__ == "__main__":
    main()
