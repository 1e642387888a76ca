"""Motor sizing refuses a run recorded too coarsely for its gait: the simulation tracks each
cable's peak tension at every physics step, and a recording whose samples miss it by more
than 1 % misses the peaks a motor must meet (recorded every 0.25 s, a motor passed with
+3.1 % margin that fails by 12 % on the same gait)."""

from __future__ import annotations

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


def test_design_size_refuses_a_run_recorded_every_quarter_second(tmp_path, capsys):
    gait = ["--controller", "examples/design/hopper_roll.yaml", "--duration", "3",
            "--no-figures"]
    fine, coarse = tmp_path / "fine", tmp_path / "coarse"
    assert main(["--quiet", "simulate", "examples/design/hopper.yaml", *gait,
                 "--out", str(fine)]) == 0
    assert main(["--quiet", "simulate", "examples/design/hopper.yaml", *gait,
                 "--record-dt", "0.25", "--out", str(coarse)]) == 0
    size = ["design", "size", "--spool-radius", "0.008", "--gear", "30"]
    assert main([*size, str(fine), "--out", str(tmp_path / "s1")]) == 0
    assert main([*size, str(coarse), "--out", str(tmp_path / "s2")]) == 2
    assert "recorded every 0.25 s, too coarse for its gait" in capsys.readouterr().err
    assert not (tmp_path / "s2").exists()
