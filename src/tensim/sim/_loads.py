"""Time-varying external forces at nodes, as piecewise-linear schedules."""

from __future__ import annotations

import dataclasses

import numpy as np

MAX_FORCE = 1e9  # [N] largest node-load component; MuJoCo zeroes inputs past 1e10


@dataclasses.dataclass(frozen=True)
class NodeLoad:
    """A world-frame force at a node, linear between knots and held outside them.

    Attributes:
        node: the node it pushes on.
        times: (k,) knot times, strictly increasing [s].
        forces: (k, 3) force at each knot, world frame [N].
    """

    node: str
    times: np.ndarray
    forces: np.ndarray

    def __post_init__(self) -> None:
        times = np.ascontiguousarray(self.times, dtype=float).reshape(-1)
        forces = np.ascontiguousarray(self.forces, dtype=float).reshape(-1, 3)
        if times.size == 0 or forces.shape[0] != times.size:
            raise ValueError(f"load at {self.node!r}: need k >= 1 times and (k, 3) forces, got "
                             f"{times.size} times and {forces.shape[0]} forces")
        if not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0) \
                or not np.all(np.isfinite(forces)):
            raise ValueError(f"load at {self.node!r}: times must be finite and increase, forces "
                             "be finite")
        if np.abs(forces).max(initial=0.0) > MAX_FORCE:
            raise ValueError(f"load at {self.node!r}: a force component of "
                             f"{np.abs(forces).max():.3g} N is past {MAX_FORCE:g} N (MuJoCo "
                             "would silently zero such an input)")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "forces", forces)

    def force_at(self, t: float) -> np.ndarray:
        """(3,) the force at time t [N], each row of :meth:`forces_at` the same."""
        times, forces = self.times, self.forces
        if t <= times[0]:
            return forces[0].copy()
        if t >= times[-1]:
            return forces[-1].copy()
        k = int(np.searchsorted(times, t, side="right")) - 1
        s = (t - times[k]) / (times[k + 1] - times[k])
        return forces[k] + s * (forces[k + 1] - forces[k])

    def forces_at(self, t: np.ndarray) -> np.ndarray:
        """(len(t), 3) the force at each time [N], each row exactly as :meth:`force_at`."""
        t = np.asarray(t, dtype=float)
        times, forces = self.times, self.forces
        k = np.clip(np.searchsorted(times, t, side="right") - 1, 0, max(times.size - 2, 0))
        if times.size == 1:
            return np.broadcast_to(forces[0], (t.size, 3)).copy()
        with np.errstate(invalid="ignore"):
            s = (t - times[k]) / (times[k + 1] - times[k])
            out = forces[k] + s[:, None] * (forces[k + 1] - forces[k])
        out[t <= times[0]] = forces[0]
        out[t >= times[-1]] = forces[-1]
        return out

    def scaled(self, factor: float) -> NodeLoad:
        """The same schedule with every force multiplied by ``factor``."""
        return dataclasses.replace(self, forces=self.forces * factor)

    def at(self, node: str) -> NodeLoad:
        """The same schedule applied at another node."""
        return dataclasses.replace(self, node=node)


def ramp_hold_release(node: str, direction: tuple[float, float, float], peak: float,
                      start: float, rise: float, hold: float, fall: float) -> NodeLoad:
    """A force that ramps from 0 to ``peak`` newtons, holds, and ramps back to 0.

    Args:
        node: where it acts.
        direction: (3,) direction, normalised here.
        peak: force magnitude at the plateau [N].
        start, rise, hold, fall: phase start time and phase durations [s].
    """
    unit = np.asarray(direction, dtype=float)
    unit = unit / np.linalg.norm(unit)
    times = np.cumsum([start, rise, hold, fall])
    magnitude = np.array([0.0, peak, peak, 0.0])
    return NodeLoad(node, times, magnitude[:, None] * unit[None, :])
