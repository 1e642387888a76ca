"""Named, bounded parameter vectors for gaits, and their map to the unit cube for optimizers.

A gait family (a spine CPG, a sine gait) describes its learnable parameters as a
:class:`ParameterLayout`, a :class:`ParameterVector` that makes a gait (system identification
fits a plain :class:`ParameterVector`): an ordered tuple of :class:`Parameter` entries, each with
bounds and a nominal value. Optimizers search the unit cube; :meth:`ParameterVector.from_unit`
maps a point back to physical values, and the layout's ``gait(values)`` builds the gait.
"""

from __future__ import annotations

import abc
import dataclasses
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # the gaits import this module
    from tensim.control.sine import SineGait
    from tensim.control.spine import SpineCPG


@dataclasses.dataclass(frozen=True)
class Bounds:
    """A parameter's range and nominal value.

    Attributes:
        low: lower bound.
        high: upper bound, > low.
        nominal: default value, within the bounds.
    """

    low: float
    high: float
    nominal: float

    def __post_init__(self) -> None:
        values = (self.low, self.high, self.nominal)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"bounds must be finite, got {values}")
        if not self.low < self.high:
            raise ValueError(f"bounds need low < high, got {self.low} and {self.high}")
        if not self.low <= self.nominal <= self.high:
            raise ValueError(f"nominal {self.nominal} lies outside [{self.low}, {self.high}]")


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One named, bounded entry of a parameter vector.

    Attributes:
        name: e.g. ``weight/0/outer_top|inner_left``, ``amplitude``.
        bounds: its range and nominal value.
    """

    name: str
    bounds: Bounds


class ParameterVector(abc.ABC):
    """Named, bounded entries in vector order, and the vector operations on them (checks,
    clipping, the unit-cube map, name <-> value)."""

    @property
    @abc.abstractmethod
    def parameters(self) -> tuple[Parameter, ...]:
        """The entries, in vector order."""

    @property
    def names(self) -> tuple[str, ...]:
        """Entry names, in vector order."""
        return tuple(p.name for p in self.parameters)

    @property
    def size(self) -> int:
        """Number of parameters."""
        return len(self.parameters)

    @property
    def low(self) -> np.ndarray:
        """(size,) lower bounds."""
        return np.array([p.bounds.low for p in self.parameters])

    @property
    def high(self) -> np.ndarray:
        """(size,) upper bounds."""
        return np.array([p.bounds.high for p in self.parameters])

    @property
    def nominal(self) -> np.ndarray:
        """(size,) nominal values."""
        return np.array([p.bounds.nominal for p in self.parameters])

    def vector(self, values: Sequence[float] | np.ndarray, what: str = "values") -> np.ndarray:
        """``values`` as a checked (size,) float array.

        Raises:
            ValueError: a wrong shape or a non-finite entry, naming ``what``.
        """
        v = np.asarray(values, dtype=float)
        if v.shape != (self.size,):
            raise ValueError(f"{what} must have shape ({self.size},), got {v.shape}")
        if not np.isfinite(v).all():
            raise ValueError(f"{what} must be finite")
        return v

    def check_bounds(self, values: Sequence[float] | np.ndarray) -> np.ndarray:
        """The checked vector; raises ValueError naming every entry outside its bounds."""
        v = self.vector(values)
        slack = 1e-12 * (self.high - self.low)
        outside = (v < self.low - slack) | (v > self.high + slack)
        if outside.any():
            bad = {self.names[i]: float(v[i]) for i in np.flatnonzero(outside)}
            raise ValueError(f"parameters outside their bounds: {bad} (use clip)")
        return v

    def clip(self, values: Sequence[float] | np.ndarray) -> np.ndarray:
        """``values`` clipped into the bounds."""
        return np.clip(self.vector(values), self.low, self.high)

    def to_unit(self, values: Sequence[float] | np.ndarray) -> np.ndarray:
        """Maps values in the bounds to [0, 1] (low -> 0, high -> 1)."""
        v = self.check_bounds(values)
        return np.clip((v - self.low) / (self.high - self.low), 0.0, 1.0)

    def from_unit(self, unit: Sequence[float] | np.ndarray) -> np.ndarray:
        """Maps [0, 1] back to values in the bounds (the inverse of :meth:`to_unit`)."""
        u = self.vector(unit, "unit")
        if (u < 0).any() or (u > 1).any():
            raise ValueError("unit values must lie in [0, 1]")
        return self.low + u * (self.high - self.low)

    def as_dict(self, values: Sequence[float] | np.ndarray) -> dict[str, float]:
        """name -> value."""
        v = self.vector(values)
        return {name: float(x) for name, x in zip(self.names, v, strict=True)}

    def from_dict(self, named: dict[str, float], what: str = "parameters") -> np.ndarray:
        """The vector from name -> value; every entry must be given, no unknown names.

        Raises:
            ValueError: naming the missing or unknown entries.
        """
        missing = [n for n in self.names if n not in named]
        unknown = sorted(set(named) - set(self.names))
        if missing or unknown:
            raise ValueError(f"{what}: missing {missing[:5]}{'...' if len(missing) > 5 else ''}"
                             f", unknown {unknown[:5]}; expected the {self.size} entries "
                             f"{list(self.names[:3])}...")
        return self.check_bounds([float(named[n]) for n in self.names])


class ParameterLayout(ParameterVector):
    """A gait family's parameter vector: its values make a gait."""

    @abc.abstractmethod
    def gait(self, values: Sequence[float] | np.ndarray | None = None) -> SineGait | SpineCPG:
        """The gait for a parameter vector (None: the nominal values)."""
