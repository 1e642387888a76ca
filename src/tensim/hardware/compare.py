"""Simulated versus logged cable tensions: time alignment and the paper's error figures.

The headline figure is the paper's: the error on the maximum system tension (the largest
tension any cable reaches), in percent of the hardware's (6.1 %, 7.9 % and 1.6 % in its
Fig. 3-5). Beside it, per cable and for the whole robot: the error on the maximum tension,
the RMSE, the correlation, the mean pretension offset and the oscillation amplitude ratio.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from tensim.hardware.loads import load_window, replay_loads
from tensim.hardware.logs import HardwareLog
from tensim.hardware.replay import node_positions
from tensim.hardware.sensor import SensorModel, interpolate
from tensim.limits import check_count
from tensim.model import CompiledModel
from tensim.sim import TimeSeries

MAX_LAGS = 10_000  # most time lags one offset estimate tries
SETTLE_S = 1.0  # s, default start of the "after settling" maxima


@dataclasses.dataclass(frozen=True)
class CableErrors:
    """How one cable's simulated tension matches the logged one (on the log's samples).

    Attributes:
        max_hardware_N, max_simulated_N: largest tension [N].
        max_error_percent: 100 (max simulated - max logged) / max logged [%].
        rmse_N: root-mean-square difference [N].
        correlation: Pearson correlation of the two series [-].
        pretension_offset_N: mean simulated - mean logged tension [N].
        amplitude_ratio: oscillation amplitude (standard deviation) simulated / logged [-].
    """

    max_hardware_N: float
    max_simulated_N: float
    max_error_percent: float
    rmse_N: float
    correlation: float
    pretension_offset_N: float
    amplitude_ratio: float


def _errors(hw: np.ndarray, sim: np.ndarray) -> CableErrors:
    """Errors over the rows where both series have a sample (flattened inputs)."""
    keep = np.isfinite(hw) & np.isfinite(sim)
    hw, sim = hw[keep], sim[keep]
    if hw.size == 0:
        nan = float("nan")
        return CableErrors(nan, nan, nan, nan, nan, nan, nan)
    std_hw, std_sim = float(hw.std()), float(sim.std())
    correlation = float(np.corrcoef(hw, sim)[0, 1]) if std_hw > 0 and std_sim > 0 else np.nan
    peak_hw, peak_sim = float(hw.max()), float(sim.max())
    return CableErrors(peak_hw, peak_sim,
                       100.0 * (peak_sim - peak_hw) / peak_hw if peak_hw > 0 else np.nan,
                       float(np.sqrt(np.mean((sim - hw) ** 2))), correlation,
                       float(sim.mean() - hw.mean()),
                       std_sim / std_hw if std_hw > 0 else np.nan)


@dataclasses.dataclass(frozen=True)
class Comparison:
    """Logged and simulated tensions on the log's feedback times, and their errors.

    Attributes:
        cables: the compared cables.
        time: (S,) sample times from the log's start [s].
        hardware: (S, n) logged tensions [N] (NaN: no sample).
        simulated: (S, n) simulated readings at the same times [N].
        offset_s: the readings lag the simulation by this much: sample k is compared with the
            simulation at time[k] - offset_s [s].
        setpoint: (S, n) logged commanded tension [N], if the log has it.
        alignment: how ``offset_s`` was found (estimated, refused as ill-posed, or given).
        settle_s: the "after settling" maxima leave out samples before this time [s]
            (the t = 0 sample is the build pretension, identical in both by construction).
        load_window: (start, end) of the logged external loads [s] (None: no loads).
    """

    cables: tuple[str, ...]
    time: np.ndarray
    hardware: np.ndarray
    simulated: np.ndarray
    offset_s: float
    setpoint: np.ndarray | None = None
    alignment: str = "given"
    settle_s: float = SETTLE_S
    load_window: tuple[float, float] | None = None

    def cable_errors(self) -> dict[str, CableErrors]:
        """Cable name -> its errors."""
        return {c: _errors(self.hardware[:, k], self.simulated[:, k])
                for k, c in enumerate(self.cables)}

    def system_errors(self) -> CableErrors:
        """Errors over all cables together.

        The maximum is the maximum system tension; the correlation and the amplitude ratio
        are taken after removing each cable's own mean (they measure the oscillations, not the
        spread of pretensions between cables); the rest pool every sample.
        """
        pooled = _errors(self.hardware.ravel(), self.simulated.ravel())
        hw, sim = _centred(self.hardware, self.simulated)
        shape = _errors(hw.ravel(), sim.ravel())
        return dataclasses.replace(pooled, correlation=shape.correlation,
                                   amplitude_ratio=shape.amplitude_ratio)

    def maxima(self, start: float = -np.inf, end: float = np.inf) -> dict[str, float | None]:
        """Maximum system tension, logged and simulated, and its error, over samples with
        start <= time <= end: ``hardware_N``, ``simulated_N``, ``error_percent``."""
        rows = (self.time >= start) & (self.time <= end)
        e = _errors(self.hardware[rows].ravel(), self.simulated[rows].ravel())
        return {"hardware_N": _round(e.max_hardware_N), "simulated_N": _round(e.max_simulated_N),
                "error_percent": _round(e.max_error_percent)}

    def cable_maxima(self, start: float = -np.inf, end: float = np.inf
                     ) -> dict[str, float | None]:
        """Per cable, the error on its maximum tension over start <= time <= end [%]."""
        rows = (self.time >= start) & (self.time <= end)
        return {c: _round(_errors(self.hardware[rows, k], self.simulated[rows, k])
                          .max_error_percent) for k, c in enumerate(self.cables)}

    def summary(self) -> dict[str, Any]:
        """JSON-ready figures, the maximum-system-tension error first.

        Three maxima: over the whole run (``max_system_tension_*``, the paper's figure, which
        includes the t = 0 build pretension), after settling (``max_settled_system_tension_*``,
        from ``settle_s``) and, for a log with loads, inside the load window
        (``max_loaded_system_tension_*``).
        """
        system = self.system_errors()
        settled = self.maxima(self.settle_s)
        loaded = self.maxima(*self.load_window) if self.load_window else None
        settled_cables = self.cable_maxima(self.settle_s)
        return {
            "max_system_tension_error_percent": _round(system.max_error_percent),
            "max_system_tension_hardware_N": _round(system.max_hardware_N),
            "max_system_tension_simulated_N": _round(system.max_simulated_N),
            "max_settled_system_tension_error_percent": settled["error_percent"],
            "max_settled_system_tension_hardware_N": settled["hardware_N"],
            "max_settled_system_tension_simulated_N": settled["simulated_N"],
            "settle_s": self.settle_s,
            "max_loaded_system_tension_error_percent": loaded and loaded["error_percent"],
            "max_loaded_system_tension_hardware_N": loaded and loaded["hardware_N"],
            "max_loaded_system_tension_simulated_N": loaded and loaded["simulated_N"],
            "load_window_s": list(self.load_window) if self.load_window else None,
            "rmse_N": _round(system.rmse_N),
            "correlation": _round(system.correlation),
            "pretension_offset_N": _round(system.pretension_offset_N),
            "amplitude_ratio": _round(system.amplitude_ratio),
            "time_offset_s": _round(self.offset_s),
            "time_offset_from": self.alignment,
            "samples": int(np.isfinite(self.hardware).sum()),
            "cables": {c: {**{k: _round(v) for k, v in dataclasses.asdict(e).items()},
                           "max_settled_error_percent": settled_cables[c]}
                       for c, e in self.cable_errors().items()},
        }


def _centred(hw: np.ndarray, sim: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both series with each cable's mean over their common samples removed."""
    both = np.isfinite(hw) & np.isfinite(sim)
    hw, sim = np.where(both, hw, np.nan), np.where(both, sim, np.nan)
    with np.errstate(invalid="ignore"):
        return hw - np.nanmean(hw, axis=0), sim - np.nanmean(sim, axis=0)


