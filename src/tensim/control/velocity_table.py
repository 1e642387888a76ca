"""Sampled target-velocity inputs V* (the robot's command packets), as data and as text files.

A :class:`VelocityTable` holds V* for some cables at a fixed period; row r applies for
t in [r, r + 1)·period (a zero-order hold, as the robot's motor boards hold each 10 ms
packet). Every gait reduces to one, so the same table is what the simulation plays and what
``tensim export-trajectory`` writes for the hardware.

Text format (whitespace-separated, ``#`` lines are comments)::

    # tensim velocity input: target cable velocity V* of the impedance law (eq. 3)
    # units: time_s in s, V* in m/s times hardware_scale
    # period_s: 0.01
    # hardware_scale: 1
    time_s outer_right_1 outer_left_1 ...
    0 0.0012 -0.0012 ...
    0.01 ...

``hardware_scale`` multiplies the written V* (the paper's hardware ran amplitudes ten times the
simulator's); reading divides it out again, so a file plays back as the simulated input.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tensim._files import write_text
from tensim._input import InputError, describe, read_text
from tensim.control._common import check_driven, full_table
from tensim.control.impedance import ImpedanceController
from tensim.sim import CableSetup

HEADER = "# tensim velocity input: target cable velocity V* of the impedance law (eq. 3)"


class VelocityFileError(InputError):
    """A velocity-input file is malformed; the message names the file, line and column."""


@dataclasses.dataclass(frozen=True, eq=False)
class VelocityTable:
    """V* for some cables, sampled at a fixed period and held between samples.

    Attributes:
        cables: column names.
        period: time between rows [s], > 0.
        values: (rows, len(cables)) V* [m/s]; row r applies for t in [r, r + 1)·period.
    """

    cables: tuple[str, ...]
    period: float
    values: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "cables", tuple(str(c) for c in self.cables))
        values = np.array(self.values, dtype=float)
        values.setflags(write=False)
        object.__setattr__(self, "values", values)
        if not (math.isfinite(self.period) and self.period > 0):
            raise ValueError(f"period must be a finite time > 0 s, got {self.period}")
        if len(set(self.cables)) != len(self.cables) or not self.cables:
            raise ValueError(f"cables must be unique and at least one, got {self.cables}")
        if values.ndim != 2 or values.shape[1] != len(self.cables) or values.shape[0] < 1:
            raise ValueError(f"values must be (rows >= 1, {len(self.cables)}), got "
                             f"{values.shape}")
        if not np.isfinite(values).all():
            raise ValueError("values must be finite")

    @property
    def times(self) -> np.ndarray:
        """(rows,) start time of each row [s]."""
        return np.arange(self.values.shape[0]) * self.period

    @property
    def duration(self) -> float:
        """Time the table covers, up to its last row's start [s]."""
        return (self.values.shape[0] - 1) * self.period

    def velocity_table(self, duration: float, period: float) -> VelocityTable:
        """This table (already sampled: ``duration`` and ``period`` are not used)."""
        return self

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, VelocityTable) and self.cables == other.cables
                and self.period == other.period and np.array_equal(self.values, other.values))

    __hash__ = None  # type: ignore[assignment]


