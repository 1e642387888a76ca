"""Hardware logs: the CSV schema, its validator, and resampling to the simulator's inputs.

A log is a CSV file with optional ``# key: value`` comment lines first, then a header row and
one row per sample time. The first column is ``time_s`` [s], strictly increasing; every other
column is ``<quantity>/<item>``, its unit in the quantity's name (see :data:`QUANTITIES`)::

    # model: tetraspine3
    # hardware_scale: 1
    time_s,vstar_mps/outer_right_1,...,tension_N/outer_right_1,...,setpoint_N/outer_right_1,...
    0.00,0.0012,...,7.05,...,7.0,...
    0.01,0.0019,...,,...,,...

A cell may be empty: the robot's PC sends V* every 10 ms but stores feedback every 200 ms, so a
feedback column is empty on most command rows. In memory a log is a
:class:`~tensim.sim.TimeSeries` (channels ``tension/<cable>``, ``vstar/<cable>``,
``mocap_x/<node>``, ...; NaN where a row has no sample), the type simulated runs share.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import os
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from tensim._files import write_text
from tensim._input import InputError, read_text
from tensim.control import VelocityTable
from tensim.limits import MAX_SAMPLES, check_count
from tensim.sim import TimeSeries
from tensim.structure import Structure

TIME_COLUMN = "time_s"


@dataclasses.dataclass(frozen=True)
class Quantity:
    """One kind of logged signal.

    Attributes:
        channel: the in-memory channel quantity (``tension``, ``vstar``, ...).
        item: ``cable`` or ``node``: what the column's item names.
        unit: its unit.
        description: what it is.
    """

    channel: str
    item: str
    unit: str
    description: str


# column quantity (as written in the CSV header) -> its meaning
QUANTITIES: dict[str, Quantity] = {
    "tension_N": Quantity("tension", "cable", "N", "measured (load-cell) tension"),
    "adc": Quantity("adc", "cable", "counts", "raw load-cell ADC reading (eq. 7 converts it)"),
    "setpoint_N": Quantity("setpoint", "cable", "N", "commanded tension T_set of eq. 3"),
    "encoder": Quantity("encoder", "cable", "counts", "motor encoder"),
    "length_m": Quantity("length", "cable", "m", "cable length L"),
    "pwm": Quantity("pwm", "cable", "-", "motor PWM duty, -1 to 1"),
    "vstar_mps": Quantity("vstar", "cable", "m/s", "velocity input V* actually sent"),
    "mocap_x_m": Quantity("mocap_x", "node", "m", "motion-capture x of a node"),
    "mocap_y_m": Quantity("mocap_y", "node", "m", "motion-capture y of a node"),
    "mocap_z_m": Quantity("mocap_z", "node", "m", "motion-capture z of a node"),
    "load_N": Quantity("load", "node/axis", "N",
                       "external force on a node, world x, y or z (linear between samples)"),
}
AXES = ("x", "y", "z")
_BY_CHANNEL = {q.channel: name for name, q in QUANTITIES.items()}


class LogError(InputError):
    """A hardware log is malformed; the message names the file, line and column."""


@dataclasses.dataclass(frozen=True)
class HardwareLog:
    """A validated hardware log.

    Attributes:
        series: the samples; channel ``<quantity>/<item>`` with the in-memory quantity names
            of :data:`QUANTITIES`, NaN where a row has no sample. Times as logged [s].
        source: the file it came from (or a description).
        meta: the ``# key: value`` header lines.
    """

    series: TimeSeries
    source: str = "<memory>"
    meta: dict[str, str] = dataclasses.field(default_factory=dict)

    @property
    def start(self) -> float:
        """The first time stamp [s]; simulation time 0 is this moment."""
        return float(self.series.time[0])

    @property
    def duration(self) -> float:
        """Time from the first to the last row [s]."""
        return float(self.series.time[-1] - self.series.time[0])

    def cables(self, quantity: str = "tension") -> list[str]:
        """Cables with a ``quantity`` channel, in column order."""
        return self.series.items(quantity)

    def samples(self, quantity: str, items: Sequence[str] | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
        """Rows where any of ``items`` has a ``quantity`` sample.

        Returns:
            times (T,) relative to :attr:`start` [s], and (T, n_items) values (NaN: missing).
        """
        values = self.series.matrix(quantity, items)
        rows = ~np.isnan(values).all(axis=1)
        return self.series.time[rows] - self.start, values[rows]

    def velocity_table(self, period: float | None = None) -> VelocityTable | None:
        """The logged V* as a zero-order-hold table from the log's start (None: no V*).

        Each grid time takes the last V* sent to that cable at or before it (V* = 0 before
        the first one); ``hardware_scale`` in the header divides the logged values back to
        simulator units.

        Args:
            period: table period [s]; None takes the median spacing of the V* rows.

        Raises:
            LogError: a ``hardware_scale`` header that is not a number > 0.
        """
        cables = self.cables("vstar")
        if not cables:
            return None
        times, values = self.samples("vstar", cables)
        if period is None:
            period = round(float(np.median(np.diff(times))), 9) if times.size > 1 else 0.01
        rows = math.floor(times[-1] / period + 1e-6) + 1
        check_count(f"{self.source}: V* table of {times[-1]:g} s every {period:g} s: rows",
                    rows, MAX_SAMPLES, forceable=False)
        grid = np.arange(rows) * period
        held = np.stack([_hold(times, values[:, k], grid) for k in range(len(cables))], axis=1)
        return VelocityTable(tuple(cables), period, held / self.hardware_scale())

    def hardware_scale(self) -> float:
        """The ``hardware_scale`` header: logged V* / simulator V* (1 when absent).

        Raises:
            LogError: a value that is not a number > 0.
        """
        text = self.meta.get("hardware_scale", "1")
        try:
            scale = float(text)
        except ValueError:
            scale = math.nan
        if not (math.isfinite(scale) and scale > 0):
            raise LogError(f"{self.source}: header 'hardware_scale': expected a number > 0, "
                           f"got {text!r}")
        return scale


def _hold(times: np.ndarray, values: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Zero-order hold of one column's samples onto ``grid`` (NaN: no sample; 0 before any)."""
    sent = ~np.isnan(values)
    times, values = times[sent], values[sent]
    row = np.searchsorted(times, grid + 1e-9, side="right") - 1
    return np.where(row >= 0, values[np.maximum(row, 0)] if values.size else 0.0, 0.0)


