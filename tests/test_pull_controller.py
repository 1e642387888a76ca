"""Commanded rest lengths in controller files: what `tensim design pull` writes, simulated with
`tensim simulate --controller`, settles the robot at the inverse statics' answer; the section
round-trips and bad input names the file and the field."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

import tensim
from tensim.cli import main
from tensim.control import (
    ControllerConfig,
    ControllerFileError,
    ImpedanceController,
    RestCommand,
    load_controller,
    save_controller,
)
from tensim.design.inverse import inverse_statics
from tensim.design.verify import WIND_SPEED, settle_errors, settle_time
from tensim.hardware import node_positions
from tensim.models import tetraspine3
from tensim.models.prisms import prism
from tensim.sim import TimeSeries

HOPPER = Path(__file__).parents[1] / "examples" / "design" / "hopper.yaml"
MOVE = (0.009, 0.0337, -0.0015)  # docs/design.md: rod 0 tipped 5 degrees sideways [m]


def _positions(structure: tensim.Structure, series: TimeSeries) -> dict[str, np.ndarray]:
    """Node name -> (samples, 3) positions [m]."""
    compiled = tensim.compile_structure(structure)
    return node_positions(series, compiled, [n.name for n in structure.nodes])


def test_pull_controller_file_settles_the_hopper_where_verify_does(tmp_path, capsys) -> None:
    pull = tmp_path / "pull"
    assert main(["design", "pull", str(HOPPER), "--move", "t0=" + ",".join(map(str, MOVE)),
                 "--out", str(pull)]) == 0
    assert "controller.yaml" in capsys.readouterr().out
    assert not (pull / "rest_lengths.yaml").exists()
    hopper = tensim.load_structure(HOPPER)
    config = load_controller(pull / "controller.yaml", hopper)
    result = inverse_statics(hopper, {"t0": MOVE})
    assert config.rest == result.command(WIND_SPEED)  # every cable, exactly the answer
    assert not config.impedance.gains and config.gait is None
    duration = settle_time(result)  # 4.4 s: the longest wind at 0.01 m/s, then 2 s of rest
    run = tmp_path / "run"
    assert main(["--quiet", "simulate", str(HOPPER), "--controller", str(pull / "controller.yaml"),
                 "--duration", str(duration), "--no-figures", "--out", str(run)]) == 0
    positions = _positions(hopper, TimeSeries.from_parquet(run / "trajectory.parquet"))
    end = {n: p[-1] for n, p in positions.items()}
    target = tensim.load_structure(pull / "target.yaml")
    distance = {n: float(np.linalg.norm(p - target.position(n))) for n, p in end.items()}
    # the same law as `design pull --verify` (RestCommand in the drive's rest mode): the same
    # distances, which docs/design.md prints (t0 2.62 mm)
    verified, verify_time = settle_errors(hopper, result)
    assert verify_time == duration
    for node, value in verified.items():
        assert distance[node] == pytest.approx(value, abs=1e-9), node
    # the targeted node came to rest within 3 mm of the static answer after moving ~35 mm:
    # the feet slip ~2 mm on MuJoCo's soft contacts while the statics holds them
    assert max(distance.values()) < 3e-3
    assert np.linalg.norm(end["t0"] - positions["t0"][0]) > 0.03
    assert all(np.linalg.norm(p[-1] - p[-100]) < 1e-4 for p in positions.values())  # at rest


def test_pull_controller_on_the_prism_settles_within_the_verify_tolerance(tmp_path) -> None:
    robot = prism(3, elevation=0.015)  # as tests/test_design_inverse.py, tipped 4 degrees
    b0, t0 = robot.position("b0"), robot.position("t0")
    axis = np.cross([0.0, 0.0, 1.0], np.cross(t0 - b0, [0.0, 0.0, 1.0]))
    from scipy.spatial.transform import Rotation

    turn = Rotation.from_rotvec(np.radians(4.0) * axis / np.linalg.norm(axis))
    move = b0 + turn.apply(t0 - b0) - t0
    pull = tmp_path / "pull"
    text = ",".join(repr(float(v)) for v in move)
    assert main(["design", "pull", "prism3", "--move", f"t0={text}", "--out", str(pull)]) == 0
    config = load_controller(pull / "controller.yaml", robot)
    assert config.model == "prism3"
    compiled = tensim.compile_structure(robot)
    result = inverse_statics(robot, {"t0": tuple(move)})
    series = tensim.simulate(compiled, settle_time(result),
                             controller=config.build(compiled.model.opt.timestep)).trajectory
    end = {n: p[-1] for n, p in _positions(robot, series).items()}
    target = tensim.load_structure(pull / "target.yaml")
    for node, p in end.items():
        assert np.linalg.norm(p - target.position(node)) < 2.5e-3, node  # the verify test's
    # and t0 went where it was asked, from its build pose (as tests/test_design_inverse.py)
    assert np.linalg.norm(end["t0"] - t0 - move) < 5e-3


@pytest.fixture(scope="module")
def spine():
    return tetraspine3()


def _mixed(robot: tensim.Structure) -> ControllerConfig:
    """Impedance laws on the outer cables, commanded rest lengths on the inner ones."""
    base = load_controller("tetraspine3_impedance", robot)
    inner = [c.name for c in robot.cables if "inner" in c.tags]
    gains = {n: g for n, g in base.impedance.gains.items() if n not in inner}
    return ControllerConfig(ImpedanceController(gains), model="tetraspine3",
                            rest=RestCommand(tuple(inner), tuple(0.1 + 0.01 * i
                                                                 for i in range(len(inner))),
                                             0.02))


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_rest_lengths_round_trip(suffix, spine, tmp_path) -> None:
    mixed = _mixed(spine)
    only = ControllerConfig(ImpedanceController({}), rest=RestCommand(
        tuple(c.name for c in spine.cables), tuple(0.2 for _ in spine.cables)))
    for k, config in enumerate((mixed, only)):
        path = save_controller(config, tmp_path / f"c{k}{suffix}")
        loaded = load_controller(path, spine)
        assert loaded == config
        assert save_controller(loaded, tmp_path / f"again{k}{suffix}").read_text() \
            == path.read_text()
    assert "impedance" not in yaml.safe_load((tmp_path / f"c1{suffix}").read_text())


def test_rest_command_drives_the_named_cables_only(spine) -> None:
    config = _mixed(spine)
    compiled = tensim.compile_structure(spine)
    sim = tensim.Simulation(compiled, controller=config.build(compiled.model.opt.timestep))
    drive = sim.drive
    for name, rest in config.rest.as_dict().items():
        i = sim.index.cable_id(name)
        assert drive.mode[i] == tensim.sim.MODE_REST and drive.rest_command[i] == rest
        assert drive.max_speed[i] == min(spine.cable(name).motor.max_speed, 0.02)
    for name in config.impedance.gains:
        assert drive.mode[sim.index.cable_id(name)] == tensim.sim.MODE_IMPEDANCE


def _without_motor(robot: tensim.Structure, name: str) -> tensim.Structure:
    return dataclasses.replace(robot, cables=tuple(
        dataclasses.replace(c, motor=dataclasses.replace(c.motor, passive=True))
        if c.name == name else c for c in robot.cables))


@pytest.mark.parametrize(("change", "field", "words"), [
    (lambda d: d["rest_lengths"].update(inner_top_9=0.1), "rest_lengths.inner_top_9",
     "no cable"),
    (lambda d: d["rest_lengths"].update(inner_top_1=math.nan), "rest_lengths.inner_top_1",
     "finite number"),
    (lambda d: d["rest_lengths"].update(inner_top_1=0.0), "rest_lengths.inner_top_1", "> 0"),
    (lambda d: d["rest_lengths"].update(inner_top_1=-0.1), "rest_lengths.inner_top_1", "> 0"),
    (lambda d: d["rest_lengths"].update(inner_top_1="short"), "rest_lengths.inner_top_1",
     "finite number"),
    (lambda d: d["rest_lengths"].update(outer_top_1=0.1), "rest_lengths.outer_top_1",
     "also has impedance gains"),
    (lambda d: d["rest_lengths"].update(outer_top_1=0.1), "rest_lengths.outer_top_1",
     "not both"),
    (lambda d: d.update(rest_lengths=[0.1]), "rest_lengths", "expected a mapping"),
    (lambda d: d.update(rest_lengths={}), "rest_lengths", "at least one cable"),
    (lambda d: d.update(rest_speed=0), "rest_speed", "> 0"),
    (lambda d: d.pop("rest_lengths"), "rest_speed", "needs 'rest_lengths'"),
    (lambda d: d.pop("impedance"), "rest_lengths", "get no rest length"),
    (lambda d: d.update(rest_lenghts={}), "", "rest_lenghts"),
])
def test_bad_rest_lengths_name_file_and_field(change, field, words, spine, tmp_path) -> None:
    path = save_controller(_mixed(spine), tmp_path / "good.yaml")
    data = yaml.safe_load(path.read_text())
    change(data)
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(data))
    with pytest.raises(ControllerFileError) as err:
        load_controller(bad, spine)
    message = str(err.value)
    assert str(bad) in message and f"{field}:" in message and words in message, message


def test_a_cable_without_a_motor_cannot_get_a_rest_length(spine, tmp_path) -> None:
    robot = _without_motor(spine, "inner_top_1")
    path = save_controller(_mixed(spine), tmp_path / "c.yaml")
    with pytest.raises(ControllerFileError, match=r"c\.yaml: rest_lengths\.inner_top_1: .*no "
                       "motor"):
        load_controller(path, robot)



def test_export_refuses_a_file_with_rest_lengths(spine, tmp_path, capsys) -> None:
    path = save_controller(_mixed(spine), tmp_path / "c.yaml")
    out = tmp_path / "v.txt"
    assert main(["export-trajectory", str(path), "--out", str(out)]) == 2
    assert "c.yaml: rest_lengths: a V* table carries no commanded rest lengths" \
        in capsys.readouterr().err
    assert not out.exists()
