"""The model check: its time-step bound against simulation, and its other findings."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import yaml
from scipy.linalg import eigh

import tensim
from tensim.cli import main
from tensim.design.check import check_structure
from tensim.design.stiffness import (
    Stiffness,
    _flip_step,
    _scanned_step,
    stable_timestep,
    step_bound,
    step_matrix,
    stiffness,
)
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
    # a saturating motor's cap is not a stop: it pays out to it, a note rather than an error
    cables[2] = dataclasses.replace(cables[2], motor=Motor(max_speed=0.1, max_tension=20.0,
                                                           saturate=True))
    capped = [f for f in check_structure(dataclasses.replace(base, cables=tuple(cables)))
              if f.item == "cable 'bottom_2'"]
    assert [f.severity for f in capped] == ["note"] and "force cap 20 N" in str(capped[0])
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
    # drop bottom_1's motor from the file: it is passive (as tensim info says), a note only
    data = yaml.safe_load(text)
    del data["cables"][1]["motor"]
    path.write_text(yaml.safe_dump(data))
    robot = load_structure(path)
    assert robot.cables[1].motor.passive
    found = check_structure(robot, source=path)
    assert [(f.severity, f.message) for f in found] == [
        ("note", "bottom_1 give no motor, so they are passive (their rest lengths never "
                 "change)")]
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


def _mixed_prism() -> tensim.Structure:
    """prism3 whose vertical cables damp 20 N s/m and whose triangles do not damp at all:
    one damping-to-stiffness ratio per robot does not describe it."""
    base = prism(3)
    return dataclasses.replace(base, cables=tuple(
        dataclasses.replace(c, damping=20.0 if "vertical" in c.tags else 0.0)
        for c in base.cables))


def _grows(structure: tensim.Structure, dt: float, law: str = "explicit") -> bool:
    """Whether a small random kick of the free, weightless structure grows over 2 s under the
    cable law ``law``: the tensions' largest deviation in the last tenth of the run above that
    in the first."""
    world = tensim.WorldOptions(timestep=dt, gravity=(0.0, 0.0, 0.0), ground=False,
                                cable_law=law)
    with tensim.Simulation(tensim.compile_structure(structure, world), record_dt=dt) as sim:
        sim.data.qvel[:] += 1e-4 * np.random.default_rng(0).standard_normal(sim.model.nv)
        try:
            tension = sim.run(2.0).matrix("tension")
        except tensim.SimulationError:
            return True
    deviation = np.abs(tension - tension[0]).max(axis=1)
    tenth = len(deviation) // 10
    return not np.isfinite(deviation).all() or deviation[-tenth:].max() > deviation[:tenth].max()


def _per_mode_estimate(result: Stiffness) -> float:
    """The bound of one damping ratio per vibration mode (the modal damping v^T C v, the
    coupling between modes left out): what tensim printed before the step matrix."""
    omega = 2 * np.pi * result.frequencies
    live = omega > 1e-6 * omega.max()
    zeta = np.einsum("ik,ij,jk->k", result.modes, result.damping, result.modes)[live] \
        / (2 * omega[live])
    return float((2 * (np.sqrt(1 + zeta**2) - zeta) / omega[live]).min())


def test_step_bound_brackets_simulation_with_mixed_damping() -> None:
    structure = _mixed_prism()
    result = stiffness(structure, count=False)
    bound = step_bound(result).limit
    # bisection in simulation, from a bracket 30 % either side, down to 1 %
    low, high = 0.7 * bound, 1.3 * bound
    assert not _grows(structure, low) and _grows(structure, high)
    while high - low > 0.01 * bound:
        middle = (low + high) / 2
        low, high = (low, middle) if _grows(structure, middle) else (middle, high)
    # within 2 %: the linearisation about the build pose against the nonlinear run, whose
    # growth just above the bound is slow (2 s decide it at 1 %)
    assert 0.98 * bound < low < high < 1.02 * bound
    # the per-mode estimate misses it by more than 10 % on this robot: the test can tell them
    assert _per_mode_estimate(result) > 1.1 * bound
    found = check_structure(structure, 1.05 * bound)
    assert [f.severity for f in found if f.item == "timestep"] == ["error"]
    assert f"stable below {bound * 1e3:.4g} ms" in str(found[0])


def test_step_bound_of_one_mode_is_the_closed_form() -> None:
    # one mass on one spring and damper: x'' = -omega^2 x - 2 zeta omega x'; the step matrix
    # has the eigenvalue -1 at omega dt = 2 (sqrt(1 + zeta^2) -+ zeta) (euler: explicit
    # damping; implicitfast: implicit damping)
    omega, zeta = 40.0, 0.3
    for integrator, sign in (("euler", -1.0), ("implicitfast", 1.0)):
        stiff, damp = np.array([[omega**2]]), np.array([[2 * zeta * omega]])
        closed = 2 * (np.sqrt(1 + zeta**2) + sign * zeta) / omega
        assert _flip_step(stiff, damp, integrator) == pytest.approx(closed, rel=1e-12)
        # the scan and bisection on the spectral radius find it too
        assert _scanned_step(stiff, damp, integrator, 1.0) == pytest.approx(closed, rel=2e-4)
    with pytest.raises(ValueError, match="integrator must be one of euler, implicitfast"):
        step_matrix(stiff, damp, np.eye(1), 1e-3, "rk4")


def test_a_passive_cable_above_the_default_motors_limit_is_not_an_error(tmp_path, capsys):
    # a cable the file gives no motor is passive: no motor limit applies (tensim info agrees)
    data = yaml.safe_load(_saved(tmp_path, prism(3)).read_text())
    data["cables"][0].pop("motor")
    data["cables"][0]["pretension"] = 80.0  # above the default motor's 50 N
    path = tmp_path / "passive.yaml"
    path.write_text(yaml.safe_dump(data))
    found = check_structure(load_structure(path), source=path)
    assert not [f for f in found if "max_tension" in f.message]
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "inherit" not in out and "note: 1 cable(s): bottom_0 give no motor, so they are " \
        "passive" in out


def _saved(tmp_path, structure):
    path = tmp_path / "robot.yaml"
    save_structure(structure, path)
    return path


def test_equilibrium_is_judged_against_the_robots_weight() -> None:
    from tensim.design.equilibrium import residuals
    from tensim.models import tetraspine3

    # Tetraspine3's end segments are pulled inward by 1.45 times its weight: it settles (a
    # note, not a warning on every run)
    spine = tetraspine3()
    weight = spine.total_mass() * 9.81
    force = max(f for f, _ in residuals(spine).values())
    assert 1.4 < force / weight < 1.5
    assert [f.severity for f in check_structure(spine)] == ["note"]
    # one prism cable at 3x its pretension: 7.5 weights, a warning with the figures
    base = prism(3)
    cables = list(base.cables)
    cables[6] = dataclasses.replace(cables[6], pretension=3 * cables[6].pretension)
    (finding,) = check_structure(dataclasses.replace(base, cables=tuple(cables)))
    ratio = max(f for f, _ in residuals(dataclasses.replace(base, cables=tuple(cables)))
                .values()) / (base.total_mass() * 9.81)
    assert finding.severity == "warning" and f"{ratio:.3g} times the robot's weight" \
        in finding.message and ratio > 2


def test_the_thin_rod_floor_is_a_warning_with_figures_and_can_be_turned_off(caplog) -> None:
    import logging

    from tensim.model import WorldOptions, _compile, compile_structure

    _compile._WARNED.clear()
    with caplog.at_level(logging.WARNING, logger="tensim.model._compile"):
        compiled = compile_structure(prism(3))
    (record,) = [r for r in caplog.records if "principal inertia" in r.getMessage()]
    assert record.levelno == logging.WARNING
    message = record.getMessage()
    # the prism's rods: axial 1.39e-05 kg m^2 raised to 0.01 of the transverse 7.94e-03
    assert "from 1.39e-05 to 7.94e-05 kg m^2, up to 5.72x" in message
    assert "--inertia-floor 0" in message and len(compiled.inertia_adjusted) == 3
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="tensim.model._compile"):
        bare = compile_structure(prism(3), WorldOptions(min_inertia_ratio=0.0))
    assert not caplog.records and bare.inertia_adjusted == ()
    body = bare.model.body("rod_0").id
    assert bare.model.body_inertia[body].min() == pytest.approx(1.389e-05, rel=1e-3)


def test_the_inertia_floor_option_reaches_the_run_and_its_replay(tmp_path) -> None:
    import json

    from tensim.viz.replay import load_run

    out = tmp_path / "run"
    assert main(["--quiet", "simulate", "prism3", "--duration", "0.02", "--inertia-floor", "0",
                 "--out", str(out)]) == 0
    assert json.loads((out / "summary.json").read_text())["min_inertia_ratio"] == 0.0
    assert load_run(out).compiled.world.min_inertia_ratio == 0.0


def test_a_rod_given_its_axial_inertia_keeps_it(tmp_path, caplog) -> None:
    import logging

    from tensim.model import _compile, compile_structure

    base = prism(3)
    given = 2.5e-5  # kg m^2: between the cylinder's 1.39e-05 and the floor's 7.94e-05
    robot = dataclasses.replace(base, rods=tuple(dataclasses.replace(r, axial_inertia=given)
                                                 for r in base.rods))
    path = tmp_path / "robot.yaml"
    save_structure(robot, path)
    assert load_structure(path) == robot  # the field goes through the file
    _compile._WARNED.clear()
    with caplog.at_level(logging.WARNING, logger="tensim.model._compile"):
        compiled = compile_structure(load_structure(path))
    assert not [r for r in caplog.records if "principal inertia" in r.getMessage()]
    from tensim.structure import mass_properties

    group = next(g for g in robot.rigid_groups() if g.name == "rod_0")
    moments = np.linalg.eigvalsh(mass_properties(robot, group).inertia)  # rod plus end caps
    assert moments[0] < 0.01 * moments[-1]  # below the floor, which would have raised it
    body = compiled.model.body("rod_0").id
    assert compiled.model.body_inertia[body].min() == pytest.approx(moments[0], rel=1e-9)
    with pytest.raises(tensim.structure.StructureError, match="axial_inertia must be > 0"):
        dataclasses.replace(base.rods[0], axial_inertia=-1.0)


def _damped_prism(vertical: float = 50.0, triangle: float = 10.0) -> tensim.Structure:
    """prism3 with strongly damped verticals and lightly damped triangles: MuJoCo's
    implicitfast keeps each body's own block of their damping, not the blocks between bodies."""
    base = prism(3)
    return dataclasses.replace(base, cables=tuple(
        dataclasses.replace(c, damping=vertical if "vertical" in c.tags else triangle)
        for c in base.cables))


