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
"""

from __future__ import annotations

import cmath
import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from tensim.control._common import joint_index
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
