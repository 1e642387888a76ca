"""Learnable parameter vectors for sine gaits: per-cable waves, or the paper's Tetraspine pattern.

Two layouts, both :class:`~tensim.control.parameters.ParameterLayout` s whose ``gait(values)``
gives a :class:`~tensim.control.sine.SineGait`:

- :func:`sine_parameters`: every driven cable has its own amplitude and phase, all share one
  frequency (2 n + 1 parameters; 25 for Tetraspine3). Offsets are carried, not learned: a
  constant V* only winds a cable in or out until its motor limit.
- :func:`tetraspine_sine_parameters`: the hand-tuned pattern of the paper (section IV-B) with its
  four numbers free: amplitude, frequency, the lag from one joint to the next, and the phase of
  the inner cables against the outer ones (π: the paper's inverse sign).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from tensim.control._common import as_tuple, joint_index
from tensim.control.parameters import Bounds, Parameter, ParameterLayout
from tensim.control.sine import SineGait
from tensim.structure import Structure

# amplitudes up to Tetraspine's motor speed; the paper's simulated gaits used ~0.005-0.01 m/s
DEFAULT_AMPLITUDE = Bounds(0.0, 0.07, 0.01)  # m/s
DEFAULT_PHASE = Bounds(-math.pi, math.pi, 0.0)  # rad
DEFAULT_FREQUENCY = Bounds(0.1, 2.0, 0.5)  # Hz
DEFAULT_JOINT_LAG = Bounds(-math.pi, math.pi, math.pi)  # rad, the paper's rear joint π behind
DEFAULT_INNER_PHASE = Bounds(-math.pi, math.pi, math.pi)  # rad, π: inner = −outer


def _wrap(angle: float) -> float:
    """``angle`` wrapped into [−π, π] [rad]."""
    return float(math.remainder(angle, 2 * math.pi))


@dataclasses.dataclass(frozen=True)
class SineParameters(ParameterLayout):
    """Per-cable amplitude and phase and one shared frequency.

    The vector is ``[amplitude/<c0>, phase/<c0>, amplitude/<c1>, ..., frequency]``.

    Attributes:
        cables: the driven cables, in gait column order.
        entries: the parameters, in vector order (built by :func:`sine_parameters`).
        offset: per-cable V* offset [m/s], carried into every gait unchanged.
    """

    cables: tuple[str, ...]
    entries: tuple[Parameter, ...]
    offset: tuple[float, ...]

    def __post_init__(self) -> None:
        n = len(self.cables)
        if len(self.entries) != 2 * n + 1 or len(self.offset) != n:
            raise ValueError(f"{n} cables need {2 * n + 1} entries and {n} offsets, got "
                             f"{len(self.entries)} and {len(self.offset)}")

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        """The entries, in vector order."""
        return self.entries

    def gait(self, values: Sequence[float] | np.ndarray | None = None) -> SineGait:
        """The sine gait for a parameter vector (None: the nominal values)."""
        v = self.check_bounds(self.nominal if values is None else values)
        n = len(self.cables)
        return SineGait(self.cables, tuple(v[0:2 * n:2]), float(v[-1]), tuple(v[1:2 * n:2]),
                        self.offset)


def sine_parameters(structure: Structure, cables: Sequence[str] | None = None, *,
                    amplitude: Bounds = DEFAULT_AMPLITUDE, phase: Bounds = DEFAULT_PHASE,
                    frequency: Bounds = DEFAULT_FREQUENCY,
                    start: SineGait | None = None) -> SineParameters:
    """The per-cable sine layout; its nominal vector is ``start`` (clipped) if given.

    A negative amplitude in ``start`` becomes a positive one with π added to the phase (the
    same wave); ``start``'s frequencies must be shared, and its offsets are kept.

    Args:
        structure: the robot.
        cables: the driven cables (None: ``start``'s cables, else every cable).
        amplitude, phase, frequency: ranges [m/s, rad, Hz]; their nominal values are used
            without ``start``.
        start: a gait to take the nominal values and offsets from.

    Raises:
        KeyError: an unknown cable.
        ValueError: ``start`` has differing frequencies, or drives other cables.
    """
    names = tuple(cables) if cables is not None else (
        start.cables if start is not None else tuple(c.name for c in structure.cables))
    for name in names:
        structure.cable(name)  # KeyError for an unknown cable
    n = len(names)
    amp = np.full(n, amplitude.nominal)
    ph = np.full(n, phase.nominal)
    freq, offset = frequency.nominal, (0.0,) * n
    if start is not None:
        if set(start.cables) != set(names):
            raise ValueError(f"start gait drives {start.cables}, the layout {names}")
        frequencies = as_tuple(start.frequency)
        if len(set(frequencies)) != 1:
            raise ValueError(f"start gait has differing frequencies {start.frequency}; this "
                             "layout shares one")
        column = {c: i for i, c in enumerate(start.cables)}
        order = [column[c] for c in names]
        a = np.asarray(start.amplitude)[order]
        amp = np.clip(np.abs(a), amplitude.low, amplitude.high)
        ph = np.array([_wrap(p + (math.pi if x < 0 else 0.0)) for p, x in
                       zip(np.asarray(start.phase)[order], a, strict=True)])
        ph = np.clip(ph, phase.low, phase.high)
        freq = float(np.clip(frequencies[0], frequency.low, frequency.high))
        offset = tuple(float(o) for o in np.asarray(start.offset)[order])
    entries: list[Parameter] = []
    for name, a0, p0 in zip(names, amp, ph, strict=True):
        entries.append(Parameter(f"amplitude/{name}",
                                 dataclasses.replace(amplitude, nominal=float(a0))))
        entries.append(Parameter(f"phase/{name}", dataclasses.replace(phase, nominal=float(p0))))
    entries.append(Parameter("frequency", dataclasses.replace(frequency, nominal=freq)))
    return SineParameters(names, tuple(entries), offset)


@dataclasses.dataclass(frozen=True)
class TetraspineSineParameters(ParameterLayout):
    """The paper's Tetraspine sine pattern with four learnable numbers.

    Cable c at joint j gets ``V* = amplitude sin(2π frequency t − (j − j0) joint_lag + p_c)``
    with p_c = ``inner_phase`` for inner cables and 0 for outer ones (j0: the front joint).
    The vector is ``[amplitude, frequency, joint_lag, inner_phase]``.

    Attributes:
        cables: the driven cables, in gait column order.
        joint_offset: per cable, its joint index minus the front joint's.
        inner: per cable, whether it is an inner cable.
        amplitude, frequency, joint_lag, inner_phase: ranges [m/s, Hz, rad, rad].
    """

    cables: tuple[str, ...]
    joint_offset: tuple[int, ...]
    inner: tuple[bool, ...]
    amplitude: Bounds = DEFAULT_AMPLITUDE
    frequency: Bounds = DEFAULT_FREQUENCY
    joint_lag: Bounds = DEFAULT_JOINT_LAG
    inner_phase: Bounds = DEFAULT_INNER_PHASE

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        """The entries, in vector order."""
        return tuple(Parameter(name, getattr(self, name)) for name in
                     ("amplitude", "frequency", "joint_lag", "inner_phase"))

    def gait(self, values: Sequence[float] | np.ndarray | None = None) -> SineGait:
        """The sine gait for a parameter vector (None: the nominal values)."""
        amplitude, frequency, lag, inner = self.check_bounds(
            self.nominal if values is None else values)
        phases = tuple(-d * lag + (inner if is_inner else 0.0)
                       for d, is_inner in zip(self.joint_offset, self.inner, strict=True))
        return SineGait(self.cables, float(amplitude), float(frequency), phases)


def tetraspine_sine_parameters(structure: Structure, *,
                               amplitude: Bounds = DEFAULT_AMPLITUDE,
                               frequency: Bounds = DEFAULT_FREQUENCY,
                               joint_lag: Bounds = DEFAULT_JOINT_LAG,
                               inner_phase: Bounds = DEFAULT_INNER_PHASE
                               ) -> TetraspineSineParameters:
    """The Tetraspine pattern layout over every cable of a spine.

    Raises:
        ValueError: a cable is not tagged exactly one of inner/outer, or has no joint tag.
    """
    for cable in structure.cables:
        if ("inner" in cable.tags) == ("outer" in cable.tags):
            raise ValueError(f"cable {cable.name!r} must be tagged exactly one of 'inner' or "
                             f"'outer', has {cable.tags!r}")
    joints = [joint_index(c) for c in structure.cables]
    front = min(joints)
    return TetraspineSineParameters(
        tuple(c.name for c in structure.cables), tuple(j - front for j in joints),
        tuple("inner" in c.tags for c in structure.cables), amplitude, frequency, joint_lag,
        inner_phase)
