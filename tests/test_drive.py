"""The compiled cable law against the Python reference, determinism, isolation, snapshots."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from tensim.control import load_controller
from tensim.model import WorldOptions, compile_structure
from tensim.model._law_layout import A_PEAK_POWER, A_PEAK_SPEED, theta
from tensim.models import preset
from tensim.sim import Simulation, cable_law, compiled_available, ramp_hold_release, simulate

needs_compiled = pytest.mark.skipif(
    not compiled_available(), reason="compiled cable callback not built for this MuJoCo")

# Channels compared between runs: the cable state the laws produce, and the motion it causes.
QUANTITIES = ("tension", "applied", "setpoint", "rest_length", "length", "pos_x", "pos_z")
DURATION = 1.5  # s: the load ramps, holds and is released, and the controller reacts


def _load():
    # 5 N upward at the rear tip: ramp from 0.2 s over 0.2 s, hold 0.3 s, release over 0.2 s
    return ramp_hold_release("s2_tip", (0.0, 0.0, 1.0), 5.0, 0.2, 0.2, 0.3, 0.2)


def _run(backend: str, world: WorldOptions | None = None, loads=(), duration=DURATION):
    p = preset("tetraspine3")
    compiled = compile_structure(p.build(), world)
    return simulate(compiled, duration, controller=p.controller(), loads=loads,
                    backend=backend)


def _assert_agree(a, b, rtol: float) -> None:
    for q in QUANTITIES:
        x, y = a.trajectory.matrix(q), b.trajectory.matrix(q)
        scale = np.abs(x).max()
        assert np.abs(x - y).max() <= rtol * scale, q
    np.testing.assert_allclose(a.peak_tension, b.peak_tension, rtol=rtol)


# The C callback repeats the reference laws operation for operation, so each step's cable
# update agrees to the last bit or so. Over a run without an amplifier of rounding (no ground
# contact) these differences stay far below 1e-9 of the signals, while any difference in a law
# (a clamp, a sign, a missed motor limit, a load at the wrong point) shows at 1e-4 or more.
RTOL = 1e-9


@needs_compiled
def test_compiled_matches_reference_on_ground_without_load():
    world = WorldOptions()  # gravity and ground: the robot stands and the controller settles
    _assert_agree(_run("compiled", world), _run("python", world), RTOL)


@needs_compiled
def test_compiled_matches_reference_with_load_in_free_space():
    world = WorldOptions(gravity=(0.0, 0.0, 0.0), ground=False)
    a, b = _run("compiled", world, [_load()]), _run("python", world, [_load()])
    assert a.trajectory["pos_z/segment_2"][-1] > a.trajectory["pos_z/segment_2"][0] + 0.1
    _assert_agree(a, b, RTOL)


@needs_compiled
def test_compiled_matches_reference_with_load_on_ground():
    world = WorldOptions()
    _assert_agree(_run("compiled", world, [_load()]), _run("python", world, [_load()]), RTOL)


@pytest.mark.parametrize(
    "backend", ["python", pytest.param("compiled", marks=needs_compiled)])
def test_identical_runs_are_bitwise_identical(backend):
    # with the ground and a load: the case where any hidden state or ordering would show
    first, second = _run(backend, loads=[_load()]), _run(backend, loads=[_load()])
    assert first.trajectory.channels.keys() == second.trajectory.channels.keys()
    for name, values in first.trajectory.channels.items():
        np.testing.assert_array_equal(values, second.trajectory[name], err_msg=name)
    np.testing.assert_array_equal(first.trajectory.time, second.trajectory.time)
    np.testing.assert_array_equal(first.peak_tension, second.peak_tension)


@needs_compiled
def test_simultaneous_simulations_do_not_interfere():
    """Stepping two simulations in turn changes neither one's results."""
    solo = _run("compiled", loads=[_load()], duration=1.0)
    p = preset("tetraspine3")
    compiled = compile_structure(p.build())
    other = compile_structure(preset("prism3").build())
    sims = [Simulation(compiled, controller=p.controller(), loads=[_load()]),
            Simulation(other)]
    for _ in range(100):
        for sim in sims:
            sim.step(10)
    np.testing.assert_array_equal(sims[0].drive.tension, solo.trajectory.matrix("tension")[-1])