# -- reading ------------------------------------------------------------------------------------


def _header(path: Path, line: int, names: list[str]) -> list[str]:
    """Channel names for the header's columns; raises naming the first bad column."""
    if not names or names[0].strip() != TIME_COLUMN:
        got = names[0].strip() if names else ""
        raise LogError(f"{path}: line {line}, column 1: expected {TIME_COLUMN!r} as the first "
                       f"column, got {got!r}")
    channels = []
    for number, raw in enumerate(names[1:], start=2):
        name = raw.strip()
        quantity, _, item = name.partition("/")
        if quantity not in QUANTITIES or not item:
            raise LogError(f"{path}: line {line}, column {number} ({name!r}): expected "
                           f"'<quantity>/<item>' with quantity one of {list(QUANTITIES)}")
        if QUANTITIES[quantity].item == "node/axis" and item.rpartition("/")[2] not in AXES:
            raise LogError(f"{path}: line {line}, column {number} ({name!r}): expected "
                           f"'{quantity}/<node>/<axis>' with axis one of {list(AXES)}")
        channel = f"{QUANTITIES[quantity].channel}/{item}"
        if channel in channels:
            raise LogError(f"{path}: line {line}, column {number} ({name!r}): duplicate column")
        channels.append(channel)
    if not any(c.startswith(("tension/", "adc/")) for c in channels):
        raise LogError(f"{path}: line {line}: no tension column; expected at least one "
                       "'tension_N/<cable>' or 'adc/<cable>'")
    return channels


def _cell(path: Path, line: int, column: str, text: str, required: bool) -> float:
    text = text.strip()
    if not text and not required:
        return math.nan
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise LogError(f"{path}: line {line}, column {column!r}: expected a finite number"
                       f"{'' if required else ' or an empty cell'}, got {text!r}")
    return value


def csv_rows(path: Path) -> Iterator[tuple[int, list[str]]]:
    """(line number, cells) of each row of a UTF-8 CSV file.

    Raises:
        FileNotFoundError: no such file.
        LogError: not UTF-8 text, a folder, too large, or not CSV; naming the file.
    """
    try:
        text = read_text(path)
    except InputError as err:
        raise LogError(str(err)) from None
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        for fields in reader:
            yield reader.line_num, fields
    except csv.Error as err:
        raise LogError(f"{path}: line {reader.line_num + 1}: not valid CSV: {err}") from None


