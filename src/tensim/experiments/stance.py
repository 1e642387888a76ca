"""Did the robot keep its stance? A protocol's figures mean what they say only if it did.

The disturbance test measures tensions of a robot that stands and takes a push; the drag test
measures the friction of a robot that slides. A robot that tipped over, rolled away or slid
past the protocol's bound made figures of another experiment. :func:`stance_problems` finds
that from the recorded trajectory, in words, for the summary and the printed output.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from tensim.sim import TimeSeries
from tensim.structure import Structure

MAX_TILT_DEG = 45.0  # a rigid body turned further than this from its start has tipped or rolled
MAX_MOVE_SIZES = 0.25  # a standing robot's centre of mass moving more than this x its size


def body_rotations_deg(series: TimeSeries,
                       axes: Mapping[str, np.ndarray] | None = None) -> dict[str, float]:
    """Each rigid body's largest rotation from its first recorded pose [deg].

    Args:
        series: the recorded run (the bodies' ``quat_*``).
        axes: for a body that is one rod, its axis in the body frame: a rod turning about its
            own axis has not moved, so only the turn of the axis counts (:func:`rod_axes`).
    """
    bodies = series.items("quat_w")
    if not bodies:
        return {}
    q = np.stack([series.matrix(f"quat_{a}", bodies) for a in "wxyz"], axis=-1)
    cosine = np.abs(np.einsum("tbk,bk->tb", q, q[0])).clip(0.0, 1.0)
    angles = np.degrees(2.0 * np.arccos(cosine)).max(axis=0)
    out = {name: float(a) for name, a in zip(bodies, angles, strict=True)}
    for k, name in enumerate(bodies):
        if axes is not None and name in axes:
            way = _rotate(q[:, k], np.asarray(axes[name], dtype=float))
            turn = np.einsum("tk,k->t", way, way[0]).clip(-1.0, 1.0)
            out[name] = float(np.degrees(np.arccos(turn)).max())
    return out


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(t, 3) the body-frame vector ``v`` in the world at each unit quaternion (t, 4) w, x, y, z."""
    w, u = q[:, :1], q[:, 1:]
    twice = 2.0 * np.cross(u, np.broadcast_to(v, u.shape))
    return v + w * twice + np.cross(u, twice)


def rod_axes(structure: Structure) -> dict[str, np.ndarray]:
    """The axis of each rigid body that is one rod, in its body frame (aligned with the world
    at the build pose)."""
    out = {}
    for group in structure.rigid_groups():
        if len(group.nodes) == 2:
            a, b = (np.asarray(structure.position(n), dtype=float) for n in group.nodes)
            if np.linalg.norm(b - a) > 0:
                out[group.name] = (b - a) / np.linalg.norm(b - a)
    return out


def robot_size(structure: Structure) -> float:
    """The largest extent of the robot's build pose [m]."""
    points = np.array([n.position for n in structure.nodes])
    return float(np.ptp(points, axis=0).max()) if len(points) else 0.0


def stance_problems(series: TimeSeries, *, max_tilt_deg: float | None = MAX_TILT_DEG,
                    max_move_m: float | None = None,
                    axes: Mapping[str, np.ndarray] | None = None) -> list[str]:
    """What shows the robot left its stance, each in a sentence (empty: it kept it).

    Args:
        series: the recorded run (``pos_*/com`` and the bodies' ``quat_*``).
        max_tilt_deg: the largest rotation of a body that still counts as standing [deg]
            (None: not checked).
        max_move_m: the largest planar displacement of the centre of mass [m] (None: not
            checked).
        axes: the axes of one-rod bodies (:func:`rod_axes`), whose spin does not count.
    """
    problems = []
    rotations = body_rotations_deg(series, axes)
    if max_tilt_deg is not None and rotations:
        body, angle = max(rotations.items(), key=lambda kv: kv[1])
        if angle > max_tilt_deg:
            problems.append(f"body {body!r} turned {angle:.0f} deg from its start (more than "
                            f"{max_tilt_deg:g} deg): the robot tipped over or rolled")
    if max_move_m is not None and "pos_x/com" in series.channels:
        x, y = series["pos_x/com"], series["pos_y/com"]
        moved = float(np.hypot(x - x[0], y - y[0]).max())
        if moved > max_move_m:
            problems.append(f"its centre of mass moved {moved:.3g} m (more than {max_move_m:.3g}"
                            " m): the robot left the place it stood")
    return problems
