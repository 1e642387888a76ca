"""Motor sizing against figures recomputed by hand from a recorded trajectory."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from tensim.cli import main
from tensim.sim import TimeSeries


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory: pytest.TempPathFactory):
    """One second of the Tetraspine3 preset under its impedance controller."""
    out = tmp_path_factory.mktemp("runs") / "gait"
    assert main(["--quiet", "simulate", "tetraspine3", "--duration", "1", "--out",
                 str(out)]) == 0
    return out


def _by_hand(series: TimeSeries, cable: str) -> dict[str, float]:
    """Peak and RMS tension, peak speed, peak power through the spool and positive work of the
    samples, with plain loops."""
    t = list(series.time)
    tension = list(series[f"tension/{cable}"])
    rest = list(series[f"rest_length/{cable}"])
    n = len(t)
    speed = []
    for i in range(n):  # central differences, one-sided at the ends
        lo, hi = max(i - 1, 0), min(i + 1, n - 1)
        speed.append((rest[hi] - rest[lo]) / (t[hi] - t[lo]))
    power = [-a * b for a, b in zip(tension, speed, strict=True)]
    work = sum(0.5 * (max(power[i], 0) + max(power[i + 1], 0)) * (t[i + 1] - t[i])
               for i in range(n - 1))
    return {"peak T [N]": max(tension), "rms T [N]": math.sqrt(sum(x * x for x in tension) / n),
            "peak u [m/s]": max(abs(v) for v in speed), "peak P [W]": max(map(abs, power)),
            "W [J]": work}


def test_sizing_matches_hand_figures(run_folder, tmp_path, capsys) -> None:
    catalogue = tmp_path / "motors.yaml"
    catalogue.write_text("motors:\n  - {name: m1, stall_torque: 0.2, no_load_speed: 800.0}\n")
    out = tmp_path / "size"
    assert main(["design", "size", str(run_folder), "--spool-radius", "0.01", "--gear", "20",
                 "--motors", str(catalogue), "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert (out / "operating_points.png").exists()
    series = TimeSeries.from_parquet(run_folder / "trajectory.parquet")
    run = json.loads((run_folder / "summary.json").read_text())
    assert summary["peaks_tracked"] is True
    tracked = {c: (run["max_tension_N"][c], run["max_line_speed_m_s"][c], run["max_power_W"][c])
               for c in series.items("tension")}
    for row in summary["cables"]:
        hand = _by_hand(series, row["cable"])
        # the peaks: the simulation's over every step (a sample may top them by round-off)
        for key, peak in zip(("peak T [N]", "peak u [m/s]", "peak P [W]"),
                             tracked[row["cable"]], strict=True):
            hand[key] = max(hand[key], peak)
        for key, value in hand.items():
            assert row[key] == pytest.approx(value, rel=1e-9, abs=1e-12), (row["cable"], key)
        # shaft: tau = 1.15 T R / N, omega = 1.15 u N / R
        assert row["tau [N m]"] == pytest.approx(1.15 * hand["peak T [N]"] * 0.01 / 20)
        assert row["omega [rad/s]"] == pytest.approx(1.15 * hand["peak u [m/s]"] * 20 / 0.01)
    # the margin by hand: 1 - max over samples of tau/tau_s + omega/omega_0, and over the
    # corners (T*, min(u*, P*/T*)) and (min(T*, P*/u*), u*) of the peaks' region, worst cable
    a, b = 1.15 * 0.01 / 20 / 0.2, 1.15 * 20 / 0.01 / 800.0  # per N, per m/s
    worst = 1.0
    rows = {row["cable"]: row for row in summary["cables"]}
    for cable in series.items("tension"):
        tension = series[f"tension/{cable}"]
        t, rest = series.time, series[f"rest_length/{cable}"]
        for i in range(len(t)):
            lo, hi = max(i - 1, 0), min(i + 1, len(t) - 1)
            u = abs((rest[hi] - rest[lo]) / (t[hi] - t[lo]))
            worst = min(worst, 1.0 - (a * max(tension[i], 0) + b * u))
        peak_t, peak_u, peak_p = (rows[cable][k] for k in ("peak T [N]", "peak u [m/s]",
                                                          "peak P [W]"))
        for corner_t, corner_u in ((peak_t, min(peak_u, peak_p / peak_t)),
                                   (min(peak_t, peak_p / peak_u), peak_u)):
            worst = min(worst, 1.0 - (a * corner_t + b * corner_u))
    assert summary["motor_margins"]["m1"] == pytest.approx(worst, rel=1e-9)
    assert "motor m1: pass" in capsys.readouterr().out


def test_too_weak_motor_and_bad_catalogue(run_folder, tmp_path, capsys) -> None:
    weak = tmp_path / "weak.yaml"
    weak.write_text("motors:\n  - {name: tiny, stall_torque: 0.001, no_load_speed: 50.0}\n")
    out = tmp_path / "size"
    assert main(["design", "size", str(run_folder), "--spool-radius", "0.01", "--motors",
                 str(weak), "--out", str(out)]) == 1
    text = capsys.readouterr().out
    assert "motor tiny: FAIL" in text and "no motor in" in text and "strong enough" in text
    bad = tmp_path / "bad.yaml"
    bad.write_text("motors:\n  - {name: x, stall_torque: -1, no_load_speed: 50.0}\n")
    other = tmp_path / "other"
    assert main(["design", "size", str(run_folder), "--spool-radius", "0.01", "--motors",
                 str(bad), "--out", str(other)]) == 2
    assert "stall_torque must be a number > 0" in capsys.readouterr().err
    assert not other.exists()  # nothing written


def test_batch_of_unscaled_robots_equals_a_single_run() -> None:
    # fast path against the reference: one robot with every factor 1 through the batch engine
    # gives the same duty as tensim.simulate (the CPU batch is bit-identical to single runs)
    import tensim
    from tensim.control import load_controller
    from tensim.design.motors import cable_duty, tracked_peaks
    from tensim.design.robots import gait_duties, random_scales
    from tensim.structure import load_structure

    examples = Path(__file__).resolve().parent.parent / "examples" / "design"
    structure = load_structure(examples / "hopper.yaml")
    config = load_controller(examples / "hopper_roll.yaml", structure)
    compiled = tensim.compile_structure(structure)
    run = tensim.simulate(compiled, 1.0, controller=config.build(1e-3))
    single = cable_duty(run.trajectory, tracked=tracked_peaks(run))
    batch, done = gait_duties(compiled, lambda: config.build(1e-3), 1.0, random_scales(1, 0.0, 0))
    assert done == 1
    for a, b in zip(single, batch, strict=True):
        assert (a.cable, a.peak_tension, a.peak_speed, a.peak_power, a.work, a.tracked) == \
            (b.cable, b.peak_tension, b.peak_speed, b.peak_power, b.work, b.tracked)
    scales = random_scales(3, 0.2, seed=7)
    assert scales == random_scales(3, 0.2, seed=7)  # seeded
    assert all(0.8 <= s.stiffness <= 1.2 and 0.8 <= s.mass <= 1.2 for s in scales)


def test_the_command_sizes_a_gait_on_randomised_robots(tmp_path) -> None:
    # `design size --model ... --robots 1 --spread 0` is one unscaled robot: its peak tensions
    # are a plain simulation's, and the shaft torque is safety x peak T x spool radius / gear
    import tensim
    from tensim.control import load_controller
    from tensim.design.motors import cable_duty, tracked_peaks
    from tensim.structure import load_structure

    examples = Path(__file__).resolve().parent.parent / "examples" / "design"
    structure = load_structure(examples / "hopper.yaml")
    config = load_controller(examples / "hopper_roll.yaml", structure)
    compiled = tensim.compile_structure(structure)
    run = tensim.simulate(compiled, 0.5, controller=config.build(1e-3))
    single = cable_duty(run.trajectory, tracked=tracked_peaks(run))
    out = tmp_path / "size"
    assert main(["--quiet", "design", "size", "--model", str(examples / "hopper.yaml"),
                 "--controller", str(examples / "hopper_roll.yaml"), "--robots", "1",
                 "--spread", "0", "--duration", "0.5", "--spool-radius", "0.01", "--gear", "2",
                 "--out", str(out)]) == 0
    rows = json.loads((out / "summary.json").read_text())["cables"]
    assert [r["cable"] for r in rows] == [d.cable for d in single]
    for row, duty in zip(rows, single, strict=True):
        assert row["peak T [N]"] == pytest.approx(duty.peak_tension, rel=1e-12)
        assert row["tau [N m]"] == pytest.approx(1.15 * duty.peak_tension * 0.01 / 2, rel=1e-12)
