"""Load-cell calibration (paper eq. 7): force = gain * ADC + offset, fitted to weight pairs.

Tetraspine3's load cells feed a 10-bit ADC through an instrumentation amplifier; the paper's
calibration is f = 0.1567 ADC - 4.9363 [N], about 0.16 N per count, up to 111.21 N. A
calibration file of pairs is a CSV with the columns ``adc,force_N`` (``#`` lines are comments).
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

from tensim._files import write_json
from tensim._input import InputError, is_real, load_json, read_text
from tensim.hardware.logs import HardwareLog, LogError, csv_rows, read_log
from tensim.sim import TimeSeries


@dataclasses.dataclass(frozen=True)
class LoadCell:
    """A calibrated load cell: force = gain * counts + offset.

    Attributes:
        gain: a, newtons per ADC count [N] (the resolution).
        offset: b, the force at 0 counts [N].
        max_force: largest measurable tension [N].
        adc_max: largest ADC count (1023 for 10 bits).
    """

    gain: float
    offset: float
    max_force: float = 111.21
    adc_max: int = 1023

    def __post_init__(self) -> None:
        if not (is_real(self.gain) and self.gain > 0):
            raise ValueError(f"load-cell gain must be > 0 N per count, got {self.gain!r}")
        if not is_real(self.offset):
            raise ValueError(f"load-cell offset must be a finite force [N], got {self.offset!r}")
        if not (is_real(self.max_force) and self.max_force > 0):
            raise ValueError(f"load-cell max_force must be a finite force > 0 N, got "
                             f"{self.max_force!r}")
        if isinstance(self.adc_max, bool) or not isinstance(self.adc_max, int) \
                or self.adc_max < 1:
            raise ValueError(f"load-cell adc_max must be a whole count >= 1, got "
                             f"{self.adc_max!r}")

    def to_newtons(self, counts: np.ndarray) -> np.ndarray:
        """Force for ADC counts [N]."""
        return self.gain * np.asarray(counts, dtype=float) + self.offset

    def to_counts(self, force: np.ndarray) -> np.ndarray:
        """The ADC reading of a force: rounded to whole counts, within [0, adc_max]."""
        counts = np.rint((np.asarray(force, dtype=float) - self.offset) / self.gain)
        return np.clip(counts, 0, self.adc_max)

    def quantise(self, force: np.ndarray) -> np.ndarray:
        """What the load cell reports for a force: on the count grid, at most ``max_force``."""
        return np.minimum(self.to_newtons(self.to_counts(force)), self.max_force)

    def to_dict(self) -> dict[str, float]:
        """JSON-ready fields."""
        return {"gain_N_per_count": self.gain, "offset_N": self.offset,
                "max_force_N": self.max_force, "adc_max": self.adc_max}


PAPER_LOADCELL = LoadCell(gain=0.1567, offset=-4.9363)
"""Tetraspine3's calibration, paper eq. (7)."""


@dataclasses.dataclass(frozen=True)
class CalibrationFit:
    """A least-squares line through (ADC, force) pairs, with its statistics.

    Attributes:
        loadcell: the fitted calibration.
        gain_stderr, offset_stderr: standard errors of a [N/count] and b [N].
        r_squared: coefficient of determination.
        residual_rms, residual_max: RMS and largest absolute residual [N].
        adc, force: (n,) the pairs; residuals: (n,) force - fit [N].
    """

    loadcell: LoadCell
    gain_stderr: float
    offset_stderr: float
    r_squared: float
    residual_rms: float
    residual_max: float
    adc: np.ndarray
    force: np.ndarray
    residuals: np.ndarray

    def summary(self) -> dict[str, Any]:
        """JSON-ready figures."""
        return {"equation": f"force_N = {self.loadcell.gain:.5g} * ADC "
                            f"{'-' if self.loadcell.offset < 0 else '+'} "
                            f"{abs(self.loadcell.offset):.5g}",
                **self.loadcell.to_dict(),
                "gain_stderr_N_per_count": self.gain_stderr,
                "offset_stderr_N": self.offset_stderr,
                "resolution_N": self.loadcell.gain,
                "r_squared": self.r_squared, "residual_rms_N": self.residual_rms,
                "residual_max_N": self.residual_max, "pairs": int(self.adc.size)}


def fit_loadcell(adc: np.ndarray, force: np.ndarray, *, max_force: float = 111.21,
                 adc_max: int = 1023) -> CalibrationFit:
    """Fits force = a * ADC + b by ordinary least squares (scipy's linregress).

    Args:
        adc: (n,) ADC readings [counts].
        force: (n,) applied forces [N].
        max_force: the calibrated range's top [N].
        adc_max: largest ADC count.

    Raises:
        ValueError: fewer than 3 pairs, or all at one ADC value.
    """
    adc, force = np.asarray(adc, dtype=float), np.asarray(force, dtype=float)
    if adc.size < 3 or adc.shape != force.shape:
        raise ValueError(f"need at least 3 (adc, force) pairs of equal length, got {adc.size}")
    if np.ptp(adc) == 0:
        raise ValueError("all pairs share one ADC value; apply several different loads")
    fit = stats.linregress(adc, force)
    residuals = force - (fit.slope * adc + fit.intercept)
    return CalibrationFit(LoadCell(float(fit.slope), float(fit.intercept), max_force, adc_max),
                          float(fit.stderr), float(fit.intercept_stderr), float(fit.rvalue**2),
                          float(np.sqrt(np.mean(residuals**2))),
                          float(np.abs(residuals).max()), adc, force, residuals)


