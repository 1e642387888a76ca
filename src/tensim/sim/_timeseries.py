"""A time series with named channels, shared by simulated and measured data."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tensim._files import atomic_path


@dataclasses.dataclass(frozen=True)
class TimeSeries:
    """Samples of named scalar channels at common times.

    Channel names are ``"<quantity>/<item>"``, e.g. ``"tension/inner_top_1"`` [N] or
    ``"pos_x/segment_0"`` [m]; units follow the quantity (see :data:`UNITS`).

    Attributes:
        time: (T,) sample times [s].
        channels: name -> (T,) values.
    """

    time: np.ndarray
    channels: dict[str, np.ndarray]

    def __post_init__(self) -> None:
        for name, values in self.channels.items():
            if values.shape != self.time.shape:
                raise ValueError(f"channel {name!r} has shape {values.shape}, "
                                 f"expected {self.time.shape}")

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.channels[name]
        except KeyError:
            raise KeyError(f"no channel {name!r}; channels: {sorted(self.channels)}") from None

    def items(self, quantity: str) -> list[str]:
        """Item names that have a channel of ``quantity``, in insertion order."""
        prefix = quantity + "/"
        return [n[len(prefix):] for n in self.channels if n.startswith(prefix)]

    def matrix(self, quantity: str, items: Sequence[str] | None = None) -> np.ndarray:
        """(T, n_items) values of ``quantity`` for ``items`` (all of them by default)."""
        items = self.items(quantity) if items is None else items
        return np.stack([self[f"{quantity}/{i}"] for i in items], axis=1)

    def between(self, start: float, stop: float) -> TimeSeries:
        """The samples with start <= t <= stop."""
        keep = (self.time >= start) & (self.time <= stop)
        return TimeSeries(self.time[keep], {k: v[keep] for k, v in self.channels.items()})

    def to_parquet(self, path: str | os.PathLike[str]) -> None:
        """Writes a Parquet file (column ``time`` then the channels), atomically."""
        import pyarrow as pa  # loaded on first use: 0.1 s and 30 MiB that drawing never needs
        import pyarrow.parquet as pq

        table = pa.table({"time": self.time, **self.channels})
        with atomic_path(Path(path)) as tmp:
            # no dictionary pages: sampled floats rarely repeat, and trying costs a wide
            # table (796 cables: 5,648 columns) 40 % of its write and 12 % of its size
            pq.write_table(table, tmp, use_dictionary=False)

    @classmethod
    def from_parquet(cls, path: str | os.PathLike[str]) -> TimeSeries:
        """Reads a file written by :meth:`to_parquet`."""
        import pyarrow.parquet as pq

        table = pq.read_table(path)
        columns = {name: table.column(name).to_numpy() for name in table.column_names}
        time = columns.pop("time")
        return cls(time, columns)


UNITS = {
    "tension": "N", "applied": "N", "setpoint": "N", "length": "m", "rest_length": "m",
    "velocity": "m/s", "pos_x": "m", "pos_y": "m", "pos_z": "m",
    "quat_w": "-", "quat_x": "-", "quat_y": "-", "quat_z": "-",
}
