"""Travelling waves of joint bending along a Tetraspine, on the impedance laws' V*.

A Tetraspine joint bends in three ways, each a fixed pattern over the outer cables' sides
(``top``, ``left``, ``right``; every inner cable takes the inverse of its side's outer cable, as
in the paper's hand-tuned gait):

- ``axial``: all three sides alike, the joint lengthens and shortens;
- ``pitch``: top against the two bottom corners (weights 1, -1/2, -1/2: the top anchor sits twice
  as far above the base triangle's centroid as the bottom ones below it), the spine bends up and
  down;
- ``yaw``: left against right, the spine bends sideways.

Each mode has an amplitude [m/s] and phase [rad]; joint j runs ``joint_lag`` behind joint j - 1,
so the bending travels along the spine. A caterpillar crawl is a pitch wave; sidewinding is a yaw
wave with a pitch wave a quarter period apart. :class:`SpineWaveParameters` makes the eight
numbers a learnable layout, so ``tensim learn --controller wave`` searches gaits of this form.

On any other robot, :class:`TravellingWaveParameters` passes one sine wave over an ordered set of
cables (the order given, or derived from the build pose by :func:`wave_order`), each cable
``lag`` behind the one before it.
"""

from __future__ import annotations

import cmath
import dataclasses
import math
import re
from collections.abc import Sequence

import numpy as np

from tensim.control._common import has_joint_tag, joint_index
from tensim.control.parameters import Bounds, Parameter, ParameterLayout
from tensim.control.sine import SineGait
from tensim.structure import Structure

SIDES = ("top", "left", "right")
MODES: dict[str, dict[str, float]] = {
    "axial": {"top": 1.0, "left": 1.0, "right": 1.0},
    "pitch": {"top": 1.0, "left": -0.5, "right": -0.5},
    "yaw": {"top": 0.0, "left": 1.0, "right": -1.0},
}
Mode = tuple[float, float]  # (amplitude [m/s], phase [rad])

# search ranges of the learnable layout: amplitudes past the motors' 0.07 m/s saturate into
# square-ish waves, which a crawl can use
WAVE_FREQUENCY = Bounds(0.05, 1.5, 0.25)  # Hz
WAVE_JOINT_LAG = Bounds(-math.pi, math.pi, 0.0)  # rad
WAVE_AMPLITUDE = Bounds(0.0, 0.2, 0.05)  # m/s
WAVE_PHASE = Bounds(-math.pi, math.pi, 0.0)  # rad
WAVE_NAMES = ("frequency", "joint_lag", "axial_amplitude", "axial_phase", "pitch_amplitude",
              "pitch_phase", "yaw_amplitude", "yaw_phase")


@dataclasses.dataclass(frozen=True)
class SpineWave:
    """A travelling wave of joint bending along a Tetraspine, on V*.

    Attributes:
        frequency: [Hz].
        joint_lag: phase by which each joint runs behind the one in front of it [rad].
        axial, pitch, yaw: (amplitude [m/s], phase [rad]) of each bending mode on the outer
            cables.
    """

    frequency: float
    joint_lag: float
    axial: Mode = (0.0, 0.0)
    pitch: Mode = (0.0, 0.0)
    yaw: Mode = (0.0, 0.0)

    def gait(self, structure: Structure) -> SineGait:
        """The per-cable sine waves for ``structure`` (cables tagged by side, inner/outer and
        joint, as the Tetraspine presets are).

        Raises:
            ValueError: a cable lacks a side, inner/outer or joint tag.
        """
        joints = {c.name: joint_index(c) for c in structure.cables}
        front = min(joints.values())
        names, amplitude, phase = [], [], []
        for cable in structure.cables:
            sides = [s for s in SIDES if s in cable.tags]
            if len(sides) != 1 or ("inner" in cable.tags) == ("outer" in cable.tags):
                raise ValueError(f"cable {cable.name!r} needs one side tag of {SIDES} and one "
                                 f"of 'inner'/'outer', has {cable.tags!r}")
            wave = sum(MODES[m][sides[0]] * a * cmath.exp(1j * p) for m, (a, p) in
                       (("axial", self.axial), ("pitch", self.pitch), ("yaw", self.yaw)))
            wave = -wave if "inner" in cable.tags else wave
            names.append(cable.name)
            amplitude.append(abs(wave))
            phase.append(cmath.phase(wave) - (joints[cable.name] - front) * self.joint_lag)
        return SineGait(tuple(names), tuple(amplitude), self.frequency, tuple(phase))

    def values(self) -> tuple[float, ...]:
        """The wave as a vector in :data:`WAVE_NAMES` order."""
        return (self.frequency, self.joint_lag, *self.axial, *self.pitch, *self.yaw)


