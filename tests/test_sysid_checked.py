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
    from tensim.hardware import load_log
    from tensim.hardware.sysid import SysidSettings, _windows

    sine = load_log("examples/hardware/sine_log.csv")  # a steady gait: the last quarter
    plain = _windows(SysidSettings(), [sine])
    assert plain.fit_window == (0.0, 8.0) and plain.validate_window == (6.0, 8.0)
    logs = [_Log(20.0), _Log(16.0)]
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


# -- a hold-out that can tell fits apart -----------------------------------------------------------


def test_the_default_hold_out_holds_the_push():
    """disturbance_log.csv pushes from 2.5 to 6 s of its 7 s. Its last quarter (5.25-7 s,
    the old default) is the still robot after the push: a twentieth of the log's mean
    excitation, where every model that holds the pretension scores alike. The default is
    now a quarter where the log moves, holding part of the push; the sine gait's stays the
    last quarter."""
    from tensim.hardware import load_log
    from tensim.hardware.holdout import MIN_EXCITATION, default_hold_out, hold_out_excitation

    log = load_log("examples/hardware/disturbance_log.csv")
    assert hold_out_excitation([log], (5.25, 7.0)) < 0.5 * MIN_EXCITATION
    window = default_hold_out([log], 0.0, 7.0)
    assert window[1] - window[0] == 1.75 and window[0] < 5.0  # a second or more of the push
    assert hold_out_excitation([log], window) > 3 * MIN_EXCITATION
    sine = load_log("examples/hardware/sine_log.csv")
    assert default_hold_out([sine], 0.0, 8.0) == (6.0, 8.0)


def test_a_poor_fit_is_refused_on_the_default_hold_out(tmp_path, capsys):
    """A fit from a bad start with too small a budget (friction 0.26 against the log's 0.1):
    on the old default hold-out (5.25-7 s, after the push) it scored 0.570 N against the
    nominal model's 0.571 N and was recommended ('use it'); on the push it is worse than the
    nominal model and refused."""
    import json

    from tensim.cli import main

    out = tmp_path / "bad"
    assert main(["--quiet", "sysid", "examples/hardware/disturbance_log.csv", "--params",
                 "friction,stiffness", "--start", "friction=0.3,stiffness=450", "--max-sims",
                 "3", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "WORSE than the nominal model" in printed and "use it" not in printed
    summary = json.loads((out / "summary.json").read_text())
    assert summary["kept_nominal"] and summary["validation"]["excited"]


def test_a_fit_judged_on_a_still_hold_out_is_not_recommended(tmp_path, capsys):
    """Asked to judge on 5.25-7 s (the robot still after the push), sysid writes the fit but
    does not recommend it, and the summary says why."""
    import json

    from tensim.cli import main

    out = tmp_path / "still"
    assert main(["--quiet", "sysid", "examples/hardware/disturbance_log.csv", "--params",
                 "offset", "--max-sims", "4", "--validate-window", "5.25:7",
                 "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "not recommended: the validation samples 5.25:7 s barely move" in printed
    assert "use it" not in printed
    validation = json.loads((out / "summary.json").read_text())["validation"]
    assert not validation["excited"] and validation["excitation"] < 0.05
