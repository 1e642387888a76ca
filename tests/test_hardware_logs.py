"""Hardware log CSV schema: robot-rate logs resample cleanly, round trips are exact, and
malformed logs fail naming the file, line and column."""

from __future__ import annotations

import numpy as np
import pytest

from tensim.hardware import HardwareLog, LogError, read_log, write_log
from tensim.hardware.logs import check_items
from tensim.models import tetraspine3


def _robot_rate_csv() -> str:
    """V* every 10 ms for 1 s (a ramp), feedback every 200 ms, as the robot's PC logs it."""
    lines = ["# model: tetraspine3", "time_s,vstar_mps/inner_top_1,tension_N/inner_top_1,"
             "setpoint_N/inner_top_1"]
    for k in range(101):
        feedback = f"{20 + k / 100:.2f},{21 + k / 100:.2f}" if k % 20 == 0 else ","
        lines.append(f"{k / 100:.2f},{k / 1000:.3f},{feedback}")
    return "\n".join(lines) + "\n"


def _series(time, channels):
    from tensim.sim import TimeSeries

    return TimeSeries(np.asarray(time, dtype=float), channels)


def test_robot_rates_resample(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text(_robot_rate_csv())
    log = read_log(path)
    assert log.meta == {"model": "tetraspine3"}
    table = log.velocity_table()
    assert table.period == pytest.approx(0.01)
    np.testing.assert_allclose(table.values[:, 0], np.arange(101) / 1000)  # every command
    times, tension = log.samples("tension")
    np.testing.assert_allclose(times, np.arange(0, 1.01, 0.2))  # the 200 ms feedback rows
    np.testing.assert_allclose(tension[:, 0], 20 + times)


def test_velocity_table_holds_jittered_commands():
    # commands sent a little late (1-3 ms) each 10 ms: each grid time takes the last one sent
    sent = np.array([0.0, 0.011, 0.022, 0.031, 0.043])
    log = HardwareLog(_series(sent, {"vstar/c": np.array([1.0, 2, 3, 4, 5]),
                                     "vstar/d": np.array([1.0, 2, np.nan, 4, 5]),
                                     "tension/c": np.ones(5)}), meta={"hardware_scale": "10"})
    table = log.velocity_table(period=0.01)
    # grid 0, 0.01, .., 0.04 -> last sent at or before: 1, 1, 2, 3, 4; /10 (hardware_scale)
    np.testing.assert_allclose(table.values[:, 0], [0.1, 0.1, 0.2, 0.3, 0.4])
    # a packet missing for one cable: it keeps its previous command
    np.testing.assert_allclose(table.values[:, 1], [0.1, 0.1, 0.2, 0.2, 0.4])
    bad = HardwareLog(log.series, source="x.csv", meta={"hardware_scale": "ten"})
    with pytest.raises(LogError, match=r"x\.csv: header 'hardware_scale'"):
        bad.velocity_table()


def test_write_read_round_trip(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text(_robot_rate_csv())
    log = read_log(path)
    again = read_log(write_log(log, tmp_path / "copy.csv"))
    assert again.meta == log.meta
    np.testing.assert_array_equal(again.series.time, log.series.time)
    for name, values in log.series.channels.items():
        np.testing.assert_array_equal(again.series[name], values)


@pytest.mark.parametrize(("text", "message"), [
    ("t,tension_N/c\n0,1\n", r"line 1, column 1: expected 'time_s'"),
    ("time_s,force/c\n0,1\n", r"line 1, column 2 \('force/c'\): expected '<quantity>/<item>'"),
    ("time_s,vstar_mps/c\n0,1\n", r"line 1: no tension column"),
    ("time_s,tension_N/c,tension_N/c\n0,1,1\n", r"line 1, column 3 .* duplicate"),
    ("# a log\ntime_s,tension_N/c\n0,1\n0.2,abc\n", r"line 4, column 'tension_N/c': expected a "
                                                     r"finite number or an empty cell, got 'abc'"),
    ("time_s,tension_N/c\n0,1\n0.2,inf\n", r"line 3, column 'tension_N/c': expected a finite"),
    ("time_s,tension_N/c\n0,1\n0.2,2\n0.1,3\n", r"line 4, column 'time_s': time 0.1 s is not "
                                               r"after the previous row's 0.2 s"),
    ("time_s,tension_N/c\n0,1\n,2\n", r"line 3, column 'time_s': expected a finite number, "
                                      r"got ''"),
    ("time_s,tension_N/c\n0,1,2\n", r"line 2: expected 2 cells"),
    ("time_s,adc/c\n0,-3\n", r"line 2, column 'adc/c': expected ADC counts >= 0"),
    ("# only a comment\n", r"expected a 'time_s,<quantity>/<item>,...' header"),
])
def test_malformed_logs_name_file_line_column(tmp_path, text, message):
    path = tmp_path / "robot_log.csv"
    path.write_text(text)
    with pytest.raises(LogError, match=r"robot_log\.csv: .*" + message):
        read_log(path)


def test_unknown_cable_named():
    log = HardwareLog(_series([0.0], {"tension/inner_top_9": np.ones(1)}), source="run7.csv")
    with pytest.raises(LogError, match=r"run7\.csv: column 'tension_N/inner_top_9': "
                                       r"'tetraspine3' has no cable 'inner_top_9'"):
        check_items(log, tetraspine3())