def _round(value: float) -> float | None:
    return None if not np.isfinite(value) else round(float(value), 6)


@dataclasses.dataclass(frozen=True)
class Alignment:
    """A time-offset estimate and whether the signal supports it.

    Attributes:
        offset_s: the lag of the log behind the simulation [s] (0 when ill-posed).
        well_posed: whether the cross-correlation has a sharp peak inside the search range.
        note: why it was refused, or how it was found.
    """

    offset_s: float
    well_posed: bool
    note: str


def align(time: np.ndarray, hardware: np.ndarray, sim_time: np.ndarray, simulated: np.ndarray,
          max_offset: float = 0.5, step: float = 0.005, max_width: float = 0.1) -> Alignment:
    """The lag of the logged tensions behind the simulated ones, by cross-correlation, or a
    refusal where the signal does not determine it.

    For each candidate lag the mean-removed cable tensions are correlated with the simulation
    shifted by it, summed over cables (the inner and outer cables oscillate in opposite phase,
    so the sum of tensions would cancel); the best lag is refined by a parabola through the
    peak. The estimate is ill-posed (offset 0) when the best lag is at the search bound, or
    when the lags scoring within 0.01 of the best span more than ``max_width``: a step/hold
    test or a slow ramp correlates almost equally well at any lag (a 1 Hz gait spans 35-70 ms,
    a 1 s push ramp 110 ms or more).

    Args:
        time: (S,) log sample times [s].
        hardware: (S, n) logged tensions [N] (NaN: missing).
        sim_time: (T,) simulation times [s].
        simulated: (T, n) simulated tensions [N].
        max_offset: largest lag tried, either way [s]; keep it below half a gait period.
        step: lag grid spacing [s].
        max_width: widest near-best span of lags that still counts as a sharp peak [s].
    """
    check_count(f"time lags tried up to +-{max_offset:g} s every {step:g} s",
                2 * max_offset / step + 1, MAX_LAGS, forceable=False)
    lags = np.arange(-max_offset, max_offset + step / 2, step)
    scores = np.array([_score(hardware, interpolate(sim_time, simulated, time - lag))
                       for lag in lags])
    k = int(np.nanargmax(scores))
    near = lags[scores >= scores[k] - 0.01]
    width = float(near.max() - near.min())
    if k in (0, lags.size - 1):
        return Alignment(0.0, False, f"ill-posed: the best lag is at the search bound "
                         f"({lags[k] * 1000:+.0f} ms); offset 0 used")
    if width > max_width:
        return Alignment(0.0, False, f"ill-posed: lags over {width * 1000:.0f} ms correlate "
                         f"within 0.01 of the best (a step/hold signal); offset 0 used")
    a, b, c = scores[k - 1: k + 2]
    curvature = a - 2 * b + c
    best = lags[k] + step * 0.5 * (a - c) / curvature if curvature < 0 else lags[k]
    return Alignment(float(best), True, f"cross-correlation peak (width {width * 1000:.0f} ms)")


