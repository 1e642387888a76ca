"""The model check: its time-step bound against simulation, and its other findings."""

from __future__ import annotations

import dataclasses

import numpy as np
import yaml

import tensim
from tensim.cli import main
from tensim.design.check import check_structure
from tensim.design.stiffness import stable_timestep, stiffness
from tensim.models.prisms import prism
from tensim.structure import Motor, load_structure, save_structure


def _peak_tension_change(structure: tensim.Structure, dt: float) -> float:
    """Largest change of any cable's tension over 1.5 s of the free, weightless structure."""
    world = tensim.WorldOptions(timestep=dt, gravity=(0.0, 0.0, 0.0), ground=False)
    try:
        result = tensim.simulate(tensim.compile_structure(structure, world), 1.5, record_dt=dt)
    except tensim.SimulationError:
        return np.inf
    tension = result.trajectory.matrix("tension")
    return float(np.nanmax(np.abs(tension - tension[0]))) if np.isfinite(tension).all() \
        else np.inf


def test_timestep_bound_brackets_the_simulated_blow_up() -> None:
    # the self-stressed prism at rest: round-off grows only where the explicit step is
    # unstable; 10 % either side of the predicted bound separates the two
    structure = prism(3)
    limit, _, _ = stable_timestep(stiffness(structure))
    assert _peak_tension_change(structure, 0.9 * limit) < 1e-6  # N: round-off stays small
    assert _peak_tension_change(structure, 1.1 * limit) > 1.0  # N: grown from round-off
    found = check_structure(structure, 1.1 * limit)
    assert [f.severity for f in found if f.item == "timestep"] == ["error"]
    assert check_structure(structure, 0.4 * limit) == []


def test_findings_name_what_to_change(tmp_path) -> None:
    base = prism(3)
    cables = list(base.cables)
    cables[0] = dataclasses.replace(cables[0], pretension=0.0)
    cables[2] = dataclasses.replace(cables[2], pretension=30.0,
                                    motor=Motor(max_speed=0.1, max_tension=20.0))
    nodes = tuple(dataclasses.replace(n, position=tuple(100 * np.array(n.position)))
                  for n in base.nodes)
    found = check_structure(dataclasses.replace(base, cables=tuple(cables)))
    text = "\n".join(map(str, found))
    assert "cable 'bottom_0': slack at the build pose" in text
    assert "exceeds its motor's max_tension 20 N" in text
    assert "far from equilibrium" in text
    scaled = check_structure(dataclasses.replace(base, nodes=nodes))
    assert any("centimetres" in str(f) for f in scaled)
    # a bare 0.5 m rod of 1 mm radius: axial / transverse inertia = 6 r^2 / L^2 = 2.4e-5
    bare = dataclasses.replace(base, rods=tuple(dataclasses.replace(r, radius=0.001)
                                                for r in base.rods), point_masses=())
    thin = [f for f in check_structure(bare) if f.item.startswith("rod")]
    assert len(thin) == 3 and "use a radius of at least" in thin[0].fix


def test_cables_without_a_motor_in_their_file_are_named(tmp_path) -> None:
    path = tmp_path / "prism.yaml"
    save_structure(prism(3), path)
    text = path.read_text()
    assert text.count("motor:") == 9
    # drop bottom_1's motor from the file: it is passive
    data = yaml.safe_load(text)
    del data["cables"][1]["motor"]
    path.write_text(yaml.safe_dump(data))
    found = [str(f) for f in check_structure(load_structure(path), source=path)]
    assert any("bottom_1 give no motor, so they are passive" in f for f in found)
    assert check_structure(prism(3), source="prism3") == []  # a preset: no file to read


def test_check_command_exit_status(tmp_path, capsys) -> None:
    path = tmp_path / "prism.yaml"
    save_structure(prism(3), path)
    assert main(["check", str(path)]) == 0
    assert "no findings" in capsys.readouterr().out
    assert main(["check", str(path), "--dt", "0.02"]) == 1
    assert "use --dt 0.002" in capsys.readouterr().out


def test_simulate_warns_with_the_same_check(tmp_path, caplog) -> None:
    structure = prism(3)
    slack = dataclasses.replace(structure, cables=(
        dataclasses.replace(structure.cables[0], pretension=0.0), *structure.cables[1:]))
    path = tmp_path / "slack.yaml"
    save_structure(slack, path)
    with caplog.at_level("WARNING"):
        assert main(["--quiet", "simulate", str(path), "--duration", "0.05",
                     "--out", str(tmp_path / "run")]) == 0
    assert any("slack at the build pose" in r.getMessage() for r in caplog.records)


def test_presets_pass_at_their_step() -> None:
    # the shipped prisms are self-stressed, taut and integrate well at 1 ms
    for n in (3, 4, 5):
        assert check_structure(prism(n), 1e-3) == []
