"""Member checks (tensim.design.members): buckling, yield and breaking margins by hand, rod
forces against the self-stress, and a run's peaks against the resting prestress."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import tensim
from tensim.cli import main
from tensim.design import self_stress
from tensim.design._bodies import cable_tensions
from tensim.design.form_finding import form
from tensim.design.member_peaks import run_peaks
from tensim.design.members import bar_forces, cable_checks, rod_checks, section_mass
from tensim.design.topology import load_topology
from tensim.model import WorldOptions
from tensim.models.prisms import prism
from tensim.structure import RodSection

EXAMPLE = Path(__file__).parent.parent / "examples/design/hopper_topology.yaml"


def _hopper() -> tensim.Structure:
    """The formed hopper: rods 0.44 m of 8 x 6 mm aluminium tube, cables breaking at 400 N."""
    return form(load_topology(EXAMPLE)).structure


def test_buckling_yield_and_breaking_margins_by_hand() -> None:
    structure = _hopper()
    forces = bar_forces(structure, cable_tensions(structure))
    rods = rod_checks(structure, forces)
    # by hand: I = pi / 64 (0.008^4 - 0.006^4) = 1.37445e-10 m^4, E I = 9.48368 N m^2,
    # P_cr = pi^2 E I / 0.44^2 = 483.472 N; A = pi / 4 (0.008^2 - 0.006^2) = 2.19911e-5 m^2,
    # sigma_y A = 2.76e8 x A = 6069.56 N
    stress = self_stress(structure, min_tension=20.0)
    for check in rods:
        force = stress.rod_forces[check.rod]  # the self-stress's own figure (lone rods)
        assert check.force == pytest.approx(force, rel=1e-9)
        assert check.buckling_load == pytest.approx(483.472, rel=1e-6)
        assert check.yield_load == pytest.approx(6069.56, rel=1e-6)
        assert check.buckling_margin == pytest.approx(483.472 / -force - 1, rel=1e-6)
        assert check.yield_margin == pytest.approx(6069.56 / -force - 1, rel=1e-6)
    for check in cable_checks(structure, cable_tensions(structure)):
        assert check.margin == pytest.approx(400.0 / check.tension - 1, rel=1e-12)
    # 3 rods x 2700 kg/m^3 x A x 0.44 m = 0.078377 kg, plus 6 x 0.08 kg of end masses
    assert section_mass(structure)[0] == pytest.approx(0.078377 + 0.48, rel=1e-5)


def test_rod_forces_match_the_self_stress_on_prisms() -> None:
    for n in (3, 5):
        structure = prism(n)
        stress = self_stress(structure, min_tension=7.0)
        fixed = tensim.design.prestressed(structure, stress)
        forces = bar_forces(fixed, cable_tensions(fixed))
        for rod, force in stress.rod_forces.items():
            assert forces[rod] == pytest.approx(force, rel=1e-6)  # rest lengths to round-off


def test_unbalanced_rods_get_no_figure() -> None:
    # the 3-prism with wrong pretensions: its rods' ends are not balanced by axial forces
    structure = prism(3)
    cables = tuple(dataclasses.replace(c, pretension=5.0 + i)
                   for i, c in enumerate(structure.cables))
    forces = bar_forces(dataclasses.replace(structure, cables=cables),
                        np.arange(5.0, 14.0))
    assert set(forces.values()) == {None}


def test_run_peaks_at_rest_are_the_prestress(tmp_path: Path) -> None:
    structure = _hopper()
    compiled = tensim.compile_structure(structure, WorldOptions(gravity=(0.0, 0.0, 0.0),
                                                                ground=False))
    run = tensim.simulate(compiled, 0.5, record_dt=0.05)
    tensions, rods = run_peaks(structure, run.trajectory)
    prestress = bar_forces(structure, cable_tensions(structure))
    # at rest: the formed robot stands still (under 1 mm), so its forces stay within 0.1 %
    np.testing.assert_allclose(tensions, cable_tensions(structure), rtol=1e-3)
    for rod, force in rods.items():
        assert force == pytest.approx(prestress[rod], rel=1e-3)


def test_members_command_fails_a_weak_member(tmp_path: Path, capsys) -> None:
    structure = _hopper()
    weak = dataclasses.replace(structure, rods=tuple(
        dataclasses.replace(r, section=RodSection(0.004, 6.9e10, 2.76e8)) for r in
        structure.rods))
    path = tmp_path / "weak.yaml"
    tensim.save_structure(weak, path)
    assert main(["design", "members", str(path)]) == 1
    out = capsys.readouterr().out
    # by hand: a solid 4 mm rod: I = pi 0.004^4 / 64 = 1.25664e-11 m^4, E I = 0.867080 N m^2,
    # P_cr = pi^2 E I / 0.44^2 = 44.2032 N, below the rods' 73.35 N
    p_cr = math.pi**2 * 6.9e10 * math.pi * 0.004**4 / 64 / 0.44**2
    assert p_cr == pytest.approx(44.2032, rel=1e-5)
    force = -min(f for f in bar_forces(weak, cable_tensions(weak)).values() if f is not None)
    assert "44.2 " in out
    assert f"a member fails: the smallest margin is {100 * (p_cr / force - 1):.1f} %" in out


def test_sections_and_breaking_loads_round_trip_and_are_validated(tmp_path: Path) -> None:
    structure = _hopper()
    path = tmp_path / "robot.yaml"
    tensim.save_structure(structure, path)
    again = tensim.load_structure(path)
    assert again == structure
    assert again.rods[0].section == RodSection(0.008, 6.9e10, 2.76e8, 0.006, 2700.0)
    assert again.cables[0].breaking_load == 400.0
    text = path.read_text()
    cases = [("inner_diameter: 0.006", "inner_diameter: 0.009",
              r"rods\[0\] 'rod_0' section: inner_diameter must be >= 0 m and below "
              r"outer_diameter 0.008 m, got 0.009"),
             ("modulus: 69000000000.0", "modulus: -1",
              r"rods\[0\] 'rod_0' section: modulus must be > 0, got -1"),
             ("modulus: 69000000000.0", "modulus: 6.9e10\n    colour: red",
              r"rods\[0\] 'rod_0' section: unknown field 'colour'"),
             ("breaking_load: 400.0", "breaking_load: stiff",
              r"cable 'bottom_0': breaking_load must be a finite number \[N\]")]
    for old, new, message in cases:
        assert old in text
        path.write_text(text.replace(old, new, 1))
        with pytest.raises(tensim.StructureError, match=f"^{path}: {message}"):
            tensim.load_structure(path)


def test_members_command_reads_a_run(tmp_path: Path, capsys) -> None:
    path = tmp_path / "robot.yaml"
    tensim.save_structure(_hopper(), path)
    run = tmp_path / "run"
    assert main(["--quiet", "simulate", str(path), "--duration", "0.3", "--out", str(run)]) == 0
    capsys.readouterr()
    assert main(["design", "members", str(path), str(run)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("peak forces of 1 run(s)")
    assert "mass with the rods' sections 0.5584 kg" in out
