"""Controller files, V* tables and their export: round trips, resolution rules, clear errors,
and playback of an exported table reproducing the simulated run exactly."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
import yaml

from tensim.cli import main
from tensim.control import (
    ControllerConfig,
    ControllerFileError,
    ImpedanceGains,
    TableController,
    VelocityFileError,
    VelocityTable,
    load_controller,
    load_velocity_table,
    save_controller,
    save_velocity_table,
    shipped_controllers,
    spine_parameters,
)
from tensim.model import compile_structure
from tensim.models import tetraspine3
from tensim.sim import simulate


@pytest.fixture(scope="module")
def robot():
    return tetraspine3()


@pytest.mark.parametrize("name", ["tetraspine3_impedance", "tetraspine3_sine",
                                  "tetraspine3_cpg"])
@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_shipped_controllers_round_trip(name, suffix, robot, tmp_path) -> None:
    config = load_controller(name, robot)
    assert len(config.impedance.gains) == 12
    path = save_controller(config, tmp_path / f"copy{suffix}")
    assert load_controller(path, robot) == config
    assert not list(tmp_path.glob(".*.tmp"))


@pytest.mark.parametrize("name", ["tetraspine3_impedance", "tetraspine3_sine",
                                  "tetraspine3_cpg"])
def test_saved_text_is_pyyamls_safe_dump(name, robot, tmp_path) -> None:
    # the writer uses libyaml's emitter where it exists; the file must be the text the
    # pure-Python emitter writes, byte for byte (a learning run's files are fingerprinted)
    from tensim.control.files import _COMMENT, controller_to_dict

    config = load_controller(name, robot)
    path = save_controller(config, tmp_path / "copy.yaml")
    expected = yaml.safe_dump(controller_to_dict(config, path), sort_keys=False, width=100)
    assert path.read_text() == _COMMENT + expected


def test_shipped_cpg_has_the_116_parameter_layout(robot) -> None:
    config = load_controller("tetraspine3_cpg", robot)
    assert config.gait.layout.size == 116
    assert config.command_period == 0.01  # the robot's 10 ms command packets


def test_groups_then_cables_resolve_in_order(robot, tmp_path) -> None:
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump({
        "format": "tensim-controller", "model": "tetraspine3",
        "impedance": {
            "groups": [{"tag": "inner", "stiffness_gain": 100, "damping_gain": 50,
                        "offset_tension": 5, "target_length": 0.2},
                       {"tag": "inner_top", "stiffness_gain": 500}],
            "cables": {"inner_top_2": {"offset_tension": 9}},
            "passive": ["outer"]},
    }))
    gains = load_controller(path, robot).impedance.gains
    assert set(gains) == {c.name for c in robot.cables if "inner" in c.tags}
    assert gains["inner_left_1"] == ImpedanceGains(5.0, 100.0, 50.0, 0.2)
    assert gains["inner_top_1"] == ImpedanceGains(5.0, 500.0, 50.0, 0.2)  # later group wins
    assert gains["inner_top_2"] == ImpedanceGains(9.0, 500.0, 50.0, 0.2)  # cable wins


@pytest.mark.parametrize(("change", "field", "words"), [
    (lambda d: d["impedance"]["cables"]["inner_top_1"].update(stifness_gain=1),
     "impedance.cables.inner_top_1", "stifness_gain"),
    (lambda d: d["impedance"]["cables"]["inner_top_1"].update(damping_gain="high"),
     "impedance.cables.inner_top_1.damping_gain", "finite number"),
    (lambda d: d["impedance"]["cables"]["inner_top_1"].pop("target_length"),
     "impedance.cables.inner_top_1", "target_length"),
    (lambda d: d["impedance"]["cables"].update(middle_9={"offset_tension": 1}),
     "impedance.cables.middle_9", "no cable"),
    (lambda d: d["gait"].update(type="walk"), "gait.type", "cpg"),
    (lambda d: d["gait"]["parameters"].pop("amplitude"), "gait.parameters", "amplitude"),
    (lambda d: d["gait"]["parameters"].update(frequency=50.0), "gait.parameters", "bounds"),
    (lambda d: d.update(format="something"), "format", "tensim-controller"),
])
def test_bad_controller_files_name_file_and_field(change, field, words, robot, tmp_path):
    data = yaml.safe_load((shipped_controllers()["tetraspine3_cpg"]).read_text())
    change(data)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ControllerFileError) as err:
        load_controller(path, robot)
    message = str(err.value)
    assert str(path) in message and field in message and words in message


def test_velocity_table_text_round_trip_is_exact(tmp_path) -> None:
    rng = np.random.default_rng(3)
    table = VelocityTable(("a", "b", "c"), 0.01, rng.normal(0, 0.02, (50, 3)))
    save_velocity_table(table, tmp_path / "v.txt", hardware_scale=10.0)
    written = np.loadtxt(tmp_path / "v.txt", skiprows=5)
    np.testing.assert_array_equal(written[:, 1:], table.values * 10.0)
    np.testing.assert_allclose(written[:, 0], np.arange(50) * 0.01, rtol=0, atol=1e-15)
    back = load_velocity_table(tmp_path / "v.txt")
    assert back.cables == table.cables and back.period == table.period
    np.testing.assert_allclose(back.values, table.values, rtol=1e-15, atol=0)


@pytest.mark.parametrize(("body", "words"), [
    ("time a b\n0 1 2\n", "header"),
    ("time_s a b\n0 1 2\n0.01 1 x\n", "line 3, column 'b'"),
    ("time_s a b\n0 1 2\n0.01 1\n", "line 3"),
    ("time_s a b\n0 1 2\n0.01 1 2\n0.05 1 2\n", "uniform period"),
])
def test_bad_velocity_files_name_line_and_column(body, words, tmp_path) -> None:
    path = tmp_path / "v.txt"
    path.write_text(body)
    with pytest.raises(VelocityFileError, match=words) as err:
        load_velocity_table(path)
    assert str(path) in str(err.value)


def test_exported_table_plays_back_the_simulated_run_exactly(robot, tmp_path) -> None:
    """What was exported is what was simulated: same V* rows, bitwise-equal trajectories."""
    layout = spine_parameters(robot)
    rng = np.random.default_rng(7)
    values = layout.from_unit(rng.uniform(0.2, 0.8, layout.size))
    base = load_controller("tetraspine3_cpg", robot)
    config = dataclasses.replace(base.with_gait(layout.gait(values)), duration=2.0)
    out = tmp_path / "trajectory.txt"
    assert main(["export-trajectory", str(save_controller(config, tmp_path / "c.yaml")),
                 "--model", "tetraspine3", "--out", str(out)]) == 0
    table = load_velocity_table(out)
    assert table.values.shape == (201, 12) and table.period == 0.01
    assert np.abs(table.values).max() > 1e-4  # the gait does command something

    compiled = compile_structure(robot)
    direct = simulate(compiled, 2.0, controller=config.build(compiled.model.opt.timestep))
    played = simulate(compiled, 2.0, controller=TableController(table, config.impedance))
    # the text holds V* at full precision, so the run is the same to the last bit (contact
    # makes the dynamics chaotic: a one-ulp change in V* grows to 1e-3 N within a second)
    for channel in ("tension/inner_top_1", "pos_y/com", "rest_length/outer_left_2"):
        np.testing.assert_array_equal(played.trajectory[channel], direct.trajectory[channel])


def test_unscaled_table_file_is_bitwise(robot, tmp_path) -> None:
    config = load_controller("tetraspine3_sine", robot).with_duration(1.0)
    table = config.velocity_table(1e-3)
    save_velocity_table(table, tmp_path / "v.txt")
    assert load_velocity_table(tmp_path / "v.txt") == table


def test_config_rejects_gait_cables_without_gains(robot) -> None:
    base = load_controller("tetraspine3_sine", robot)
    fewer = {k: v for k, v in base.impedance.gains.items() if k != "inner_top_1"}
    with pytest.raises(ValueError, match="inner_top_1"):
        ControllerConfig(dataclasses.replace(base.impedance, gains=fewer), base.gait)


def test_cli_simulate_plays_an_exported_file(tmp_path, capsys) -> None:
    table = tmp_path / "v.txt"
    assert main(["export-trajectory", "tetraspine3_sine", "--out", str(table),
                 "--duration", "1"]) == 0
    out = tmp_path / "run"
    assert main(["--quiet", "simulate", "tetraspine3", "--controller", "tetraspine3_impedance",
                 "--velocity-input", str(table), "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert math.isclose(summary["duration_s"], 1.0)  # the table's length
