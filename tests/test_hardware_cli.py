"""The reality-gap commands end to end: make-log, calibrate-loadcell, compare and sysid write
their files, and a malformed log exits with a clear error."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tensim.cli import main
from tensim.control import load_controller, save_controller, tetraspine_sine
from tensim.hardware import load_log, read_log, replay
from tensim.models import tetraspine3
from tensim.structure import load_structure


@pytest.fixture(scope="module")
def raw_log(tmp_path_factory):
    """A 3 s simulated log in raw ADC counts with a stiffer 'hardware', noise and delay."""
    folder = tmp_path_factory.mktemp("logs")
    robot = tetraspine3()
    gait = load_controller("tetraspine3_impedance", robot).with_gait(
        tetraspine_sine(robot, 0.05, 1.0))
    controller = save_controller(gait, folder / "excitation.yaml")
    path = folder / "raw.csv"
    assert main(["--quiet", "make-log", "--controller", str(controller), "--duration", "3",
                 "--set", "stiffness=252", "--offset", "0.5", "--noise", "0.1", "--delay",
                 "0.03", "--adc", "--mocap", "s0_tip", "--out", str(path)]) == 0
    return path


def test_make_log_writes_robot_rates(raw_log):
    log = read_log(raw_log)
    assert log.velocity_table().period == pytest.approx(0.01)
    times, counts = log.samples("adc")
    np.testing.assert_allclose(np.diff(times), 0.2)  # 200 ms feedback
    np.testing.assert_array_equal(counts, np.rint(counts))  # whole ADC counts
    assert log.cables("mocap_x") == ["s0_tip"]
    assert log.meta["loadcell"].startswith("0.1567")


def test_compare_end_to_end(raw_log, tmp_path, capsys):
    out = tmp_path / "compare"
    assert main(["--quiet", "compare", str(raw_log), "--model", "tetraspine3", "--controller",
                 "tetraspine3_impedance", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["cables"]) == {c.name for c in tetraspine3().cables}
    assert 0.0 < summary["rmse_N"] < 2.0  # stiffer hardware, 0.5 N offset: a real gap
    assert summary["pretension_offset_N"] == pytest.approx(-0.5, abs=0.2)  # the load-cell offset
    page = (out / "report.html").read_text()
    assert "Error on the maximum system tension" in page
    assert page.count("data:image/png;base64,") == 2  # figures inlined: one self-contained page
    assert "error on the max system tension" in capsys.readouterr().out
    assert summary["mocap_displacement_rmse_m"]["s0_tip"] < 0.02  # same frame, mm-level gap
    # an existing simulated run of the same inputs gives the same figures
    run = tmp_path / "run"
    run.mkdir()
    robot = tetraspine3()
    replay(load_log(raw_log), robot, load_controller("tetraspine3_impedance", robot),
           margin=0.5).trajectory.to_parquet(run / "trajectory.parquet")
    again = tmp_path / "again"
    assert main(["--quiet", "compare", str(raw_log), "--sim", str(run), "--out",
                 str(again)]) == 0
    assert json.loads((again / "summary.json").read_text())["rmse_N"] == summary["rmse_N"]


def test_calibrate_and_convert(raw_log, tmp_path):
    pairs = tmp_path / "pairs.csv"
    adc = np.arange(30, 740, 30)
    pairs.write_text("adc,force_N\n" + "".join(f"{a},{0.1567 * a - 4.9363:.4f}\n" for a in adc))
    out = tmp_path / "cal"
    assert main(["--quiet", "calibrate-loadcell", str(pairs), "--out", str(out), "--convert",
                 str(raw_log)]) == 0
    fit = json.loads((out / "calibration.json").read_text())
    assert fit["gain_N_per_count"] == pytest.approx(0.1567, abs=1e-5)  # exact pairs, 4 digits
    assert fit["offset_N"] == pytest.approx(-4.9363, abs=1e-3)
    assert (out / "calibration.png").stat().st_size > 0
    converted = read_log(out / "raw_newtons.csv")
    assert converted.cables("tension") and not converted.cables("adc")


def test_sysid_writes_fitted_model(raw_log, tmp_path):
    out = tmp_path / "sysid"
    # measurement parameters only: one simulation, the rest reuses it
    assert main(["--quiet", "sysid", str(raw_log), "--params", "offset,delay", "--max-sims",
                 "4", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["simulations"] == 1
    assert summary["parameters"]["offset"]["fitted"] == pytest.approx(0.5, abs=0.3)
    assert summary["rmse_after_N"] < summary["rmse_before_N"]
    assert load_structure(out / "fitted_structure.yaml").name == "tetraspine3"
    measured = json.loads((out / "measurement.json").read_text())
    assert measured["delay_s"] == pytest.approx(summary["parameters"]["delay"]["fitted"])


def test_malformed_log_exits_with_its_line(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,tension_N/inner_top_1\n0,20\n0.2,twenty\n")
    assert main(["--quiet", "compare", str(bad), "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "bad.csv: line 3, column 'tension_N/inner_top_1'" in err
