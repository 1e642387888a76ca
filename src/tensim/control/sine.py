"""Open-loop sine gaits on the impedance law's target velocity V* (paper section IV-B).

A :class:`SineGait` gives every driven cable ``V*_i(t) = offset_i + amplitude_i sin(2π f_i t +
phase_i)``. The hand-tuned Tetraspine gait of the paper has the inner cables at the inverse sign
of the outer ones and the rear joint π behind the front one: :func:`tetraspine_sine` builds it
for a spine of any length. :class:`SineController` samples the gait at the physics step and
writes it into a simulation's V* table. The table helpers here are shared with
:mod:`tensim.control.cpg`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from tensim._input import InputError
from tensim.control._common import (
    check_driven,
    joint_index,
    per_item,
    sample_times,
    write_target_velocity,
)
from tensim.control.impedance import ImpedanceController
from tensim.control.velocity_table import VelocityTable
from tensim.sim import CableSetup
from tensim.structure import Structure

# -- the gait -------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class SineGait:
    """Per-cable sine waves V*_i(t) = offset_i + amplitude_i sin(2π frequency_i t + phase_i).

    Scalars are broadcast to every cable (after construction every field is a per-cable
    tuple). A negative amplitude inverts a cable's wave.

    Attributes:
        cables: names of the driven cables.
        amplitude: per-cable amplitude [m/s].
        frequency: per-cable frequency [Hz], >= 0.
        phase: per-cable phase [rad].
        offset: per-cable constant added to V* [m/s].
    """

    cables: tuple[str, ...]
    amplitude: float | tuple[float, ...]
    frequency: float | tuple[float, ...]
    phase: float | tuple[float, ...] = 0.0
    offset: float | tuple[float, ...] = 0.0

    def __post_init__(self) -> None:
        cables = tuple(str(c) for c in self.cables)
        if not cables:
            raise ValueError("a sine gait needs at least one cable")
        if len(set(cables)) != len(cables):
            raise ValueError(f"duplicate cable names in {cables}")
        object.__setattr__(self, "cables", cables)
        values = {field: per_item(getattr(self, field), len(cables), field)
                  for field in ("amplitude", "frequency", "phase", "offset")}
        for field, value in values.items():
            object.__setattr__(self, field, value)
        if min(values["frequency"]) < 0:
            raise ValueError(f"frequency must be >= 0 Hz, got {self.frequency}")

    def check_sampling(self, period: float) -> None:
        """Refuses a frequency at or above the Nyquist frequency 1 / (2 ``period``) of the
        command period [s]: sampled there, the wave aliases (to V* = 0 at a multiple of it).

        Raises:
            InputError: naming the cable, its frequency, the period and the limit.
        """
        nyquist = 0.5 / period
        frequencies: tuple[float, ...] = self.frequency  # type: ignore[assignment]
        for cable, frequency in zip(self.cables, frequencies, strict=True):
            if frequency >= nyquist:
                raise InputError(
                    f"sine gait: cable {cable!r} at {frequency:g} Hz is at or above the "
                    f"Nyquist frequency {nyquist:g} Hz of its command period {period:g} s: "
                    "sampled that often it aliases (a multiple of it reads as V* = 0); "
                    "lower the frequency, or shorten the command period")

    def table(self, times: np.ndarray) -> np.ndarray:
        """V* at ``times`` [s]: (len(times), len(cables)) [m/s], columns in ``cables`` order."""
        t = np.asarray(times, dtype=float).reshape(-1, 1)
        angle = 2 * np.pi * np.asarray(self.frequency) * t + np.asarray(self.phase)
        return np.asarray(self.offset) + np.asarray(self.amplitude) * np.sin(angle)

    def velocity_table(self, duration: float, period: float) -> VelocityTable:
        """V* sampled every ``period`` from 0 to ``duration`` inclusive [s] (see
        :meth:`check_sampling`)."""
        self.check_sampling(period)
        return VelocityTable(self.cables, period, self.table(sample_times(duration, period)))


def tagged_sine(structure: Structure, amplitude: float, frequency: float, *,
                sign: Mapping[str, float] | None = None, phase: Mapping[str, float] | None = None,
                offset: float = 0.0, cables: Sequence[str] | None = None) -> SineGait:
    """A shared sine wave whose sign and phase each cable takes from its tags.

    A cable's wave is ``s (offset + amplitude sin(2π f t + p))`` with ``s`` the product of
    ``sign[tag]`` and ``p`` the sum of ``phase[tag]`` over the cable's tags.

    Args:
        structure: the robot.
        amplitude: shared amplitude [m/s].
        frequency: shared frequency [Hz].
        sign: tag -> sign factor (e.g. ``{"inner": -1}``).
        phase: tag -> phase added [rad] (e.g. ``{"joint_2": -math.pi}``).
        offset: shared V* offset [m/s], signed like the wave.
        cables: the driven cables; None drives every cable of ``structure``.
    """
    sign, phase = sign or {}, phase or {}
    chosen = [structure.cable(n) for n in cables] if cables is not None else structure.cables
    signs = [math.prod(sign.get(t, 1.0) for t in c.tags) for c in chosen]
    phases = [math.fsum(phase.get(t, 0.0) for t in c.tags) for c in chosen]
    return SineGait(tuple(c.name for c in chosen), tuple(s * amplitude for s in signs),
                    frequency, tuple(phases), tuple(s * offset for s in signs))


def tetraspine_sine(structure: Structure, amplitude: float, frequency: float, *,
                    phase: float = 0.0, offset: float = 0.0,
                    joint_lag: float = math.pi) -> SineGait:
    """The paper's hand-tuned Tetraspine gait: inner = −outer, each joint π behind the one ahead.

    Outer cables get ``offset + amplitude sin(2π f t + phase − (j − j0) joint_lag)`` at joint j
    (j0 the front joint); inner cables the same wave with the inverse sign. With the default
    lag of π on Tetraspine3 the rear joint runs π behind the front joint.

    Args:
        structure: a Tetraspine (cables tagged "inner"/"outer" and "joint_<j>").
        amplitude: outer-cable amplitude [m/s].
        frequency: [Hz].
        phase: front-joint outer-cable phase [rad].
        offset: outer-cable V* offset [m/s].
        joint_lag: phase by which each joint runs behind the one in front of it [rad].

    Raises:
        ValueError: a cable is not tagged inner or outer, or has no joint tag.
    """
    for cable in structure.cables:
        if ("inner" in cable.tags) == ("outer" in cable.tags):
            raise ValueError(f"cable {cable.name!r} must be tagged exactly one of 'inner' or "
                             f"'outer', has {cable.tags!r}")
    joints = sorted({joint_index(c) for c in structure.cables})
    lags = {f"joint_{j}": phase - (j - joints[0]) * joint_lag for j in joints}
    return tagged_sine(structure, amplitude, frequency, sign={"inner": -1.0}, phase=lags,
                       offset=offset)


# -- the controller -------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class SineController:
    """A sine gait on top of impedance laws.

    ``configure`` sets the impedance gains, then the V* table (the impedance controller's
    constant target velocity is replaced; cables outside the gait get V* = 0). Past
    ``duration`` the drive holds the last row, so simulate at most ``duration``.

    Attributes:
        gait: the sine waves.
        impedance: the impedance laws; every gait cable must have gains.
        duration: time covered by the V* table [s].
        sample_steps: table period in physics steps (1: V* sampled at every step).
    """

    gait: SineGait
    impedance: ImpedanceController
    duration: float
    sample_steps: int = 1

    def __post_init__(self) -> None:
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise ValueError(f"duration must be a finite time > 0 s, got {self.duration}")
        if int(self.sample_steps) != self.sample_steps or self.sample_steps < 1:
            raise ValueError(f"sample_steps must be an integer >= 1, got {self.sample_steps}")
        check_driven(self.impedance, self.gait.cables)

    def configure(self, sim: CableSetup) -> None:
        """Writes the impedance gains and the sampled gait into ``sim.drive``."""
        self.impedance.configure(sim)
        table_dt = self.sample_steps * sim.dt
        self.gait.check_sampling(table_dt)
        times = sample_times(self.duration, table_dt)
        write_target_velocity(sim, self.gait.cables, self.gait.table(times), table_dt)