def read_pairs(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """Reads a calibration CSV with the columns ``adc,force_N``.

    Returns:
        (n,) ADC counts and (n,) forces [N].

    Raises:
        LogError: naming the file, the first bad line and column.
    """
    path = Path(path)
    header: list[str] | None = None
    rows: list[tuple[float, float]] = []
    for line, fields in csv_rows(path):
        if not fields or not "".join(fields).strip() or fields[0].lstrip().startswith("#"):
            continue
        fields = [c.strip() for c in fields]
        if header is None:
            if sorted(fields) != ["adc", "force_N"]:
                raise LogError(f"{path}: line {line}: expected the header 'adc,force_N', "
                               f"got {','.join(fields)[:60]!r}")
            header = fields
            continue
        if len(fields) != 2:
            raise LogError(f"{path}: line {line}: expected 2 cells, got {len(fields)}")
        cells = dict(zip(header, fields, strict=True))
        rows.append((_number(path, line, "adc", cells["adc"]),
                     _number(path, line, "force_N", cells["force_N"])))
    if not rows:
        raise LogError(f"{path}: expected an 'adc,force_N' header and data rows")
    data = np.array(rows)
    return data[:, 0], data[:, 1]


def _number(path: Path, line: int, column: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise LogError(f"{path}: line {line}, column {column!r}: expected a number, got {text!r}")
    return value


def convert_log(log: HardwareLog, loadcell: LoadCell) -> HardwareLog:
    """The log with every ``adc/<cable>`` channel replaced by ``tension/<cable>`` [N]."""
    channels = {}
    for name, values in log.series.channels.items():
        quantity, _, item = name.partition("/")
        if quantity != "adc":
            channels[name] = values
        elif f"tension/{item}" not in log.series.channels:  # a logged tension_N column wins
            channels[f"tension/{item}"] = loadcell.to_newtons(values)
    meta = {**log.meta, "loadcell": f"{loadcell.gain!r} * ADC + {loadcell.offset!r}"}
    return HardwareLog(TimeSeries(log.series.time, channels), log.source, meta)


def loadcell_for(log: HardwareLog, given: LoadCell | None = None) -> LoadCell:
    """The calibration for a log's ADC columns: ``given``, else the header's, else eq. (7).

    The header form is ``# loadcell: <gain> * ADC + <offset>``.
    """
    if given is not None:
        return given
    text = log.meta.get("loadcell")
    if text is None:
        return PAPER_LOADCELL
    try:
        gain, _, offset = text.replace(" ", "").partition("*ADC+")
        return LoadCell(float(gain), float(offset))
    except ValueError:  # not two numbers, or not a valid calibration (nan, gain <= 0)
        raise LogError(f"{log.source}: header 'loadcell': expected '<gain> * ADC + <offset>', "
                       f"got {text!r}") from None


def load_log(path: str | os.PathLike[str], loadcell: LoadCell | None = None) -> HardwareLog:
    """Reads and validates a log (:func:`~tensim.hardware.logs.read_log`), ADC columns in N,
    and checks it as ``compare`` and ``sysid`` need it
    (:func:`~tensim.hardware.checklog.validate_log`).

    Args:
        path: the CSV file.
        loadcell: calibration for ``adc/`` columns (default: the header's, else eq. 7).

    Raises:
        LogError: naming the file and what was expected.
    """
    from tensim.hardware.checklog import validate_log

    log = read_log(path)
    if log.cables("adc"):
        log = convert_log(log, loadcell_for(log, loadcell))
    validate_log(log)
    return log


def save_calibration(fit: CalibrationFit, path: Path) -> None:
    """Writes the fit's summary as JSON, atomically (read back by :func:`load_calibration`)."""
    write_json(path, fit.summary())


def load_calibration(path: str | os.PathLike[str]) -> LoadCell:
    """Reads the calibration written by :func:`save_calibration`.

    Raises:
        LogError: a missing or non-numeric field, naming the file.
    """
    try:
        data = load_json(read_text(path), str(path))
    except InputError as err:
        raise LogError(str(err)) from None
    if not isinstance(data, dict):
        raise LogError(f"{path}: expected a JSON object with 'gain_N_per_count' and 'offset_N'")
    try:
        return LoadCell(data["gain_N_per_count"], data["offset_N"],
                        data.get("max_force_N", 111.21), data.get("adc_max", 1023))
    except KeyError as err:
        raise LogError(f"{path}: expected a calibration with 'gain_N_per_count' and 'offset_N' "
                       f"numbers; {err} is missing") from None
    except ValueError as err:
        raise LogError(f"{path}: {err}") from None
