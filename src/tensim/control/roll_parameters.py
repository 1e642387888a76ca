"""A rolling gait's parameters: one wave of cable contraction running around the robot.

A rolling robot (a 3-bar prism, a 6-bar icosahedron) rolls about a horizontal axis; it does so
when its cables contract one after the other around that axis. :func:`roll_parameters` gives
every driven cable a sine on its impedance law's V* (a :class:`~tensim.control.sine.SineGait`:
through the law T = T0 + K (L - L*) + B (V - V*) a V* wave of amplitude A swings the cable's
tension by about B A, so the motor winds its rest length periodically) whose phase is set by
where the cable sits around the rolling axis in the build pose:

    V*_c(t) = A_e(c) sin(2π f t + n θ_c + φ_e(c))

with θ_c the angle of the cable's midpoint about the axis [rad], e(c) the end of the robot
the cable lies at (``a`` below the axis's mid-plane, ``b`` above it), and φ_a = 0. Five
numbers whatever the robot: ``amplitude/a``, ``amplitude/b`` [m/s], ``phase/b`` [rad],
``wave_number`` n (±1: one wave around the axis, its sign the rolling direction) and
``frequency`` f [Hz]. The robot's symmetry is built in: cables a rotation about the axis maps
onto each other share an amplitude and differ in phase by n times the rotation angle, so
rotating the pattern is the same gait shifted in time (exactly for a whole wave number; the
search may also try fractional ones, whose wave jumps where the angle wraps at ±π).

The rolling axis is the principal axis of the build pose's nodes with the largest spread (a
prism's long axis); a robot without one (an icosahedron) rolls about its longest
rod's horizontal direction (:func:`rolling_axis`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from tensim.control.parameters import Bounds, Parameter, ParameterLayout
from tensim.control.sine import SineGait
from tensim.structure import Structure

ROLL_AMPLITUDE = Bounds(0.0, 1.5, 0.5)  # m/s
ROLL_PHASE = Bounds(-math.pi, math.pi, 0.0)  # rad
ROLL_WAVE_NUMBER = Bounds(-1.5, 1.5, 1.0)  # waves around the axis
ROLL_FREQUENCY = Bounds(0.1, 2.0, 0.5)  # Hz
ROLL_NAMES = ("amplitude/a", "amplitude/b", "phase/b", "wave_number", "frequency")
_ISOTROPIC = 1.05  # largest node variance within 5 % of the next: no long axis


def rolling_axis(structure: Structure) -> np.ndarray:
    """(3,) unit axis the robot rolls about, from its build pose.

    The principal axis of the nodes' positions with the largest variance (a prism's long
    axis, which its cables are symmetric about; lying on a side face it tilts a little);
    where no axis stands out (variances within 5 %), the direction of the longest rod.
    """
    points = np.array([n.position for n in structure.nodes], dtype=float)
    variance, vectors = np.linalg.eigh(np.cov((points - points.mean(axis=0)).T))
    axis = vectors[:, -1].copy()
    if variance[-1] < _ISOTROPIC * variance[-2]:
        rod = max(structure.rods, key=lambda r: structure.distance(*r.nodes))
        axis = structure.position(rod.nodes[1]) - structure.position(rod.nodes[0])
    axis = axis / np.linalg.norm(axis)
    i = int(np.argmax(np.abs(axis)))
    return axis if axis[i] > 0 else -axis  # a deterministic sign


@dataclasses.dataclass(frozen=True)
class RollParameters(ParameterLayout):
    """The rolling wave's five numbers over the driven cables.

    Attributes:
        cables: the driven cables, in gait column order.
        angle: per cable, its midpoint's angle about the rolling axis in the build pose [rad].
        end_b: per cable, whether it lies at end ``b`` (else end ``a``).
        entries: the parameters, in :data:`ROLL_NAMES` order.
    """

    cables: tuple[str, ...]
    angle: tuple[float, ...]
    end_b: tuple[bool, ...]
    entries: tuple[Parameter, ...]

    def __post_init__(self) -> None:
        n = len(self.cables)
        if not n or len(self.angle) != n or len(self.end_b) != n:
            raise ValueError(f"{n} cables need as many angles and ends, got {len(self.angle)} "
                             f"and {len(self.end_b)}")
        if tuple(p.name for p in self.entries) != ROLL_NAMES:
            raise ValueError(f"a rolling wave's parameters are {list(ROLL_NAMES)}")

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        """The entries, in vector order."""
        return self.entries

    def gait(self, values: Sequence[float] | np.ndarray | None = None) -> SineGait:
        """The per-cable sine gait of a parameter vector (None: the nominal values)."""
        a, b, phase_b, wave, frequency = self.check_bounds(
            self.nominal if values is None else values)
        end_b = np.asarray(self.end_b)
        amplitude = np.where(end_b, b, a)
        phase = wave * np.asarray(self.angle) + np.where(end_b, phase_b, 0.0)
        phase = np.remainder(phase + math.pi, 2 * math.pi) - math.pi
        return SineGait(self.cables, tuple(float(x) for x in amplitude), float(frequency),
                        tuple(float(x) for x in phase))


def roll_parameters(structure: Structure, cables: Sequence[str], *,
                    axis: Sequence[float] | None = None,
                    amplitude: Bounds = ROLL_AMPLITUDE, phase: Bounds = ROLL_PHASE,
                    wave_number: Bounds = ROLL_WAVE_NUMBER,
                    frequency: Bounds = ROLL_FREQUENCY) -> RollParameters:
    """The rolling-wave layout over ``cables`` of ``structure`` in its build pose.

    Args:
        structure: the robot, in the pose it starts a trial in.
        cables: the driven cables.
        axis: the rolling axis (None: :func:`rolling_axis`).
        amplitude, phase, wave_number, frequency: ranges [m/s, rad, -, Hz].

    Raises:
        ValueError: no cables.
        KeyError: an unknown cable.
    """
    cables = tuple(cables)
    if not cables:
        raise ValueError("a rolling wave needs at least one driven cable")
    u = rolling_axis(structure) if axis is None else np.asarray(axis, dtype=float)
    u = u / np.linalg.norm(u)
    down = np.array([0.0, 0.0, -1.0])
    down = down - (down @ u) * u
    if np.linalg.norm(down) < 0.5:
        # built standing on an end (a lab's prism on its end triangle): it falls onto its
        # side first; the angles about the axis (body-fixed) are then taken from +x (or +y)
        down = np.eye(3)[int(np.argmin(np.abs(u[:2])))]
        down = down - (down @ u) * u
    down /= np.linalg.norm(down)
    side = np.cross(u, down)
    centre = np.mean([n.position for n in structure.nodes], axis=0)
    angles, ends = [], []
    for name in cables:
        a, b = structure.cable(name).nodes
        mid = (structure.position(a) + structure.position(b)) / 2 - centre
        angles.append(math.atan2(float(mid @ side), float(mid @ down)))
        ends.append(bool(mid @ u > 0))
    bounds = (amplitude, amplitude, phase, wave_number, frequency)
    entries = tuple(Parameter(n, b) for n, b in zip(ROLL_NAMES, bounds, strict=True))
    return RollParameters(cables, tuple(angles), tuple(ends), entries)
