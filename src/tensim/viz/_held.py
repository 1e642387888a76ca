"""Held inputs as a figure takes them (plain data: importing it loads no plotting library)."""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class HeldInputs:
    """Inputs sampled at a fixed period and held between samples, as the V* figure reads them
    (a :class:`tensim.control.VelocityTable`'s data, which the figure-drawing process can load
    without the controllers' modules).

    Attributes:
        cables: the cables, one column each.
        period: time between rows [s].
        values: (rows, len(cables)) V* [m/s]; row r applies for t in [r, r + 1)·period.
    """

    cables: tuple[str, ...]
    period: float
    values: np.ndarray

    @property
    def times(self) -> np.ndarray:
        """(rows,) start time of each row [s]."""
        return np.arange(self.values.shape[0]) * self.period