def test_two_free_masses_under_implicitfast_lose_their_damping_bonus() -> None:
    # x1'' = -w^2 (x1 - x2) - c (x1' - x2'), and the same for x2 (unit masses): implicitfast
    # takes each mass's own damping c implicitly but the cross term -c x2' explicitly; on the
    # vibration mode u = x1 - x2 the two cancel in the flip condition
    # r^2 u = K u + r (C - 2 D) u = 2 w^2 u + r (2 c - 2 c) u, so dt = 2 / (sqrt(2) w) whatever
    # c, against 2 (sqrt(1 + z^2) + z) / (sqrt(2) w) with all of C implicit
    w, c = 30.0, 25.0
    stiff = w**2 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    damp = c * np.array([[1.0, -1.0], [-1.0, 1.0]])
    own = np.diag(np.diag(damp))
    closed = 2 / (np.sqrt(2) * w)
    assert _flip_step(stiff, damp, "implicitfast", (stiff, damp, own)) == pytest.approx(closed)
    for dt, grows in ((0.99 * closed, False), (1.01 * closed, True)):
        radius = np.abs(np.linalg.eigvals(
            step_matrix(stiff, damp, np.eye(2), dt, "implicitfast", own))).max()
        assert (radius > 1 + 1e-9) == grows
    zeta = 2 * c / (2 * np.sqrt(2) * w)  # the mode's damping ratio (its C is 2 c)
    full = 2 * (np.sqrt(1 + zeta**2) + zeta) / (np.sqrt(2) * w)
    assert _flip_step(stiff, damp, "implicitfast") == pytest.approx(full)