@needs_compiled
@pytest.mark.parametrize("law", ["explicit", "implicit", "implicitfast"])
def test_compiled_law_equals_the_reference_on_random_states(law):
    """For random rest lengths, commands, modes and motions, the compiled callbacks write the
    act_dot and actuator force that tensim.sim.cable_law computes from the same data (under
    the implicit law: its pull's rate too, and MuJoCo's force, gain term plus bias, clamped)."""
    p = preset("tetraspine3")
    compiled = compile_structure(p.build(), WorldOptions(cable_law=law))
    rng = np.random.default_rng(7)
    with Simulation(compiled, controller=p.controller()) as sim:
        m, d, n = sim.model, sim.data, compiled.n_cables
        s = int(m.actuator_actnum[0])  # activations per cable
        for trial in range(20):
            sim.drive.mode[:] = rng.integers(0, 2, n)
            sim.drive.offset_tension[:] = rng.uniform(0, 20, n)
            d.qvel[:] = rng.normal(0, 0.5, m.nv)
            d.act[0:s * n:s] = compiled.rest_length * rng.uniform(0.8, 1.6, n)
            d.act[1:s * n:s] = rng.uniform(0, 30, n)
            d.act[A_PEAK_SPEED:s * n:s] = rng.uniform(0, 0.14, n)  # m/s, 2x max_speed: some hold
            d.act[A_PEAK_POWER:s * n:s] = rng.uniform(0, 1.0, n)  # W
            d.ctrl[:n] = np.where(sim.drive.mode == 1, rng.normal(0, 0.05, n),
                                  compiled.rest_length * rng.uniform(0.8, 1.2, n))
            mujoco.mj_forward(m, d)
            rates = cable_law(m, d)
            assert np.abs(rates.rest_rate).max() > 0, trial  # the motors do move
            np.testing.assert_array_equal(d.act_dot[0:s * n:s], rates.rest_rate)
            np.testing.assert_array_equal(d.act_dot[1:s * n:s], rates.peak_rate)
            np.testing.assert_array_equal(d.act_dot[A_PEAK_SPEED:s * n:s], rates.peak_speed_rate)
            np.testing.assert_array_equal(d.act_dot[A_PEAK_POWER:s * n:s], rates.peak_power_rate)
            assert 0 < np.count_nonzero(rates.peak_speed_rate) < n  # some peaks rise, some hold
            np.testing.assert_array_equal(d.actuator_force[:n], rates.force)
            if law != "explicit":  # the pull: -theta exactly where taut after the motor step
                pulled = -theta(m)  # 1/2 under the discrete integrator, 1 under implicitfast
                assert pulled == {"implicit": -0.5, "implicitfast": -1.0}[law]
                d.act[s - 1:s * n:s] = rng.choice([pulled, 0.0], n)
                mujoco.mj_forward(m, d)
                rates = cable_law(m, d)
                np.testing.assert_array_equal(d.act_dot[s - 1:s * n:s], rates.pull_rate)
                np.testing.assert_array_equal(d.actuator_force[:n], rates.force)
                pull = d.act[s - 1:s * n:s] + rates.pull_rate * m.opt.timestep
                rest = d.act[0:s * n:s] + rates.rest_rate * m.opt.timestep
                taut = d.ten_length[compiled.index.tendon] > rest
                np.testing.assert_allclose(pull, np.where(taut, pulled, 0.0), atol=1e-12)
                assert 0 < taut.sum() < n and np.all(rates.force[~taut] == 0.0)


def test_snapshot_continuation_is_bit_identical_mid_gait():
    """Restoring get_state() (mjSTATE_INTEGRATION) mid-gait continues exactly as never
    stopping; plain mj_getState on sim.model/sim.data gives the same state."""
    p = preset("tetraspine3")
    structure = p.build()
    compiled = compile_structure(structure)
    controller = load_controller("tetraspine3_cpg", structure).with_duration(4.0).build(
        compiled.model.opt.timestep)
    with Simulation(compiled, controller=controller) as sim:
        sim.run(2.0)
        state = sim.get_state()
        spec = mujoco.mjtState.mjSTATE_INTEGRATION
        plain = np.empty(mujoco.mj_stateSize(sim.model, spec))
        mujoco.mj_getState(sim.model, sim.data, plain, spec)
        np.testing.assert_array_equal(plain, state)
        straight = sim.run(1.0)
        end = sim.get_state()
    with Simulation(compiled, controller=controller) as other:
        other.run(0.5)  # somewhere else entirely
        other.set_state(state)
        resumed = other.run(1.0)
        np.testing.assert_array_equal(other.get_state(), end)
    assert np.abs(straight["pos_y/com"][-1] - straight["pos_y/com"][0]) > 1e-3  # it walked
    for name in straight.channels:  # the first sample shows the restored derived fields
        np.testing.assert_array_equal(resumed[name][1:], straight[name][1:], err_msg=name)


def test_a_run_in_short_input_blocks_is_bit_identical(monkeypatch):
    """The inputs are computed a block of steps at a time, as many steps as fit a budget of
    values; any block size gives the same run, bit for bit: Tetraspine3's gait with a load,
    by simulate and by Simulation.step, in blocks of 20,000 steps and of 7 (a prime: the
    blocks' edges fall inside V* rows and control periods)."""
    from tensim.sim import _simulation

    def run():
        p = preset("tetraspine3")
        compiled = compile_structure(p.build())
        result = simulate(compiled, 0.6, controller=p.controller(), loads=[_load()])
        with Simulation(compiled, controller=p.controller(), loads=[_load()]) as sim:
            sim.step(357)
            state = sim.get_state()
        return result, state

    whole, whole_state = run()
    monkeypatch.setattr(_simulation, "_BLOCK_VALUES", 7 * 12)  # 12 cables: 7 steps a block
    assert _simulation._block_steps(12) == 7
    short, short_state = run()
    for name, values in whole.trajectory.channels.items():
        assert values.tobytes() == short.trajectory[name].tobytes(), name
    assert whole_state.tobytes() == short_state.tobytes()


def test_the_commands_of_steps_are_their_v_star_rows_or_the_rest_command():
    """CableDrive.commands gathers each step's row of per-row commands: the same as the
    formula applied to every step (impedance cables read V*, the others their rest
    command), for steps in any order, before, inside and past the table."""
    from tensim.model._law_layout import MODE_IMPEDANCE
    from tensim.sim._drive import CableDrive

    p = preset("tetraspine3")
    compiled = compile_structure(p.build())
    with Simulation(compiled, controller=p.controller()) as sim:
        drive: CableDrive = sim.drive
        rng = np.random.default_rng(3)
        drive.set_target_velocity(rng.standard_normal((9, drive.stiffness.size)), 0.013)
        steps = rng.permutation(np.arange(-5, 400))
        dt = float(compiled.model.opt.timestep)
        rows = np.clip(np.floor(steps * dt / drive.table_dt + 1e-9).astype(int), 0, 8)
        expected = np.where(drive.mode == MODE_IMPEDANCE, drive.target_velocity[rows],
                            drive.rest_command)
        assert drive.commands(steps, dt).tobytes() == expected.tobytes()
        assert drive.commands(np.arange(0), dt).shape == (0, drive.stiffness.size)
