"""System identification that says what it checked: a fit is judged on held-out samples by
default, an open window is clipped to the logs (no Infinity in summary.json), and check-log
decides what a log whose push was removed is (not valid), and what a noisy log that records
its push is (valid, and not told it lacks one)."""

from __future__ import annotations

import numpy as np

# -- held-out data by default, open windows clipped, check-log's decisions ------------------


class _Log:
    def __init__(self, duration):
        self.duration = duration


def test_a_fit_is_judged_on_held_out_samples_by_default():
    from tensim.hardware.sysid import SysidSettings, _windows

    logs = [_Log(20.0), _Log(16.0)]
    plain = _windows(SysidSettings(), logs)  # the last quarter of the longest log held out
    assert plain.fit_window == (0.0, 15.0) and plain.validate_window == (15.0, 20.0)
    after = _windows(SysidSettings(fit_window=(2.0, 8.0)), logs)
    assert after.validate_window == (8.0, 20.0)
    before = _windows(SysidSettings(fit_window=(5.0, 20.0)), logs)
    assert before.validate_window == (0.0, 5.0)
    whole = _windows(SysidSettings(fit_window=(0.0, 20.0)), logs)
    assert whole.validate_window is None  # nothing left out: the verdict is on fitted data


def test_an_open_window_is_clipped_to_the_logs_and_never_written_as_infinity():
    import json
    import math

    from tensim.hardware.sysid import SysidSettings, _windows

    clipped = _windows(SysidSettings(fit_window=(0.0, math.inf)), [_Log(12.0)])
    assert clipped.fit_window == (0.0, 12.0)
    json.dumps(dataclasses_asdict(clipped), allow_nan=False)  # JSON, not Infinity


def dataclasses_asdict(settings):
    import dataclasses

    return dataclasses.asdict(settings)


def test_check_log_refuses_a_log_whose_push_was_removed(capsys):
    from tensim.cli import main

    assert main(["check-log", "examples/hardware/disturbance_log_no_loads.csv"]) == 1
    out = capsys.readouterr().out
    assert "NOT valid: a push the log does not record?" in out and "\n  valid" not in out
    assert main(["check-log", "examples/hardware/disturbance_log.csv"]) == 0
    assert capsys.readouterr().out.rstrip().endswith("valid")


def test_a_noisy_log_that_records_its_push_is_valid_and_not_told_it_lacks_one(tmp_path,
                                                                             capsys):
    from tensim.cli import main
    from tensim.hardware import load_log
    from tensim.hardware.checklog import summarize_log
    from tensim.hardware.logs import write_log
    from tensim.sim import TimeSeries

    log = load_log("examples/hardware/disturbance_log.csv")
    rng = np.random.default_rng(0)
    channels = {k: (v + 3.0 * rng.standard_normal(v.size) * (rng.random(v.size) < 0.05)
                    if k.startswith("tension/") else v) for k, v in log.series.channels.items()}
    noisy = type(log)(**{**log.__dict__, "series": TimeSeries(log.series.time, channels)})
    summary = summarize_log(noisy)
    assert summary["records_loads"] and summary["valid"]
    path = write_log(noisy, tmp_path / "noisy.csv")
    assert main(["check-log", str(path)]) == 0
    out = capsys.readouterr().out
    assert "warning: tensions jump" in out and "does not record" not in out
