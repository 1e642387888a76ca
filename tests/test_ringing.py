"""Runs that know when they ring: a step too long for a cable stops the run (single, batch) or
marks the RL environment's robot unstable, with the cable, the time and a step to use."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
import yaml

import tensim
from tensim.control.files import shipped_controllers
from tensim.design import check_structure
from tensim.models import PRESETS, load_model, resolve_controller
from tensim.models.prisms import prism
from tensim.sim import Trial, run_batch
from tensim.sim._loop import RING_STEPS, ringing, suggest_step
from tensim.structure import Motor, load_structure, save_structure
from tensim.terrain import parse_terrain

HOPPER = "examples/design/hopper.yaml"


def _lab_three_bar() -> tensim.Structure:
    """A lab's 3-bar: 1.376 m rods of 4 kg, 6 end-triangle cables and 3 verticals of 10 kN/m
    and 1000 N s/m, in the self-stressed prism form (tensim check: Euler stable below
    0.66 ms, set by the damping)."""
    base = prism(3)
    scale = 1.376 / base.distance(*base.rods[0].nodes)
    nodes = tuple(dataclasses.replace(n, position=tuple(scale * np.array(n.position)))
                  for n in base.nodes)
    rods = tuple(dataclasses.replace(r, linear_density=4.0 / 1.376, radius=0.02)
                 for r in base.rods)
    cables = tuple(dataclasses.replace(c, stiffness=1e4, damping=1e3,
                                       pretension=scale * c.pretension,
                                       motor=Motor(max_speed=0.5, max_tension=2000.0))
                   for c in base.cables)
    return dataclasses.replace(base, name="lab3", nodes=nodes, rods=rods, cables=cables,
                               point_masses=())


def _run(structure: tensim.Structure, dt: float, duration: float) -> str | None:
    """The error of a run of ``structure`` at step ``dt`` [s] (None if it finished)."""
    compiled = tensim.compile_structure(structure, tensim.WorldOptions(timestep=dt))
    try:
        tensim.simulate(compiled, duration, record_dt=2 * dt)
    except tensim.SimulationError as err:
        return str(err)
    return None


def test_ringing_tells_the_step_frequency_from_resolved_motion() -> None:
    dt, t = 1e-3, np.arange(RING_STEPS)[None, :, None] * 1e-3
    slack_taut = np.array([0.0, 240.0, 0.0])[None, :, None]
    resolved = 50.0 + 40.0 * np.sin(2 * np.pi * 100.0 * t)  # 100 Hz, 10 steps a cycle
    small = 50.0 + np.array([-5.0, 5.0, -5.0])[None, :, None]  # inside its band
    round_off = np.array([0.0, 1e-9, 0.0])[None, :, None]
    forces = np.concatenate([slack_taut, resolved, small, round_off], axis=2)
    assert ringing(-forces).tolist() == [[True, False, False, False]]  # forces pull: < 0
    assert suggest_step(dt) == 5e-4 and suggest_step(5.2e-3) == 2e-3


def test_the_free_hopper_at_5_2_ms_is_caught_with_cable_time_and_step() -> None:
    # tensim check: Euler stable below 4.29 ms; the speed check alone stops it at 5.18 s
    error = _run(load_structure(HOPPER), 5.2e-3, 1.0)
    assert error is not None
    found = re.search(r"unstable at t = ([\d.]+) s: cable '(\w+)' rings at the step frequency",
                      error)
    assert found and float(found[1]) < 1.0
    assert "Use --dt 0.002 or less" in error
    assert _run(load_structure(HOPPER), 4e-3, 1.0) is None  # below the bound: quiet


def test_the_lab_three_bar_at_1_ms_is_caught_single_and_batch() -> None:
    structure = _lab_three_bar()
    error = _run(structure, 1e-3, 1.0)
    assert error is not None and "rings at the step frequency" in error
    assert "Use --dt 0.0005 or less" in error
    compiled = tensim.compile_structure(structure, tensim.WorldOptions(timestep=1e-3))
    batch = run_batch(compiled, [Trial(), Trial()], 1.0, record_dt=2e-3)
    assert [r.error for r in batch] == [f"trial {i}: {error}" for i in range(2)]
    found = [f for f in check_structure(structure, 1e-3) if f.item == "timestep"]
    assert found[0].severity == "error" and "stable below 0.6618 ms" in found[0].message
    assert _run(structure, 2e-4, 1.0) is None  # the step tensim check asks for: quiet


def test_rl_environment_checks_its_step_and_reports_ringing(tmp_path) -> None:
    from tensim.rl import EnvConfig, TensegrityEnv
    from tensim.rl.config import Randomization

    path = tmp_path / "lab3.yaml"
    save_structure(_lab_three_bar(), path)
    with pytest.raises(tensim.InputError, match=r"world.timestep = 0.001 s: .*stable below"):
        TensegrityEnv(EnvConfig(model=str(path)))
    # the hopper passes the check at 1 ms, but 30 times stiffer cables (a randomisation
    # beyond its bound of 4.29 ms / sqrt(30) = 0.78 ms) ring
    config = EnvConfig(model=HOPPER, action="rest_length",
                       randomization=Randomization(stiffness=(30.0, 30.0)))
    for scale, rings in ((30.0, True), (1.0, False)):
        env = TensegrityEnv(dataclasses.replace(
            config, randomization=Randomization(stiffness=(scale, scale))))
        env.reset(seed=0)
        env.action_space.seed(0)
        unstable = False
        for _ in range(150):  # 1.5 s of random actions
            unstable = env.step(env.action_space.sample())[4]["unstable"]
            if unstable:
                break
        assert unstable == rings
        # the ringing check is what fires (or stays quiet)
        kept = env.worlds.forces
        assert bool(ringing(kept.force[:1], kept.band).any()) == rings


EXAMPLES = ["examples/design/hopper.yaml", "examples/design/hopper_sketch.yaml",
            "examples/design/payload_prism.yaml", "examples/tensegrity_prism.yaml",
            "examples/prism4.yaml", "examples/hardware/tetraspine3_dc.yaml"]
CASES = [(name, None) for name in sorted(PRESETS)] + [(path, None) for path in EXAMPLES] \
    + [(yaml.safe_load(path.read_text())["model"], name)  # the robot each file names
       for name, path in sorted(shipped_controllers().items())] \
    + [("examples/design/hopper.yaml", "examples/design/hopper_roll.yaml")]


@pytest.mark.parametrize(("model", "controller"), CASES)
def test_shipped_models_are_quiet_at_their_default_step(model: str, controller: str | None
                                                         ) -> None:
    # each preset with its own controller, each example structure, each shipped controller
    # file on its model: 0.3 s at the default 1 ms step finish without ringing
    structure = load_model(model)
    config = resolve_controller(model, structure, controller)
    compiled = tensim.compile_structure(structure)
    # (a ringing cable raises SimulationError: the run must reach its end, finite)
    run = tensim.simulate(compiled, 0.3, controller=config.build(1e-3) if config else None)
    assert run.trajectory.time[-1] == pytest.approx(0.3)
    assert np.isfinite(run.trajectory.matrix("tension")).all()


def test_the_contact_cable_example_is_quiet() -> None:
    # examples/contact_edge.yaml over the wall of docs/cables.md
    world = tensim.WorldOptions(terrain=parse_terrain("wall:height=0.3,distance=-0.1,"
                                                      "thickness=0.1"))
    compiled = tensim.compile_structure(load_structure("examples/contact_edge.yaml"), world)
    run = tensim.simulate(compiled, 0.3)  # a ringing cable would raise SimulationError
    assert run.trajectory.time[-1] == pytest.approx(0.3)


def test_rl_environment_checks_the_step_of_its_own_cable_law(tmp_path) -> None:
    from tensim.rl import EnvConfig, TensegrityEnv

    path = tmp_path / "lab3.yaml"
    save_structure(_lab_three_bar(), path)
    # refused at 1 ms under the explicit law (above), taken under the implicit one: its
    # discrete step has no bound, and the check says so in a note
    env = TensegrityEnv(EnvConfig(model=str(path),
                                  world=tensim.WorldOptions(cable_law="implicit")))
    assert [(f.severity, f.item) for f in env.robot.findings if f.item == "timestep"] == [
        ("note", "timestep")]
