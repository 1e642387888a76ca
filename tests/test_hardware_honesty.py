"""Honest reality-gap tools: a hold-out that is one, figures on the samples that were
simulated, logs that check-log calls valid only when compare and sysid accept them, and
intervals that cover the spread of fits on other windows."""

from __future__ import annotations

import pytest

from tensim.cli import main
from tensim.control import load_controller
from tensim.hardware import SysidSettings, identify, simulated_log, write_log
from tensim.hardware.loads import experiment_params
from tensim.hardware.sysid import SysidError
from tensim.models import tetraspine3

PUSH = "start=1.5,rise=0.5,hold=0.5,fall=0.5"  # a short disturbance: 1.5-3 s


@pytest.fixture(scope="module")
def robot():
    return tetraspine3()


@pytest.fixture(scope="module")
def impedance(robot):
    return load_controller("tetraspine3_impedance", robot)


@pytest.fixture(scope="module")
def push_log(robot, impedance):
    """An exact (noise-free) 3.5 s disturbance log of the nominal robot, 0.5 N offset."""
    from tensim.hardware import SensorModel

    params = experiment_params("disturbance", PUSH, "test")
    return simulated_log(robot, impedance, 3.5, experiment=("disturbance", params),
                         sensor=SensorModel(offset=0.5))


@pytest.mark.parametrize("fit, validate, shared", [
    ((0.0, 3.0), (0.0, 3.0), "0-3"),  # identical
    ((0.0, 3.5), (1.0, 2.0), "1-2"),  # validation inside the fit
    ((1.0, 2.0), (0.0, 3.5), "1-2"),  # fit inside the validation
    ((0.0, 2.0), (1.5, 3.5), "1.5-2"),  # overlapping
])
def test_overlapping_windows_are_no_hold_out(push_log, robot, impedance, fit, validate,
                                             shared):
    with pytest.raises(SysidError, match=rf"--fit-window {fit[0]:g}:{fit[1]:g} and "
                       rf"--validate-window {validate[0]:g}:{validate[1]:g} s overlap "
                       rf"\({shared} s\)"):
        identify([push_log], robot, impedance, ["offset"],
                 settings=SysidSettings(fit_window=fit, validate_window=validate))


def test_touching_windows_fit_no_validation_sample(push_log, robot, impedance):
    """Windows 0:2 and 2:3.5 share the sample at 2 s: it is validated, never fitted, and
    every figure is on the simulated samples (to 3.5 s here)."""
    settings = SysidSettings(fit_window=(0.0, 2.0), validate_window=(2.0, 3.5),
                             max_simulations=4)
    result = identify([push_log], robot, impedance, ["offset"], settings=settings)
    # the offset is fitted from the samples of 0-1.8 s (5 Hz feedback): 10 rows of 12 cables
    assert result.validation["window_s"] == [2.0, 3.5]
    assert result.optimizer.fun.size == 10 * 12
    assert result.fitted[0] == pytest.approx(0.5, abs=0.01)


def test_window_fit_compares_the_window_it_simulated(push_log, robot, impedance):
    """A fit on 0:2 s simulates to 2 s; its before/after figures and the nominal model's
    alignment use those samples, not the rest of the log (which the simulation never
    reached: a held last value would be scored there)."""
    result = identify([push_log], robot, impedance, ["offset"],
                      settings=SysidSettings(fit_window=(0.0, 2.0), max_simulations=4))
    for comparison in (*result.before, *result.after):
        assert comparison.time[-1] <= 2.0
    summary = result.summary()
    # no validation window: the verdict is on the fit samples, the same as the baseline's
    assert summary["rmse_before_N"] == pytest.approx(result.validation["nominal_rmse_N"],
                                                     abs=1e-6)
    assert summary["rmse_after_N"] == pytest.approx(result.validation["fitted_rmse_N"],
                                                    abs=1e-6)


def test_cli_names_overlapping_windows(push_log, tmp_path, capsys):
    log = write_log(push_log, tmp_path / "push.csv")
    assert main(["--quiet", "sysid", str(log), "--params", "offset", "--fit-window", "0:3",
                 "--validate-window", "2:3.5", "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err
    assert "--fit-window 0:3 and --validate-window 2:3.5 s overlap (2-3 s)" in err
    assert not (tmp_path / "s").exists()
