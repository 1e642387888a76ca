"""The gait experiments (sine, cpg) and the drag test, against independent expectations."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tensim.cli import main
from tensim.experiments.drag import DragSettings, run_drag
from tensim.experiments.gait import locomotion
from tensim.sim import TimeSeries


def _moving(dx: float, dy: float) -> TimeSeries:
    t = np.linspace(0.0, 5.0, 51)
    share = np.clip((t - 1.0) / 4.0, 0.0, 1.0)
    # a jump before the settling time must not count
    jump = np.where(t < 1.0, 0.3, 0.0)
    return TimeSeries(t, {"pos_x/com": jump + dx * share, "pos_y/com": dy * share,
                          "pos_z/com": np.full_like(t, 0.1)})


@pytest.mark.parametrize(("dx", "dy", "label", "angle"), [
    (0.0, 0.2, "left (+y)", 90.0), (0.01, -0.2, "right (-y)", -87.14),
    (0.3, 0.05, "forward (+x)", 9.46), (-0.3, 0.0, "backward (-x)", 180.0),
])
def test_locomotion_reports_distance_and_direction(dx, dy, label, angle) -> None:
    report = locomotion(_moving(dx, dy))
    assert report["direction"] == label
    assert report["direction_deg"] == pytest.approx(angle, abs=0.01)
    assert report["planar_displacement_m"] == pytest.approx(np.hypot(dx, dy), abs=1e-6)
    assert report["world_dy_m"] == pytest.approx(dy, abs=1e-6)
    assert report["average_speed_m_per_s"] == pytest.approx(np.hypot(dx, dy) / 4.0, abs=1e-6)


@pytest.mark.parametrize("name", ["sine", "cpg"])
def test_gait_experiment_writes_summary_and_figures(name, tmp_path, capsys) -> None:
    out = tmp_path / name
    assert main(["--quiet", "experiment", name, "--duration", "3", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    for key in ("max_tension_N", "max_system_tension_N", "com_displacement_m",
                "real_time_factor", "planar_displacement_m", "direction", "direction_deg"):
        assert key in summary, key
    assert len(summary["max_tension_N"]) == 12
    assert summary["max_system_tension_N"] == max(summary["max_tension_N"].values())
    assert summary["duration_s"] == 3.0
    for figure in summary["figures"]:
        assert (out / figure).read_bytes()[:4] == b"\x89PNG"
    assert "moved" in capsys.readouterr().out


def test_drag_force_is_coulomb_friction_of_the_whole_weight() -> None:
    """Dragged steadily by a horizontal line, the robot's ground friction is μ m g.

    Closed form: with the pull horizontal the normal forces sum to m g, so sliding Coulomb
    friction gives F = μ m g = 0.075 x 2.349 kg x 9.81 m/s² = 1.728 N whatever the pose.
    MuJoCo's soft contacts slide a little below the Coulomb limit; 3 % is the tolerance.
    """
    result, summary = run_drag(settings=DragSettings(duration=8.0, steady_from=3.0))
    assert summary["coulomb_force_N"] == pytest.approx(0.075 * 2.349 * 9.81, rel=1e-3)
    assert summary["drag_force_N"] == pytest.approx(summary["coulomb_force_N"], rel=0.03)
    assert summary["effective_friction"] == pytest.approx(0.075, rel=0.03)
    assert summary["valid"] and summary["stance_problems"] == []  # a steady slide
    # the robot follows the tow point at its speed
    assert summary["com_speed_m_per_s"] == pytest.approx(0.05, rel=0.05)
    assert result.trajectory["pos_x/com"][-1] - result.trajectory["pos_x/com"][0] > 0.2


def test_drag_rejects_a_window_past_the_end() -> None:
    # the message says which durations work: more than settle + steady_from
    with pytest.raises(ValueError, match="must be more than 4 s"):
        DragSettings(duration=3.0, settle=2.0, steady_from=2.0)


def test_cpg_run_barely_depends_on_the_command_period() -> None:
    """The CPG's V* sampled every 1, 2, 5 or 10 ms drives nearly the same run.

    The oscillator output is smooth at the gait's frequency (about 0.3 Hz), so holding it for
    10 ms changes it by well under 1 %; every cable's peak tension stays within 1.5 % and the
    centre of mass ends within 2 mm.
    """
    import dataclasses

    from tensim.control import load_controller
    from tensim.model import compile_structure
    from tensim.models import tetraspine3
    from tensim.sim import simulate

    robot = tetraspine3()
    config = load_controller("tetraspine3_cpg", robot).with_duration(4.0)
    compiled = compile_structure(robot)
    runs = {p: simulate(compiled, 4.0, controller=dataclasses.replace(
        config, command_period=p).build(1e-3)) for p in (None, 0.002, 0.005, 0.01)}
    reference = runs[None]
    for period, run in runs.items():
        change = np.abs(run.peak_tension / reference.peak_tension - 1.0)
        assert change.max() < 0.015, period
        end = np.array(run.summary()["com_displacement_m"])
        assert np.abs(end - reference.summary()["com_displacement_m"]).max() < 2e-3, period


def test_experiments_take_a_fitted_robot_file(tmp_path) -> None:
    """--robot swaps in a Tetraspine3 variant: doubled friction doubles the drag (μ m g)."""
    import dataclasses

    from tensim import save_structure
    from tensim.models import tetraspine3

    robot = tetraspine3()
    rough = dataclasses.replace(robot, rods=tuple(dataclasses.replace(r, friction=0.15)
                                                  for r in robot.rods))
    save_structure(rough, tmp_path / "rough.yaml")
    out = tmp_path / "drag"
    assert main(["--quiet", "experiment", "drag", "--robot", str(tmp_path / "rough.yaml"),
                 "--duration", "8", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["coulomb_force_N"] == pytest.approx(0.15 * 2.349 * 9.81, rel=1e-3)
    assert summary["effective_friction"] == pytest.approx(0.15, rel=0.03)