def test_implicitfast_bound_brackets_simulation_under_the_implicitfast_law() -> None:
    structure = _damped_prism()
    result = stiffness(structure, count=False)
    bound = step_bound(result, "implicitfast").limit
    # all of C implicit would promise a step 2.2x longer: the test tells the two apart
    everything = dataclasses.replace(result, dof_body=np.zeros_like(result.dof_body))
    assert step_bound(everything, "implicitfast").limit > 2 * bound
    # bisection in simulation under the implicitfast law, from 30 % either side down to 2 %
    low, high = 0.7 * bound, 1.3 * bound
    assert not _grows(structure, low, "implicitfast") and _grows(structure, high, "implicitfast")
    while high - low > 0.02 * bound:
        middle = (low + high) / 2
        low, high = (low, middle) if _grows(structure, middle, "implicitfast") \
            else (middle, high)
    # within 2 %: the linearisation against the nonlinear run (as for the explicit bound)
    assert 0.98 * bound < low < high < 1.02 * bound
    found = check_structure(structure, 1.05 * bound, cable_law="implicitfast")
    assert [f.severity for f in found if f.item == "timestep"] == ["error"]
    assert f"implicitfast step is stable below {bound * 1e3:.4g} ms" in str(found[0])


def test_the_implicit_law_has_no_bound_and_check_says_so(capsys) -> None:
    structure = _damped_prism()
    result = stiffness(structure, count=False)
    assert step_bound(result, "discrete").limit == np.inf
    # trapezoidal in K and C: the step matrix does not grow at any step (the rigid motions'
    # eigenvalue 1 is a Jordan block, which round-off splits by ~sqrt(eps |matrix|), up to
    # 2e-6 at a 1 s step); in the stiffened modes alone it shrinks. The Euler step grows far
    # above its bound
    explicit = step_bound(result).limit
    values, modes = eigh(result.matrix, result.mass)
    keep = values > 1e-9 * values.max()
    stiff, damp = np.diag(values[keep]), (modes.T @ result.damping @ modes)[np.ix_(keep, keep)]
    for dt in np.geomspace(1e-4, 1.0, 9):
        matrix = step_matrix(result.matrix, result.damping, result.mass, dt, "discrete")
        assert np.abs(np.linalg.eigvals(matrix)).max() <= 1 + 1e-5
        modal = step_matrix(stiff, damp, np.eye(len(stiff)), dt, "discrete")
        assert np.abs(np.linalg.eigvals(modal)).max() < 1
    euler = step_matrix(result.matrix, result.damping, result.mass, 10 * explicit)
    assert np.abs(np.linalg.eigvals(euler)).max() > 2
    found = check_structure(structure, 10 * explicit, cable_law="implicit")
    assert [(f.severity, f.item) for f in found] == [("note", "timestep")]
    assert f"Euler step is stable below {explicit * 1e3:.4g} ms" in found[0].message
    assert main(["check", "prism3", "--dt", "0.05", "--cable-law", "implicit"]) == 0
    assert "stable at any step" in capsys.readouterr().out
    assert main(["check", "prism3", "--dt", "0.05", "--cable-law", "implicitfast"]) == 1
    assert "the implicitfast step is stable below" in capsys.readouterr().out
    with pytest.raises(ValueError, match="cable_law must be one of"):
        check_structure(structure, cable_law="stiff")
