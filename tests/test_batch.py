"""The batch engine: each trial bit-identical to the same run alone, at any thread count, with
per-trial physics equal to recompiled structures, and failures kept to their own trial."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tensim.control import load_controller
from tensim.model import compile_structure
from tensim.models import preset
from tensim.sim import (
    PhysicsScale,
    Trial,
    compiled_available,
    ramp_hold_release,
    run_batch,
    simulate,
)

pytestmark = pytest.mark.skipif(not compiled_available(),
                                reason="the batch engine needs the compiled cable law")

DURATION = 1.5  # s


@pytest.fixture(params=["alone", "chunks"])
def engine(request, monkeypatch):
    """Both ways a batch runs its trials: each alone in the compiled record loop (where it is
    built), or chunks of trials as one-thread ``mujoco.batch`` batches (without it)."""
    from tensim.sim import _batch

    if request.param == "alone" and not _batch.solo_available():
        pytest.skip("the compiled record loop is not built")
    if request.param == "chunks":
        monkeypatch.setattr(_batch, "solo_available", lambda: False)
    return request.param


@pytest.fixture(scope="module")
def robot():
    p = preset("tetraspine3")
    structure = p.build()
    return p, structure, compile_structure(structure)


def _gait(structure, compiled, name: str):
    config = load_controller(name, structure)
    return config.with_duration(DURATION).build(compiled.model.opt.timestep)


def _push():
    return ramp_hold_release("s2_tip", (0.0, 1.0, 0.5), 8.0, 0.2, 0.3, 0.4, 0.3)


def _assert_identical(single, trial) -> None:
    assert trial.ok, trial.error
    batch = trial.result
    np.testing.assert_array_equal(single.trajectory.time, batch.trajectory.time)
    for name, values in single.trajectory.channels.items():
        np.testing.assert_array_equal(values, batch.trajectory[name], err_msg=name)
    np.testing.assert_array_equal(single.peak_tension, batch.peak_tension)


def test_each_trial_equals_its_single_run_bit_for_bit(robot, engine):
    p, structure, compiled = robot
    cases = [Trial(p.controller()),
             Trial(_gait(structure, compiled, "tetraspine3_cpg")),
             Trial(_gait(structure, compiled, "tetraspine3_sine")),
             Trial(p.controller(), loads=(_push(),))]
    results = run_batch(compiled, cases, DURATION, threads=2)
    moved = []
    for case, trial in zip(cases, results, strict=True):
        single = simulate(compiled, DURATION, controller=case.controller, loads=case.loads)
        _assert_identical(single, trial)
        moved.append(np.ptp(single.trajectory["pos_y/com"]))
    assert min(moved[1:]) > 1e-3  # the gaits and the push do move the robot


def test_one_thread_equals_two_and_repeats_exactly(robot, engine):
    _, structure, compiled = robot
    trials = [Trial(_gait(structure, compiled, "tetraspine3_cpg"),
                    physics=PhysicsScale(friction=f)) for f in np.linspace(0.5, 1.5, 6)]
    reference = run_batch(compiled, trials, 0.3, threads=1)
    finals = {tuple(r.result.trajectory["pos_x/com"][-1:]) for r in reference}
    assert len(finals) > 1  # the trials differ from each other
    for _ in range(50 if engine == "chunks" else 20):  # no races: every 2-thread batch
        # gives the same numbers
        again = run_batch(compiled, trials, 0.3, threads=2)
        for a, b in zip(reference, again, strict=True):
            _assert_identical(a.result, b)


def _modified(structure, stiffness=1.0, damping=1.0, friction=1.0, motor_speed=1.0):
    """The same robot rebuilt with scaled parameters (rest lengths kept as built)."""
    cables = tuple(dataclasses.replace(
        c, stiffness=c.stiffness * stiffness, damping=c.damping * damping, pretension=None,
        rest_length=structure.rest_length(c),
        motor=dataclasses.replace(c.motor, max_speed=c.motor.max_speed * motor_speed))
        for c in structure.cables)
    rods = tuple(dataclasses.replace(r, friction=r.friction * friction) for r in structure.rods)
    return dataclasses.replace(structure, cables=cables, rods=rods)


@pytest.mark.parametrize("scale", [
    {"stiffness": 1.1}, {"damping": 0.7}, {"friction": 1.3}, {"motor_speed": 0.8},
])
def test_physics_scales_equal_recompiled_structures(robot, engine, scale):
    _, structure, compiled = robot
    gait = _gait(structure, compiled, "tetraspine3_cpg")
    rebuilt = compile_structure(_modified(structure, **scale))
    trial, own = run_batch(compiled, [Trial(gait, physics=PhysicsScale(**scale)),
                                      Trial(gait, compiled=rebuilt)], DURATION, threads=2)
    _assert_identical(simulate(rebuilt, DURATION, controller=gait), trial)
    _assert_identical(simulate(rebuilt, DURATION, controller=gait), own)  # a per-trial model
    nominal = simulate(compiled, DURATION, controller=gait)
    assert not np.array_equal(nominal.trajectory["tension/inner_top_1"],
                              trial.result.trajectory["tension/inner_top_1"])


def test_mass_scale_equals_a_heavier_robot(robot):
    p, structure, compiled = robot
    rods = tuple(dataclasses.replace(
        r, linear_density=None if r.linear_density is None else r.linear_density * 1.2,
        density=None if r.density is None else r.density * 1.2) for r in structure.rods)
    masses = tuple(dataclasses.replace(m, mass=m.mass * 1.2) for m in structure.point_masses)
    heavier = compile_structure(dataclasses.replace(structure, rods=rods, point_masses=masses))
    np.testing.assert_allclose(heavier.model.body_mass, compiled.model.body_mass * 1.2,
                               rtol=1e-12)
    [trial] = run_batch(compiled, [Trial(p.controller(), physics=PhysicsScale(mass=1.2))],
                        DURATION)
    single = simulate(heavier, DURATION, controller=p.controller())
    for name in ("tension/inner_top_1", "pos_z/segment_1", "rest_length/outer_right_1"):
        np.testing.assert_allclose(trial.result.trajectory[name], single.trajectory[name],
                                   rtol=1e-7, atol=1e-9, err_msg=name)


def test_a_bad_trial_fails_alone_with_a_message(robot, engine):
    p, _, compiled = robot
    names = list(compiled.index.cables)

    class NanGain:  # e.g. an optimizer's proposal gone wrong, past the gains' own checks
        def configure(self, sim):
            p.controller().configure(sim)
            sim.drive.gain_k[0] = np.nan

    nan_gains = NanGain()
    trials = [Trial(p.controller()), Trial(nan_gains),
              Trial(p.controller(), physics=PhysicsScale(stiffness=1e4)),
              Trial(p.controller())]
    results = run_batch(compiled, trials, 1.0, threads=2)
    assert results[0].ok and results[3].ok
    assert not results[1].ok and names[0] in results[1].error and "non-finite" in results[1].error
    assert not results[2].ok and "unstable" in results[2].error
    single = simulate(compiled, 1.0, controller=p.controller())
    _assert_identical(single, results[3])


def test_an_empty_batch_is_refused(robot):
    with pytest.raises(ValueError, match="at least one trial"):
        run_batch(robot[2], [], 1.0)


def test_a_batch_too_large_to_hold_is_refused_up_front(robot):
    with pytest.raises(ValueError, match="limit"):
        run_batch(robot[2], [Trial()] * 1000, 1e5)


def test_starting_from_a_snapshot_equals_continuing(robot, engine):
    from tensim.sim import Simulation

    _, structure, compiled = robot
    gait = _gait(structure, compiled, "tetraspine3_cpg")
    with Simulation(compiled, controller=gait) as sim:
        sim.run(0.5)
        state = sim.get_state()
        straight = sim.run(0.5)
    [trial] = run_batch(compiled, [Trial(gait, initial_state=state)], 0.5)
    for name, values in straight.channels.items():
        np.testing.assert_array_equal(values[1:], trial.result.trajectory[name][1:],
                                      err_msg=name)


def test_the_rollout_benchmark_replays_exactly_the_batch_trials():
    """The engine-limit figure of `tensim bench --batch` is the same work: mujoco.rollout on
    its inputs ends where the batch's trials end, bit for bit."""
    import mujoco
    from mujoco import rollout

    from tensim.benchmarks.batch import _problem, rollout_inputs

    problem = _problem(0.3)
    points = np.random.default_rng(5).random((3, problem.dimension))
    models, state, control, nstep = rollout_inputs(problem, points)
    states, _ = rollout.rollout(models, mujoco.MjData(models[0]), state, control, nstep=nstep)
    compiled = problem.compiled()
    dt = compiled.model.opt.timestep
    trials = run_batch(compiled, [Trial(problem.controller(u).build(dt)) for u in points], 0.3,
                       record_dt=problem.record_dt)
    act = mujoco.mj_stateSize(compiled.model, mujoco.mjtState.mjSTATE_TIME) + compiled.model.nq \
        + compiled.model.nv  # where act starts in a full-physics state
    for k, trial in enumerate(trials):
        rest = compiled.index.cable_act(states[k, -1, act:act + compiled.model.na])
        np.testing.assert_array_equal(trial.result.trajectory.matrix("rest_length")[-1], rest)


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_chunks_on_any_thread_count_equal_single_runs_and_name_their_trials(robot, engine, threads):
    """Trials cut into chunks that threads take as they finish: every trial still equals its
    single run bit for bit, and a failure names its place in the whole batch."""
    p, structure, compiled = robot
    gait = _gait(structure, compiled, "tetraspine3_cpg")
    trials = [Trial(gait, physics=PhysicsScale(friction=f)) for f in np.linspace(0.6, 1.4, 6)]
    trials.insert(4, Trial(p.controller(), physics=PhysicsScale(stiffness=1e4)))  # blows up
    results = run_batch(compiled, trials, 0.3, threads=threads)
    assert not results[4].ok and results[4].error.startswith("trial 4:")
    for k in (0, 3, 5, 6):
        trial = trials[k]
        scaled = _modified(structure, friction=trial.physics.friction)
        single = simulate(compile_structure(scaled), 0.3, controller=gait)
        _assert_identical(single, results[k])


def test_a_batch_runs_each_trial_alone_where_the_compiled_record_loop_is_built(robot,
                                                                               monkeypatch):
    """The trials of a batch are single runs in the compiled loop, not MuJoCo batch rows,
    wherever that loop is built: ``mujoco.batch`` is not even set up."""
    from tensim.sim import _batch

    if not _batch.solo_available():
        pytest.skip("the compiled record loop is not built")

    def never(*args, **kwargs):
        raise AssertionError("a mujoco.batch chunk was set up")

    monkeypatch.setattr(_batch, "_BatchRun", never)
    p, _, compiled = robot
    [trial] = run_batch(compiled, [Trial(p.controller())], 0.2)
    _assert_identical(simulate(compiled, 0.2, controller=p.controller()), trial)
