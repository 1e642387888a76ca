"""Motor sizing on a run recorded too coarsely for its gait: the simulation tracks each
cable's peak tension, line speed and power at every physics step, and sizing reads those; a
run folder without them (an older tensim's) whose samples miss the tracked peak tension by
more than 1 % is refused, as it misses the peaks a motor must meet (recorded every 0.25 s, a
motor passed with +3.1 % margin that fails by 12 % on the same gait)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tensim.cli import main
from tensim.design import DesignError
from tensim.design.motors import check_sampling
from tensim.sim import TimeSeries


def _gait(every: float) -> TimeSeries:
    t = np.arange(0.0, 2.0 + 1e-9, every)
    tension = 50.0 + 20.0 * np.sin(2 * np.pi * 1.3 * t) ** 8  # narrow peaks of 70 N
    return TimeSeries(t, {"tension/a": tension, "rest_length/a": 0.3 + 0.01 * np.sin(t)})


def test_a_coarse_recording_is_refused_with_its_figures():
    tracked = {"a": 70.0}
    check_sampling(_gait(0.001), tracked, "fine")  # within 1 % of the tracked peak
    with pytest.raises(DesignError, match=r"coarse: recorded every 0.25 s, too coarse for its "
                                          r"gait: cable 'a' peaked at 70 N between samples"):
        check_sampling(_gait(0.25), tracked, "coarse")
    check_sampling(_gait(0.25), {}, "no summary")  # nothing tracked: nothing to judge


def test_design_size_sizes_a_quarter_second_run_from_its_tracked_peaks(tmp_path, capsys):
    gait = ["--controller", "examples/design/hopper_roll.yaml", "--duration", "3",
            "--no-figures"]
    fine, coarse = tmp_path / "fine", tmp_path / "coarse"
    assert main(["--quiet", "simulate", "examples/design/hopper.yaml", *gait,
                 "--out", str(fine)]) == 0
    assert main(["--quiet", "simulate", "examples/design/hopper.yaml", *gait,
                 "--record-dt", "0.25", "--out", str(coarse)]) == 0
    size = ["design", "size", "--spool-radius", "0.008", "--gear", "30"]
    assert main([*size, str(fine), "--out", str(tmp_path / "s1")]) == 0
    capsys.readouterr()
    assert main([*size, str(coarse), "--out", str(tmp_path / "s2")]) == 0
    # it says that the figures from the samples (RMS, mean power, work) are rough
    assert "recorded every 0.25 s, too coarse for its gait" in capsys.readouterr().err
    rows = [json.loads((tmp_path / s / "summary.json").read_text())["cables"]
            for s in ("s1", "s2")]
    for a, b in zip(*rows, strict=True):  # the same peaks, and shaft torque and speed
        assert a["tau [N m]"] == pytest.approx(b["tau [N m]"], rel=1e-5)
        assert a["omega [rad/s]"] == pytest.approx(b["omega [rad/s]"], rel=1e-9)
    # the same folder as an older tensim wrote it, without the tracked speed and power:
    # sized from its samples, which miss the peaks, so it is refused
    summary = json.loads((coarse / "summary.json").read_text())
    del summary["max_line_speed_m_s"], summary["max_power_W"]
    (coarse / "summary.json").write_text(json.dumps(summary))
    capsys.readouterr()
    assert main([*size, str(coarse), "--out", str(tmp_path / "s3")]) == 2
    assert "recorded every 0.25 s, too coarse for its gait" in capsys.readouterr().err
    assert not (tmp_path / "s3").exists()