@dataclasses.dataclass(frozen=True)
class SpineWaveParameters(ParameterLayout):
    """A :class:`SpineWave`'s eight numbers as a learnable layout, in :data:`WAVE_NAMES` order.

    Attributes:
        structure: the Tetraspine the waves are made for (its cables are checked up front).
        entries: the parameters (see :func:`spine_wave_parameters`).
    """

    structure: Structure
    entries: tuple[Parameter, ...]

    def __post_init__(self) -> None:
        if tuple(p.name for p in self.entries) != WAVE_NAMES:
            raise ValueError(f"a spine wave layout has the entries {WAVE_NAMES}, got "
                             f"{tuple(p.name for p in self.entries)}")
        SpineWave(0.1, 0.0).gait(self.structure)  # ValueError for an untagged cable

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        """The entries, in vector order."""
        return self.entries

    def wave(self, values: Sequence[float] | np.ndarray | None = None) -> SpineWave:
        """The wave of a parameter vector (None: the nominal values)."""
        v = [float(x) for x in self.check_bounds(self.nominal if values is None else values)]
        return SpineWave(v[0], v[1], (v[2], v[3]), (v[4], v[5]), (v[6], v[7]))

    def gait(self, values: Sequence[float] | np.ndarray | None = None) -> SineGait:
        """The per-cable sine gait of a parameter vector (None: the nominal values)."""
        return self.wave(values).gait(self.structure)


def spine_wave_parameters(structure: Structure, start: SpineWave | None = None, *,
                          frequency: Bounds = WAVE_FREQUENCY,
                          joint_lag: Bounds = WAVE_JOINT_LAG,
                          amplitude: Bounds = WAVE_AMPLITUDE,
                          phase: Bounds = WAVE_PHASE) -> SpineWaveParameters:
    """The wave layout for a Tetraspine; its nominal vector is ``start`` (clipped) if given.

    Args:
        structure: a spine whose cables carry side, inner/outer and ``joint_<j>`` tags.
        start: the wave to start from (None: every range's nominal value).
        frequency, joint_lag, amplitude, phase: ranges [Hz, rad, m/s, rad]; amplitude and phase
            apply to each of the three modes.

    Raises:
        ValueError: a cable the wave cannot place.
    """
    bounds = (frequency, joint_lag, amplitude, phase, amplitude, phase, amplitude, phase)
    nominal = ([b.nominal for b in bounds] if start is None else
               [min(max(v, b.low), b.high) for v, b in zip(start.values(), bounds, strict=True)])
    entries = tuple(Parameter(name, dataclasses.replace(b, nominal=float(n))) for name, b, n in
                    zip(WAVE_NAMES, bounds, nominal, strict=True))
    return SpineWaveParameters(structure, entries)


# -- a travelling wave over any ordered set of cables ---------------------------------------------

TRAVEL_NAMES = ("amplitude", "frequency", "lag")
_WAVE_TAG = re.compile(r"wave_(\d+)")
TRAVEL_AMPLITUDE = Bounds(0.0, 0.07, 0.02)  # m/s
TRAVEL_LAG = Bounds(-math.pi, math.pi, math.pi / 2)  # rad


def wave_order(structure: Structure, cables: Sequence[str], how: str = "auto"
               ) -> tuple[str, ...]:
    """The cables in the order a travelling wave passes them, from tags or the build pose.

    ``"tags"`` sorts by each cable's ``wave_<k>`` tag (the user's order; equal k move
    together); ``"axis"`` sorts the cables' midpoints along the longest horizontal principal
    axis of the nodes (front to back along a spine); ``"around"`` by their angle about the
    vertical axis through the nodes' centroid (round a prism's rings); ``"auto"`` takes
    ``"tags"`` where every cable has a ``wave_<k>`` tag, else ``"axis"`` where that axis is at
    least 1.5 times as long as the other horizontal one, else ``"around"``. Ties keep the given
    order.

    Raises:
        ValueError: an unknown ``how``, or ``"tags"`` with a cable lacking its ``wave_<k>``.
        KeyError: an unknown cable.
    """
    if how not in ("auto", "tags", "axis", "around"):
        raise ValueError(f"wave order must be 'auto', 'tags', 'axis', 'around' or a list of "
                         f"cables, got {how!r}")
    tagged = {c: [int(m.group(1)) for t in structure.cable(c).tags
                  if (m := _WAVE_TAG.fullmatch(t))] for c in cables}
    if how == "tags" or (how == "auto" and all(len(k) == 1 for k in tagged.values())):
        bad = [c for c, k in tagged.items() if len(k) != 1]
        if bad:
            raise ValueError(f"cables {bad} need exactly one 'wave_<k>' tag to set their place "
                             "in the wave")
        return tuple(sorted(cables, key=lambda c: tagged[c][0]))
    points = np.array([structure.position(n.name)[:2] for n in structure.nodes])
    centre = points.mean(axis=0)
    spread, axes = np.linalg.eigh(np.cov((points - centre).T) + 1e-15 * np.eye(2))
    if how == "auto":
        how = "axis" if spread[1] >= 1.5**2 * spread[0] else "around"
    mid = {c: np.mean([structure.position(n)[:2] for n in structure.cable(c).nodes], axis=0)
           for c in cables}
    if how == "axis":
        along = axes[:, 1] * (1.0 if axes[0, 1] >= 0 else -1.0)  # front: toward +x
        key = {c: -float((mid[c] - centre) @ along) for c in cables}
    else:
        key = {c: float(np.arctan2(*(mid[c] - centre)[::-1])) for c in cables}
    rank = {c: i for i, c in enumerate(cables)}
    return tuple(sorted(cables, key=lambda c: (round(key[c], 9), rank[c])))