def read_log(path: str | os.PathLike[str]) -> HardwareLog:
    """Reads and validates a hardware log CSV.

    Raises:
        FileNotFoundError: no such file.
        LogError: naming the file, the first bad line and column, and what was expected.
    """
    path = Path(path)
    meta: dict[str, str] = {}
    header: list[str] | None = None
    rows: list[list[float]] = []
    for line, fields in csv_rows(path):
        if not fields or not "".join(fields).strip():
            continue
        if fields[0].lstrip().startswith("#"):
            key, sep, value = ",".join(fields).lstrip()[1:].partition(":")
            if sep and header is None:
                meta[key.strip()] = value.strip()
            continue
        if header is None:
            header = [TIME_COLUMN, *_header(path, line, fields)]
            continue
        rows.append(_row(path, line, fields, header, rows[-1][0] if rows else None))
    if header is None or len(rows) < 2:
        raise LogError(f"{path}: expected a '{TIME_COLUMN},<quantity>/<item>,...' header and at "
                       f"least two data rows (a log spans time), got {len(rows)}")
    data = np.array(rows)
    channels = {name: data[:, k] for k, name in enumerate(header) if k > 0}
    return HardwareLog(TimeSeries(data[:, 0], channels), str(path), meta)


def _row(path: Path, line: int, fields: list[str], header: list[str], previous: float | None
         ) -> list[float]:
    if len(fields) != len(header):
        raise LogError(f"{path}: line {line}: expected {len(header)} cells (one per header "
                       f"column), got {len(fields)}")
    names = [TIME_COLUMN, *(column_name(c) for c in header[1:])]
    row = [_cell(path, line, names[k], text, k == 0) for k, text in enumerate(fields)]
    if previous is not None and row[0] <= previous:
        raise LogError(f"{path}: line {line}, column {TIME_COLUMN!r}: time {row[0]!r} s is not "
                       f"after the previous row's {previous!r} s; expected strictly increasing "
                       "times")
    for k, value in enumerate(row[1:], start=1):
        if names[k].startswith("adc/") and value < 0:
            raise LogError(f"{path}: line {line}, column {names[k]!r}: expected ADC counts "
                           f">= 0, got {fields[k].strip()!r}")
    return row


def column_name(channel: str) -> str:
    """The CSV column of an in-memory channel (``tension/c`` -> ``tension_N/c``)."""
    quantity, _, item = channel.partition("/")
    return f"{_BY_CHANNEL[quantity]}/{item}"


def check_items(log: HardwareLog, structure: Structure) -> None:
    """Checks that every column names a cable or node of ``structure``.

    Raises:
        LogError: naming the file and the first unknown column.
    """
    cables = {c.name for c in structure.cables}
    nodes = {n.name for n in structure.nodes}
    for channel in log.series.channels:
        quantity, _, item = channel.partition("/")
        kind = QUANTITIES[_BY_CHANNEL[quantity]].item
        if kind == "node/axis":
            item, kind = item.rpartition("/")[0], "node"
        known = cables if kind == "cable" else nodes
        if item not in known:
            raise LogError(f"{log.source}: column {column_name(channel)!r}: {structure.name!r} "
                           f"has no {kind} {item!r}; expected one of {sorted(known)[:6]}...")


# -- writing ------------------------------------------------------------------------------------


def write_log(log: HardwareLog, path: str | os.PathLike[str], *, digits: int = 6) -> Path:
    """Writes ``log`` as CSV (``meta`` as comment lines), atomically.

    Args:
        log: the log.
        path: output file.
        digits: significant digits per value (times keep full precision).
    """
    path = Path(path)
    names = list(log.series.channels)
    lines = [f"# {k}: {v}" for k, v in log.meta.items()]
    lines.append(",".join([TIME_COLUMN, *(column_name(n) for n in names)]))
    columns = [log.series[n] for n in names]
    for r, t in enumerate(log.series.time):
        cells = ["" if math.isnan(c[r]) else f"{c[r]:.{digits}g}" for c in columns]
        lines.append(",".join([f"{t:.6f}".rstrip("0").rstrip("."), *cells]))
    write_text(path, "\n".join(lines) + "\n")
    return path
