"""The energy-growth check: the mechanical energy of the bodies and cable springs, and runs
stopped where it runs away (single runs, the batch), beside the ringing check."""

from __future__ import annotations

import re
from unittest import mock

import mujoco
import numpy as np
import pytest

import tensim
from tensim.models.prisms import prism
from tensim.sim import Trial, run_batch
from tensim.sim._loop import ENERGY_LIMIT, Energy, EnergyHistory, ForceHistory
from tensim.structure import load_structure

HOPPER = "examples/design/hopper.yaml"


def test_energy_is_mujocos_kinetic_and_potential_energy_plus_the_springs() -> None:
    # MuJoCo's own mj_energyVel (1/2 v^T M v) and mj_energyPos (the weights' potential) on a
    # random state of prism3: the fast per-body sums must give the same numbers; the cables'
    # k max(0, x - l)^2 / 2 is the load cell's T^2 / (2 k)
    compiled = tensim.compile_structure(prism(3))
    with tensim.Simulation(compiled) as sim:
        rng = np.random.default_rng(1)
        sim.data.qvel[:] = rng.standard_normal(sim.model.nv)
        sim.step(3)
        m, d = sim.model, sim.data
        mujoco.mj_forward(m, d)  # the kinematics and mass matrix of the state itself
        kinetic, weight, spring = Energy(compiled).parts(d.qvel[None], d.xpos[None],
                                                         d.ten_length[None], d.act[None])
        mujoco.mj_energyPos(m, d)
        mujoco.mj_energyVel(m, d)
        assert kinetic.sum() == pytest.approx(d.energy[1], rel=1e-12)
        assert weight[0] == pytest.approx(d.energy[0], rel=1e-12)
        fields = (d.qvel[None], d.xpos[None], d.ten_length[None], d.act[None])
        assert Energy(compiled).total(*fields)[0] == pytest.approx(
            kinetic.sum() + weight[0] + spring.sum(), rel=1e-12)  # the fast path: the sum
        tension = sim.drive.tension
        assert spring[0] == pytest.approx(tension**2 / (2 * sim.drive.stiffness), rel=1e-12)


def test_growth_from_inputs_is_not_a_runaway() -> None:
    # checks every 50 ms for 2 s: a push's work or a motor's spring energy growing as t^2 to
    # 30 times the robot's energy scale, a fall (a constant total), a run that doubles its
    # energy every check from round-off, and one that doubles but stays below the limit
    history = EnergyHistory(4, scale=1.0)
    t = np.arange(1, 41) * 0.05
    grows = np.zeros(4, dtype=bool)
    for k in range(len(t)):
        grows |= history.push(slice(None), np.array([30 * (t[k] / t[-1]) ** 2, 1.0,
                                                     1e-9 * 2.0**k, min(1e-9 * 2.0**k, 9.0)]))
    assert grows.tolist() == [False, False, True, False]


def _no_ringing(self: ForceHistory, ids: object) -> np.ndarray:
    return np.zeros((len(self.force[ids]), len(self.band)), dtype=bool)


def test_a_runaway_the_ringing_check_is_blind_to_is_stopped_single_and_batch() -> None:
    # the free hopper at 6 ms (tensim check: Euler stable below 4.29 ms) with the ringing
    # check off: its energy runs away to ten times the robot's before the speed check (which
    # alone stops it at 0.49 s); at 4 ms it stays quiet
    structure = load_structure(HOPPER)
    with mock.patch.object(ForceHistory, "ringing", _no_ringing):
        compiled = tensim.compile_structure(structure, tensim.WorldOptions(timestep=6e-3))
        with pytest.raises(tensim.SimulationError) as caught:
            tensim.simulate(compiled, 1.0, record_dt=6e-3)
        error = str(caught.value)
        found = re.search(r"unstable at t = ([\d.]+) s: the mechanical energy of the bodies "
                          r"and cables runs away, from ([\d.]+) to ([\d.]+) J", error)
        assert found and float(found[1]) < 0.49
        assert float(found[3]) > ENERGY_LIMIT * Energy(compiled).scale
        assert "most of it in body 'rod_" in error and "Use --dt 0.002 or less" in error
        assert "--cable-law implicit, or softer cables" in error  # every cable is explicit
        batch = run_batch(compiled, [Trial()], 1.0, record_dt=6e-3)
        assert batch[0].error == f"trial 0: {error}"
        quiet = tensim.compile_structure(structure, tensim.WorldOptions(timestep=4e-3))
        assert tensim.simulate(quiet, 1.0, record_dt=8e-3).trajectory.time[-1] \
            == pytest.approx(1.0)


def test_a_pulled_mass_is_not_a_runaway_and_the_allowance_is_the_loads_work() -> None:
    # a 10 g bob on a 100 N/m cable pulled down by a load ramped to 50 N: the cable stores
    # about 12.5 J, 70 times the robot's own energy scale (0.175 J), yet the step (omega dt =
    # 0.1) is stable; the allowance is the load's peak force over the robot's size (50 N x
    # 0.5 m) or the kinetic energy of its impulse ((50 N x 0.2 s)^2 / (2 x 0.01 kg)),
    # whichever is larger, and the run is checked against 10 times scale + allowance
    from tensim.sim import NodeLoad
    from tensim.structure import Cable, Node, PointMass, Structure

    s = Structure(
        "hanging",
        (Node("top", (0.0, 0.0, 1.0), fixed=True), Node("bob", (0.0, 0.0, 0.5))),
        cables=(Cable("spring", ("top", "bob"), 100.0, rest_length=0.45),),
        point_masses=(PointMass("bob", 0.01),),
    )
    compiled = tensim.compile_structure(s, tensim.WorldOptions(timestep=1e-3, ground=False))
    load = NodeLoad("bob", np.array([0.0, 0.2]), np.array([[0, 0, 0], [0, 0, -50.0]]))
    energy = Energy(compiled)
    assert energy.size == pytest.approx(0.5)
    assert energy.load_allowance([load]) == pytest.approx(max(50 * 0.5, (50 * 0.2) ** 2 / 0.02))
    assert energy.load_allowance([]) == 0.0
    result = tensim.simulate(compiled, 1.0, loads=[load], record_dt=1e-2)
    assert result.trajectory.time[-1] == pytest.approx(1.0)
    assert result.trajectory["tension/spring"].max() > 45.0  # the pull reached the cable


def test_a_runaway_suggests_only_what_the_cable_law_can_still_do() -> None:
    # the implicit law for an all-explicit robot, more cables handed over for one split by
    # cable (the test_cable_split robot at 4 ms: its stiff pair handed over, the soft cable
    # not), and nothing of the law where every cable is on the implicit law already
    from tensim.sim._loop import energy_message
    from test_cable_split import HELD

    def advice(structure, **options) -> str:
        compiled = tensim.compile_structure(structure, tensim.WorldOptions(**options))
        return energy_message("body 'rod'", np.ones(4), 0.5, 4e-3, Energy(compiled).remedy)

    hopper = load_structure(HOPPER)
    assert "(`tensim check` prints the bound), --cable-law implicit, or softer" in advice(hopper)
    assert "(`tensim check` prints the bound), or softer" in advice(hopper, cable_law="implicit")
    split = advice(HELD, timestep=4e-3, ground=False, cable_law="implicit", split_margin=4.0)
    assert "bound), a larger --split-margin (more cables on the implicit law), or softer" \
        in split
