"""How far the lab file's motors can move its 3-bar: statics, and MuJoCo's own run of the file.

``examples/rolling/three_bar_lab.xml`` drives each end-triangle cable with a force actuator of
up to 400 N in parallel with a 10 kN/m tendon spring: its tension is k max(0, x - l0) + F,
0 <= F <= 400 N. For each face kind the prism can stand on (its end triangle; a side face,
whose edges are the fold's shallow edge, the sharp edge between folds and the edge on an end
triangle, docs/rolling.md), this script prints:

- statics (:func:`tensim.design.inverse.settle`, the feet held where they stand): how far
  inside each edge the centre of mass lies at rest and, over the 64 patterns of the six
  actuators at rest (F = 0) or full pull (F = 400 N: while the cable is longer than l0, the
  spring with rest length l0 - F / k), the nearest it comes to that edge in a static pose; a
  pattern whose static pose leaves a pulled cable shorter than l0 has no static pose under the
  file's law (there the actuator pulls on alone as the cable shortens and the prism folds)
  and is counted apart;
- MuJoCo (the file itself, no tensim law): each pattern held for 3 s from rest on the face,
  how many change the support face, and over which kind of edge the first change goes.

Usage: python examples/rolling/lab_reach.py
"""

from __future__ import annotations

import itertools
from pathlib import Path

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from tensim.control.roll_plans import face_down_pose, hull_faces
from tensim.control.rolling import support_edges, support_face
from tensim.design.inverse import settle, with_rest_lengths
from tensim.io import import_mjcf

XML = Path(__file__).with_name("three_bar_lab.xml")
PULL_N = 400.0  # the file's gainprm x ctrl at full pull
HOLD_S = 3.0  # each pattern held this long in MuJoCo
LOOK_S = 0.05  # the support face looked at this often, a new one counted once seen twice
BISECT = 7  # halvings of the pull in the search for the largest one that holds
FACES = (("b0", "b1", "b2"), ("b2", "t0", "t1"))  # the end triangle it stands on, a side face


def edge_kinds(positions: dict[str, np.ndarray], face: tuple[str, ...]) -> dict[str, str]:
    """Each edge of the hull face ``face`` ('a-b') -> its kind, from the angle between the
    outward normals of the face and its neighbour across the edge."""
    faces = hull_faces(positions)
    own = faces[tuple(sorted(face))]
    kinds = {}
    for other, normal in faces.items():
        shared = set(other) & set(face)
        if len(shared) == 2:
            angle = np.degrees(np.arccos(float(np.clip(own @ normal, -1, 1))))
            ends = {n[0] for n in shared}
            kind = "end-triangle edge" if len(ends) == 1 else \
                ("fold's edge" if angle < 45 else "edge between folds")
            kinds["-".join(sorted(shared))] = f"{kind}, {angle:.0f} deg"
    return kinds


def edge_of(face: tuple[str, ...], points: dict[str, np.ndarray], line: np.ndarray) -> str:
    off = [abs(points[f][:2] @ line[:2] + line[2]) for f in face]
    return "-".join(sorted(face[i] for i in np.argsort(off)[:2]))