@dataclasses.dataclass(frozen=True)
class TableController:
    """Impedance laws whose V* is played from a table (zero-order hold).

    Past the table's end the drive holds the last row.

    Attributes:
        table: the V* samples; every column's cable must have impedance gains.
        impedance: the impedance laws.
    """

    table: VelocityTable
    impedance: ImpedanceController
    # the table placed at each model's cables, read-only: the simulations of one controller
    # share it (a batch of thousands of worlds on a few gaits holds and computes each once)
    _placed: dict[tuple[int, ...], np.ndarray] = dataclasses.field(
        default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        check_driven(self.impedance, self.table.cables)

    def configure(self, sim: CableSetup) -> None:
        """Writes the impedance gains and the V* table into ``sim.drive``."""
        self.impedance.configure(sim)
        key = (sim.compiled.n_cables, *(sim.index.cable_id(c) for c in self.table.cables))
        full = self._placed.get(key)
        if full is None:
            full = full_table(sim, self.table.cables, self.table.values)
            full.flags.writeable = False
            self._placed[key] = full
        sim.drive.set_target_velocity(full, self.table.period)


def save_velocity_table(table: VelocityTable, path: str | os.PathLike[str], *,
                        hardware_scale: float = 1.0, comments: Sequence[str] = ()) -> None:
    """Writes ``table`` as a text file, atomically; values keep full double precision.

    Args:
        table: the V* samples [m/s].
        path: output file.
        hardware_scale: factor applied to the written V* (and divided out on reading).
        comments: extra ``#`` lines for the header (model, controller file, ...).
    """
    if not (math.isfinite(hardware_scale) and hardware_scale > 0):
        raise ValueError(f"hardware_scale must be finite and > 0, got {hardware_scale}")
    lines = [HEADER, "# units: time_s in s, V* in m/s times hardware_scale",
             f"# period_s: {table.period!r}", f"# hardware_scale: {hardware_scale!r}",
             *(f"# {c}" for c in comments), " ".join(("time_s", *table.cables))]
    scaled = table.values * hardware_scale
    for t, row in zip(table.times, scaled, strict=True):
        lines.append(" ".join((repr(float(t)), *(repr(float(v)) for v in row))))
    write_text(Path(path), "\n".join(lines) + "\n")


def load_velocity_table(path: str | os.PathLike[str]) -> VelocityTable:
    """Reads a file written by :func:`save_velocity_table` (or by hand, in that format).

    Raises:
        FileNotFoundError: no such file.
        VelocityFileError: naming the file, the line and what was expected.
    """
    path = Path(path)
    meta: dict[str, str] = {}
    names: list[str] | None = None
    rows: list[list[float]] = []
    try:
        text = read_text(path)
    except InputError as err:
        raise VelocityFileError(str(err)) from None
    for number, line in enumerate(text.splitlines(), start=1):
        text = line.strip()
        if not text:
            continue
        if text.startswith("#"):
            key, sep, value = text[1:].partition(":")
            if sep and names is None:
                meta[key.strip()] = value.strip()
            continue
        fields = text.split()
        if names is None:
            if fields[0] != "time_s" or len(fields) < 2:
                raise VelocityFileError(f"{path}: line {number}: expected the column header "
                                        f"'time_s <cable> <cable> ...', got {text[:60]!r}")
            names = fields[1:]
            continue
        if len(fields) != len(names) + 1:
            raise VelocityFileError(f"{path}: line {number}: expected {len(names) + 1} numbers "
                                    f"(time_s and one per cable), got {len(fields)}")
        try:
            row = [float(f) for f in fields]
        except ValueError:
            bad = next(i for i, f in enumerate(fields) if not _is_float(f))
            column = "time_s" if bad == 0 else names[bad - 1]
            raise VelocityFileError(f"{path}: line {number}, column {column!r}: expected a "
                                    f"number, got {describe(fields[bad])}") from None
        if not all(math.isfinite(v) for v in row):
            raise VelocityFileError(f"{path}: line {number}: values must be finite")
        rows.append(row)
    if names is None or not rows:
        raise VelocityFileError(f"{path}: expected a 'time_s <cable> ...' header and at least "
                                "one row")
    data = np.array(rows)
    period = _period(path, meta, data[:, 0])
    scale = _positive(path, meta.get("hardware_scale", "1"), "hardware_scale")
    try:
        return VelocityTable(tuple(names), period, data[:, 1:] / scale)
    except ValueError as err:
        raise VelocityFileError(f"{path}: {err}") from None


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _positive(path: Path, text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise VelocityFileError(f"{path}: header '{what}': expected a number > 0, got "
                                f"{describe(text)}")
    return value


def _period(path: Path, meta: dict[str, str], times: np.ndarray) -> float:
    """The row period: the header's ``period_s``, checked against the time column."""
    if "period_s" in meta:
        period = _positive(path, meta["period_s"], "period_s")
    elif times.size > 1:
        period = float(times[1] - times[0])
    else:
        raise VelocityFileError(f"{path}: one row and no 'period_s' header: the period is "
                                "unknown")
    expected = np.arange(times.size) * period
    off = np.flatnonzero(np.abs(times - expected) > 1e-6 * max(period, 1.0))
    if off.size:
        row = int(off[0])
        raise VelocityFileError(f"{path}: data row {row + 1}: time_s {times[row]!r} breaks the "
                                f"uniform period {period!r} s (expected {expected[row]!r})")
    return period
