"""Sensor model, time alignment and error figures, checked against closed-form signals; a
simulated log replays exactly."""

from __future__ import annotations

import numpy as np
import pytest

from tensim.control import load_controller, tetraspine_sine
from tensim.hardware import (
    PAPER_LOADCELL,
    HardwareLog,
    SensorModel,
    compare_tensions,
    estimate_offset,
    replay,
    simulated_log,
)
from tensim.models import tetraspine3
from tensim.sim import TimeSeries

SIM_T = np.arange(0.0, 10.0 + 1e-9, 0.01)  # a simulation's 100 Hz record [s]
LOG_T = np.arange(0.0, 9.0 + 1e-9, 0.2)  # the robot's 200 ms feedback [s]


def _waves(t: np.ndarray) -> np.ndarray:
    """Two cables oscillating in opposite phase at 1 Hz around 20 N and 10 N."""
    s = np.sin(2 * np.pi * t)
    return np.stack([20 + 3 * s, 10 - 2 * s], axis=1)


def _log(t: np.ndarray, tension: np.ndarray) -> HardwareLog:
    return HardwareLog(TimeSeries(t, {"tension/a": tension[:, 0], "tension/b": tension[:, 1]}))


def _sim(t: np.ndarray, tension: np.ndarray) -> TimeSeries:
    return TimeSeries(t, {"tension/a": tension[:, 0], "tension/b": tension[:, 1]})


def test_sensor_delay_gain_offset():
    sensor = SensorModel(offset=0.5, gain=1.1, delay=0.03)
    reading = sensor.expected(SIM_T, _waves(SIM_T), LOG_T[1:])
    # linear interpolation of a 1 Hz sine on a 10 ms grid errs by at most (2π)² A dt² / 8
    np.testing.assert_allclose(reading, 1.1 * _waves(LOG_T[1:] - 0.03) + 0.5, atol=0.002)


def test_sensor_noise_and_quantisation():
    sensor = SensorModel(noise=0.2, loadcell=PAPER_LOADCELL)
    flat = np.full((SIM_T.size, 1), 20.0)
    at = np.linspace(0, 10, 20000)
    reading = sensor.measure(SIM_T, flat, at, np.random.default_rng(3))[:, 0]
    counts = (reading - PAPER_LOADCELL.offset) / PAPER_LOADCELL.gain
    np.testing.assert_allclose(counts, np.rint(counts), atol=1e-9)  # on the ADC grid
    # noise 0.2 N plus uniform rounding of one 0.1567 N count: variance 0.2² + 0.1567²/12
    assert reading.std() == pytest.approx(np.sqrt(0.04 + 0.1567**2 / 12), rel=0.03)
    assert reading.mean() == pytest.approx(20.0, abs=0.01)  # rounding has no bias on average
    with pytest.raises(ValueError, match="rng"):
        sensor.measure(SIM_T, flat, at)  # randomness is an argument


@pytest.mark.parametrize("lag", [-0.07, 0.0, 0.03, 0.12])
def test_estimate_offset_recovers_known_lag(lag):
    logged = _waves(LOG_T - lag)  # the log lags the simulation by `lag`
    found = estimate_offset(LOG_T, logged, SIM_T, _waves(SIM_T), max_offset=0.4)
    assert found == pytest.approx(lag, abs=0.002)  # parabola on a 5 ms grid


def test_error_figures_closed_form():
    # simulation = 0.9 x the oscillation, 0.4 N above the hardware, no lag
    t = np.arange(0.0, 10.0, 0.05)  # whole periods, so sine moments are exact
    s = np.sin(2 * np.pi * t)
    hw = np.stack([20 + 3 * s, 10 - 2 * s], axis=1)
    sim = np.stack([20.4 + 2.7 * s, 10.4 - 1.8 * s], axis=1)
    c = compare_tensions(_log(t, hw), _sim(t, sim), offset=0.0)
    e = c.cable_errors()["a"]
    assert e.max_error_percent == pytest.approx(100 * (23.1 - 23.0) / 23.0)
    assert e.pretension_offset_N == pytest.approx(0.4)
    assert e.amplitude_ratio == pytest.approx(0.9)
    assert e.correlation == pytest.approx(1.0)
    # RMSE² = offset² + (amplitude difference)² / 2 for whole periods
    assert e.rmse_N == pytest.approx(np.sqrt(0.4**2 + 0.3**2 / 2))
    system = c.system_errors()
    assert system.max_hardware_N == pytest.approx(23.0)
    assert system.max_error_percent == pytest.approx(100 * 0.1 / 23.0)
    assert system.amplitude_ratio == pytest.approx(0.9)  # both cables scaled by 0.9
    assert system.correlation == pytest.approx(1.0)  # cable means removed before pooling
    assert c.summary()["max_system_tension_error_percent"] == pytest.approx(100 * 0.1 / 23.0)


def test_skip_leaves_out_the_start():
    hw = _waves(LOG_T)
    sim = _waves(SIM_T)
    sim[SIM_T < 1.0] += 50.0  # a settling transient
    c = compare_tensions(_log(LOG_T, hw), _sim(SIM_T, sim), offset=0.0, skip=1.0)
    assert c.time[0] == pytest.approx(1.0)
    assert c.system_errors().rmse_N < 0.01


def test_simulated_log_replays_exactly():
    robot = tetraspine3()
    impedance = load_controller("tetraspine3_impedance", robot)
    log = simulated_log(robot, impedance.with_gait(tetraspine_sine(robot, 0.05, 1.0)), 2.0)
    result = replay(log, robot, impedance)  # V* from the log; exact sensor, no delay
    c = compare_tensions(log, result.trajectory, offset=0.0)
    # same V* table, same start, same physics: bit-identical tensions
    assert c.system_errors().rmse_N == 0.0
    assert abs(compare_tensions(log, result.trajectory).offset_s) < 0.003