def estimate_offset(time: np.ndarray, hardware: np.ndarray, sim_time: np.ndarray,
                    simulated: np.ndarray, max_offset: float = 0.5, step: float = 0.005
                    ) -> float:
    """The lag [s] of :func:`align` (0 where it is ill-posed): reading k matches the
    simulation at time[k] - lag."""
    return align(time, hardware, sim_time, simulated, max_offset, step).offset_s


def _score(hardware: np.ndarray, shifted: np.ndarray) -> float:
    hw, sim = _centred(hardware, shifted)
    hw, sim = np.nan_to_num(hw), np.nan_to_num(sim)
    norm = np.sqrt((hw**2).sum() * (sim**2).sum())
    return float((hw * sim).sum() / norm) if norm > 0 else 0.0


def compare_tensions(log: HardwareLog, simulated: TimeSeries, *,
                     sensor: SensorModel | None = None, offset: float | None = None,
                     max_offset: float = 0.5, skip: float = 0.0, end: float = np.inf,
                     settle: float = SETTLE_S) -> Comparison:
    """Compares a log's tensions with a simulation of it (simulation time 0 = log start).

    Args:
        log: the hardware log (tensions in N).
        simulated: the simulated run (``tension/<cable>`` channels).
        sensor: applied to the simulated tensions (gain, offset) before comparing.
        offset: lag of the readings behind the simulation [s]; None uses ``sensor.delay``
            when a sensor is given, else estimates it (:func:`estimate_offset`).
        max_offset: largest lag the estimate tries [s].
        skip: leave out the log's first seconds (e.g. a settling transient) [s].
        end: leave out the samples after this time from the log's start [s] (e.g. past the
            end of a simulation that covers only part of the log).
        settle: start of the "after settling" maxima [s].

    Raises:
        KeyError: a logged cable the simulation lacks.
    """
    cables = tuple(log.cables("tension"))
    values = log.series.matrix("tension", cables)
    since = log.series.time - log.start
    rows = ~np.isnan(values).all(axis=1) & (since >= skip) & (since <= end)
    time, hardware = log.series.time[rows] - log.start, values[rows]
    true = simulated.matrix("tension", cables)
    how = "given"
    if offset is None and sensor is not None:
        offset, how = sensor.delay, "sensor delay"
    elif offset is None:
        found = align(time, hardware, simulated.time, true, max_offset)
        offset, how = found.offset_s, found.note
    reading = dataclasses.replace(sensor or SensorModel(), delay=offset)
    predicted = reading.expected(simulated.time, true, time)
    return Comparison(cables, time, hardware, predicted, float(offset),
                      _logged(log, "setpoint", cables, rows), how, settle,
                      load_window(replay_loads(log)))


def _logged(log: HardwareLog, quantity: str, cables: tuple[str, ...], rows: np.ndarray
            ) -> np.ndarray | None:
    """(rows, n) logged ``quantity`` per cable (NaN for cables without it); None if absent."""
    if not log.cables(quantity):
        return None
    out = np.full((int(rows.sum()), len(cables)), np.nan)
    for k, cable in enumerate(cables):
        if f"{quantity}/{cable}" in log.series.channels:
            out[:, k] = log.series[f"{quantity}/{cable}"][rows]
    return out



def displacement_errors(log: HardwareLog, simulated: TimeSeries, compiled: CompiledModel,
                        offset: float) -> dict[str, float]:
    """RMS error of each motion-captured node's displacement from its first logged sample.

    Displacements rather than positions, so the motion-capture frame's origin need not match
    the model's (its axes must).

    Args:
        log: the hardware log, with ``mocap_x/<node>`` ... columns [m].
        simulated: the simulated run (body poses).
        compiled: the model it ran (node placement on the bodies).
        offset: lag of the log behind the simulation [s].

    Returns:
        node -> RMS displacement error [m].
    """
    out = {}
    nodes = log.cables("mocap_x")
    for node, xyz in node_positions(simulated, compiled, nodes).items():
        rows = ~np.isnan(log.series[f"mocap_x/{node}"])
        time = log.series.time[rows] - log.start
        logged = np.stack([log.series[f"mocap_{a}/{node}"][rows] for a in "xyz"], axis=1)
        predicted = interpolate(simulated.time, xyz, time - offset)
        error = (predicted - predicted[0]) - (logged - logged[0])
        out[node] = float(np.sqrt(np.mean(np.sum(error**2, axis=1))))
    return out
