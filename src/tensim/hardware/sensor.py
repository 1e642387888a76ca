"""A sensor model that makes simulated tensions look like logged ones.

The robot's readings differ from the simulator's true spring tension by a zero offset and gain
of the load cell, its quantisation to ADC counts (eq. 7: 0.1567 N per count), electrical noise,
and a delay: a reading is stored some time after the commands that shaped it (control loop,
I2C round trip). These act on signals only, so fitting them needs no new simulation.
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path

import numpy as np

from tensim._files import write_json
from tensim._input import InputError, describe, is_real, load_json, read_text
from tensim.hardware.loadcell import LoadCell


@dataclasses.dataclass(frozen=True)
class SensorModel:
    """Logged reading = quantise(gain * T(t - delay) + offset + noise).

    Attributes:
        offset: added to every reading [N] (zero drift of the load cell).
        gain: multiplies the true tension [-].
        noise: standard deviation of white reading noise [N].
        delay: a reading logged at time t shows the tension at t - delay [s].
        loadcell: quantise readings to this load cell's ADC counts and range (None: exact).
    """

    offset: float = 0.0
    gain: float = 1.0
    noise: float = 0.0
    delay: float = 0.0
    loadcell: LoadCell | None = None

    def __post_init__(self) -> None:
        for name in ("offset", "gain", "noise", "delay"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"sensor {name} must be finite, got {getattr(self, name)}")
        if self.gain <= 0:
            raise ValueError(f"sensor gain must be > 0, got {self.gain}")
        if self.noise < 0:
            raise ValueError(f"sensor noise must be >= 0 N, got {self.noise}")

    def expected(self, time: np.ndarray, tension: np.ndarray, at: np.ndarray) -> np.ndarray:
        """The noise-free, unquantised reading: gain * T(at - delay) + offset.

        Args:
            time: (T,) simulation sample times [s].
            tension: (T, n) true tensions [N].
            at: (S,) reading times on the same clock [s].

        Returns:
            (S, n) readings [N].
        """
        return self.gain * interpolate(time, tension, np.asarray(at) - self.delay) + self.offset

    def measure(self, time: np.ndarray, tension: np.ndarray, at: np.ndarray,
                rng: np.random.Generator | None = None) -> np.ndarray:
        """Readings at ``at`` with noise and quantisation, as the robot would log them.

        Raises:
            ValueError: ``noise`` > 0 and no ``rng`` (randomness is an argument).
        """
        reading = self.expected(time, tension, at)
        if self.noise > 0:
            if rng is None:
                raise ValueError("a noisy sensor needs an rng (np.random.default_rng(seed))")
            reading = reading + rng.normal(0.0, self.noise, reading.shape)
        if self.loadcell is not None:
            reading = self.loadcell.quantise(reading)
        return reading

    def to_dict(self) -> dict[str, object]:
        """JSON-ready fields."""
        return {"offset_N": self.offset, "gain": self.gain, "noise_N": self.noise,
                "delay_s": self.delay,
                "loadcell": None if self.loadcell is None else self.loadcell.to_dict()}


def interpolate(time: np.ndarray, values: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Linear interpolation of each column of (T, n) ``values`` at times ``at``.

    Times outside ``time`` take the first or last sample (a held reading).
    """
    values = np.asarray(values, dtype=float)
    columns = [np.interp(at, time, values[:, k]) for k in range(values.shape[1])]
    return np.stack(columns, axis=1) if columns else np.zeros((np.size(at), 0))


def save_measurement(path: Path, sensor: SensorModel, vstar_scale: float = 1.0) -> None:
    """Writes the fitted measurement model (and V* scale) as JSON, atomically."""
    write_json(path, {"offset_N": sensor.offset, "gain": sensor.gain, "delay_s": sensor.delay,
                      "vstar_scale": vstar_scale})


def load_measurement(path: str | os.PathLike[str]) -> tuple[SensorModel, float]:
    """Reads :func:`save_measurement`'s file: the sensor model and the V* scale.

    Raises:
        InputError: a field that is not a finite number (or out of range), naming the file.
    """
    data = load_json(read_text(path), str(path))
    fields = {"offset_N": 0.0, "gain": 1.0, "delay_s": 0.0, "vstar_scale": 1.0}
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a JSON object with {list(fields)}")
    values = {k: data.get(k, default) for k, default in fields.items()}
    bad = [k for k, v in values.items() if not is_real(v)]
    if bad:
        raise InputError(f"{path}: {bad[0]} must be a finite number, got "
                         f"{describe(values[bad[0]])}")
    if values["vstar_scale"] <= 0:
        raise InputError(f"{path}: vstar_scale must be > 0, got {values['vstar_scale']!r}")
    try:
        sensor = SensorModel(offset=float(values["offset_N"]), gain=float(values["gain"]),
                             delay=float(values["delay_s"]))
    except ValueError as err:
        raise InputError(f"{path}: {err}") from None
    return sensor, float(values["vstar_scale"])
