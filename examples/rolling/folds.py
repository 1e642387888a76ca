"""Where the `three_bar` preset's rocks back happen: its hull's folds, and a 30 s run's faces.

A twisted 3-bar prism's six side faces pair up into three *folds*: two faces meeting at a
shallow edge that no member spans, across which the robot rocks at little cost; between
folds lie the sharp edges along the passive verticals, over which each roll must go. The
script prints the angle between the outward normals of every pair of side faces that share
an edge (build pose), then runs the statics gait toward -30 degrees for 30 s (as `tensim
experiment roll three_bar --heading -30 --duration 30`) and splits its rocks back (a change of
face back to the face before, :func:`tensim.control.rolling.rocks_back`) into those across a
fold's edge and those across an edge between folds, and counts the changes of fold.

Usage: python examples/rolling/folds.py
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.spatial import ConvexHull

from tensim.control.rolling import folds, support_face
from tensim.experiments.roll import held_faces, node_bodies, node_paths, roll
from tensim.model import compile_structure
from tensim.models import load_model

FOLD_DEG = 45.0  # side faces whose normals are nearer than this make a fold


def main() -> None:
    robot = load_model("three_bar")
    build = {n.name: np.asarray(n.position, dtype=float) for n in robot.nodes}
    names = list(build)
    hull = ConvexHull(np.array(list(build.values())))
    faces = [frozenset(names[i] for i in s) for s in hull.simplices]
    for (i, a), (j, b) in itertools.combinations(enumerate(faces), 2):
        shared = a & b
        sides = all({n[0] for n in f} == {"b", "t"} for f in (a, b))
        if len(shared) == 2 and sides:
            angle = np.degrees(np.arccos(np.clip(hull.equations[i, :3] @ hull.equations[j, :3],
                                                 -1.0, 1.0)))
            print(f"{' '.join(sorted(a))} | {' '.join(sorted(b))}: across "
                  f"{'-'.join(sorted(shared))}, {angle:.0f} deg")
    fold = folds(build, FOLD_DEG)
    result, summary = roll(robot, 30.0, heading_deg=-30.0)
    # the faces stood on, from the recorded rod poses looked at every 0.05 s, as the gait
    # counts them (tests/test_roll_prism.py checks that the two agree)
    ts = result.trajectory
    nodes = node_bodies(compile_structure(robot).index)
    looked = [support_face(dict(zip(nodes, p, strict=True)))
              for p in node_paths(ts, nodes)[::5]]
    stood, _ = held_faces(looked)

    def key(face: tuple[str, ...]) -> tuple[str, ...]:
        return fold[face][0] if face in fold else face

    rocks = [i for i in range(2, len(stood)) if stood[i] == stood[i - 2]]
    within = sum(1 for i in rocks if key(stood[i]) == key(stood[i - 1]))
    keys = [key(f) for f in stood]
    changes = [k for a, k in itertools.pairwise(keys) if k != a]
    print(f"{summary['rolls']} rolls, {len(rocks)} rocks back: {within} across a fold's edge, "
          f"{len(rocks) - within} between folds; {len(changes)} changes of fold")


if __name__ == "__main__":
    main()