def statics(face: tuple[str, ...]) -> None:
    robot = import_mjcf(XML, warn=False).structure
    built = np.array([robot.rest_length(c) for c in robot.cables])
    k = np.array([c.stiffness for c in robot.cables])
    motorised = np.array([not c.motor.passive for c in robot.cables])
    build = {n.name: np.asarray(n.position, dtype=float) for n in robot.nodes}
    pose = face_down_pose(robot, hull_faces(build)[face])
    rest_pose = settle(with_rest_lengths(pose, built), face)
    feet = {f: np.asarray(rest_pose.pose.position(f)) for f in face}
    lines = support_edges(np.array([feet[f][:2] for f in face]))
    kinds = edge_kinds(build, face)

    def com(lin: object) -> np.ndarray:
        b = lin.body_set  # type: ignore[attr-defined]
        return b.mass @ b.com / b.mass.sum()

    inside = {edge_of(face, feet, e): -(e[:2] @ com(rest_pose)[:2] + e[2]) for e in lines}
    nearest = {name: (d, 0.0) for name, d in inside.items()}

    def static_pose(pull: np.ndarray) -> object | None:
        """The static pose under the file's law, None where a pulled cable would be
        shorter than its spring's rest length (the actuator then pulls on alone)."""
        lin = settle(with_rest_lengths(pose, built - pull / k), face)
        lengths = np.array([lin.pose.cable_length(c) for c in lin.pose.cables])
        return None if np.any((pull > 0) & (lengths < built)) else lin

    folding = 0
    for bits in itertools.product((0.0, 1.0), repeat=int(motorised.sum())):
        pattern = np.zeros(len(built))
        pattern[motorised] = bits
        if static_pose(PULL_N * pattern) is None:
            folding += 1
        held: object = rest_pose  # the pose of the largest pull that holds a static pose
        low, high = 0.0, PULL_N
        for _ in range(BISECT if pattern.any() else 0):
            lin = static_pose((low + high) / 2 * pattern)
            low, high, held = ((low + high) / 2, high, lin) if lin is not None else \
                (low, (low + high) / 2, held)
        for e in lines:
            name, d = edge_of(face, feet, e), -(e[:2] @ com(held)[:2] + e[2])
            if d < nearest[name][0]:
                nearest[name] = (d, low)
    print(f"statics on {' '.join(face)}: centre of mass {com(rest_pose)[2]:.3f} m up; "
          f"{folding} of 64 patterns at full pull have no static pose")
    for name in sorted(inside, key=lambda e: inside[e]):
        d, pull = nearest[name]
        print(f"  {name} ({kinds[name]}): {inside[name]:.3f} m inside at rest, at best "
              f"{d:.3f} m ({inside[name] - d:.3f} m nearer, pulls of {pull:.0f} N)")


def mujoco_tips(face: tuple[str, ...]) -> None:
    m = mujoco.MjModel.from_xml_path(str(XML))
    d = mujoco.MjData(m)
    sites = [m.site(i).name for i in range(m.nsite)]

    def positions() -> dict[str, np.ndarray]:
        return {s: d.site_xpos[i].copy() for i, s in enumerate(sites)}

    mujoco.mj_forward(m, d)
    build = positions()
    turn, _ = Rotation.align_vectors([[0.0, 0.0, -1.0]], [hull_faces(build)[face]])
    lift = 0.036 - turn.apply(np.array(list(build.values())))[:, 2].min()  # caps 35 mm
    for b in range(1, m.nbody):
        adr = m.jnt_qposadr[m.body_jntadr[b]]
        d.qpos[adr:adr + 3] = turn.apply(d.qpos[adr:adr + 3]) + np.array([0.0, 0.0, lift])
        quat = Rotation.from_quat(d.qpos[adr + 3:adr + 7], scalar_first=True)
        d.qpos[adr + 3:adr + 7] = (turn * quat).as_quat(scalar_first=True)
    mujoco.mj_forward(m, d)
    mujoco.mj_step(m, d, nstep=round(HOLD_S / m.opt.timestep))  # settle at rest
    stood = support_face(positions())
    kinds = edge_kinds(build, stood)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state, spec)
    over: dict[str, list[float]] = {}
    look = round(LOOK_S / m.opt.timestep)
    for bits in itertools.product((0.0, -1.0), repeat=m.nu):
        mujoco.mj_setState(m, d, state, spec)
        d.ctrl[:] = bits
        seen = stood
        for i in range(round(HOLD_S / LOOK_S)):
            mujoco.mj_step(m, d, nstep=look)
            now = support_face(positions())
            if now != stood and now == seen:
                shared = set(now) & set(stood)
                key = next((kinds[e] for e in kinds if set(e.split("-")) <= shared),
                           "onto a fourth node").split(",")[0]
                over.setdefault(key, []).append((i + 1) * LOOK_S)
                break
            seen = now
    print(f"MuJoCo on {' '.join(stood)}: {sum(map(len, over.values()))} of {2 ** m.nu} "
          f"patterns change the face within {HOLD_S:g} s")
    for key, times in sorted(over.items()):
        print(f"  {len(times)} over the {key} (after {min(times):.2f} to {max(times):.2f} s)")


def main() -> None:
    for face in FACES:
        statics(face)
    for face in FACES:
        mujoco_tips(face)


if __name__ == "__main__":
    main()