@dataclasses.dataclass(frozen=True)
class TravellingWaveParameters(ParameterLayout):
    """A travelling sine wave over ordered cables: the k-th cable in ``order`` gets
    V* = amplitude sin(2π frequency t − k lag) [m/s] (cables of one ``wave_<k>`` tag share k);
    the vector is [amplitude, frequency, lag]
    ([m/s, Hz, rad]).

    Attributes:
        order: the driven cables, in the order the wave passes them.
        entries: the parameters (see :func:`travelling_wave_parameters`).
        steps: each cable's k (None: its place in ``order``).
    """

    order: tuple[str, ...]
    entries: tuple[Parameter, ...]
    steps: tuple[int, ...] | None = None

    def __post_init__(self) -> None:
        if self.steps is None:
            object.__setattr__(self, "steps", tuple(range(len(self.order))))
        if len(self.steps) != len(self.order):  # type: ignore[arg-type]
            raise ValueError(f"{len(self.order)} cables need as many steps, got {self.steps}")
        if tuple(p.name for p in self.entries) != TRAVEL_NAMES:
            raise ValueError(f"a travelling wave layout has the entries {TRAVEL_NAMES}")
        if not self.order or len(set(self.order)) != len(self.order):
            raise ValueError(f"a travelling wave needs unique cables, got {self.order}")

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        """The entries, in vector order."""
        return self.entries

    def gait(self, values: Sequence[float] | np.ndarray | None = None) -> SineGait:
        """The per-cable sine gait of a parameter vector (None: the nominal values)."""
        amplitude, frequency, lag = (float(x) for x in self.check_bounds(
            self.nominal if values is None else values))
        assert self.steps is not None
        return SineGait(self.order, (amplitude,) * len(self.order), frequency,
                        tuple(float(math.remainder(-k * lag, 2 * math.pi)) for k in self.steps))


def travelling_wave_parameters(structure: Structure, cables: Sequence[str],
                               order: str | Sequence[str] = "auto", *,
                               amplitude: Bounds = TRAVEL_AMPLITUDE,
                               frequency: Bounds = WAVE_FREQUENCY,
                               lag: Bounds = TRAVEL_LAG) -> TravellingWaveParameters:
    """The travelling-wave layout over ``cables`` on any structure.

    Args:
        structure: the robot.
        cables: the driven cables.
        order: the cables in wave order (the same set as ``cables``), or how to derive it
            (see :func:`wave_order`).
        amplitude, frequency, lag: ranges [m/s, Hz, rad].

    Raises:
        ValueError: no cables, or an order that is not a permutation of ``cables``.
        KeyError: an unknown cable.
    """
    cables = tuple(cables)
    if not cables:
        raise ValueError("a travelling wave needs at least one driven cable")
    steps = None
    if isinstance(order, str):
        ordered = wave_order(structure, cables, order)
        tags = [[int(m.group(1)) for t in structure.cable(c).tags
                 if (m := _WAVE_TAG.fullmatch(t))] for c in ordered]
        if order in ("tags", "auto") and all(len(k) == 1 for k in tags):
            steps = tuple(k[0] - tags[0][0] for k in tags)
    else:
        ordered = tuple(order)
        if sorted(ordered) != sorted(cables):
            raise ValueError(f"wave order {list(ordered)} must list each driven cable "
                             f"{sorted(cables)} once")
    entries = tuple(Parameter(name, b) for name, b in
                    zip(TRAVEL_NAMES, (amplitude, frequency, lag), strict=True))
    return TravellingWaveParameters(ordered, entries, steps)


def spine_tagged(structure: Structure) -> bool:
    """Whether every cable carries the Tetraspine tags :class:`SpineWave` places cables by."""
    return bool(structure.cables) and all(
        has_joint_tag(c) and sum(s in c.tags for s in SIDES) == 1
        and ("inner" in c.tags) != ("outer" in c.tags) for c in structure.cables)
