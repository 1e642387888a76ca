"""The MuJoCo Warp back-end, on Warp's CPU device, against the CPU engine.

MuJoCo Warp computes in float32 and has its own constraint solver, so a world agrees with the
CPU engine to a tolerance. float32 alone moves a cable's tension by about k x (rounding of
lengths near 0.2 m, ~1.5e-8 m) = 1.5e-5 N; what dominates is the contact solver: its forces
differ slightly, the bodies drift apart by ~1e-5 m in 1 s, and a 1000 N/m cable turns that into
~0.1 N. Measured over 1 s: 0.19 N (push) and 0.08 N (CPG gait) at most on 30 N tensions, peak
tensions within 0.08 N, the centre of mass within 2e-5 m. The tolerances below are about five
times those figures: loose enough for rounding and solver details, tight enough that a wrong
sign, a missed motor limit or a shifted V* row (several newtons) fails.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco_warp", reason="MuJoCo Warp (pip install 'tensim[gpu]') is not "
                    "installed")

from tensim.control import load_controller
from tensim.model import compile_structure
from tensim.models import preset
from tensim.sim import PhysicsScale, Trial, ramp_hold_release, run_batch

DURATION = 1.0  # s: MuJoCo Warp on the CPU device takes ~7 ms a step


def test_warp_worlds_agree_with_the_cpu_engine():
    p = preset("tetraspine3")
    structure = p.build()
    compiled = compile_structure(structure)
    gait = load_controller("tetraspine3_cpg", structure).with_duration(DURATION).build(
        compiled.model.opt.timestep)
    push = ramp_hold_release("s2_tip", (0.0, 1.0, 0.5), 8.0, 0.2, 0.3, 0.4, 0.1)
    trials = [Trial(p.controller(), loads=(push,)), Trial(gait),
              Trial(gait, physics=PhysicsScale(stiffness=1.1, friction=2.0)),
              Trial(gait, physics=PhysicsScale(mass=1.3))]
    warp = run_batch(compiled, trials, DURATION, backend="warp", device="cpu")
    cpu = run_batch(compiled, trials, DURATION)
    for w, c in zip(warp, cpu, strict=True):
        assert w.ok and c.ok, (w.error, c.error)
        a, b = c.result.trajectory, w.result.trajectory
        np.testing.assert_array_equal(a.time, b.time)
        assert np.abs(a.matrix("tension") - b.matrix("tension")).max() < 1.0
        assert np.abs(a.matrix("rest_length") - b.matrix("rest_length")).max() < 1e-3
        np.testing.assert_allclose(w.result.peak_tension, c.result.peak_tension, atol=0.5)
        # the kernel tracks the peak line speed and power too (measured: within 5.7e-6 m/s and
        # 0.006 W; a kernel that dropped either would read 0.07 m/s and ~1 W off)
        np.testing.assert_allclose(w.result.peak_speed, c.result.peak_speed, atol=3e-5)
        np.testing.assert_allclose(w.result.peak_power, c.result.peak_power, atol=0.03)
        for axis in "xyz":
            assert np.abs(a[f"pos_{axis}/com"] - b[f"pos_{axis}/com"]).max() < 1e-3
    # the per-world parameters took effect: the stiffer robot's tensions differ from the gait's
    stiff, nominal = warp[2].result.trajectory, warp[1].result.trajectory
    assert np.abs(stiff.matrix("tension") - nominal.matrix("tension")).max() > 1.0
    heavy = warp[3].result.trajectory  # masses, inertias and derived constants per world
    assert np.abs(heavy.matrix("tension") - nominal.matrix("tension")).max() > 1.0


def test_a_trial_with_its_own_compiled_model_runs_as_on_the_cpu_engine():
    # a recompiled structure (stiffer cables, heavier rods, more friction) of the same layout:
    # every field it changes, derived constants included, becomes a per-world field
    import dataclasses

    p = preset("tetraspine3")
    structure = p.build()
    compiled = compile_structure(structure)
    gait = load_controller("tetraspine3_cpg", structure).with_duration(DURATION).build(
        compiled.model.opt.timestep)
    changed = dataclasses.replace(
        structure,
        cables=tuple(dataclasses.replace(c, stiffness=1.1 * c.stiffness, pretension=None,
                                         rest_length=structure.rest_length(c))
                     for c in structure.cables),
        rods=tuple(dataclasses.replace(
            r, friction=1.5 * r.friction,
            linear_density=None if r.linear_density is None else 1.2 * r.linear_density,
            density=None if r.density is None else 1.2 * r.density) for r in structure.rods))
    own = compile_structure(changed)
    trials = [Trial(gait), Trial(gait, compiled=own)]
    warp = run_batch(compiled, trials, DURATION, backend="warp", device="cpu")
    cpu = run_batch(compiled, trials, DURATION)
    for w, c in zip(warp, cpu, strict=True):
        assert w.ok and c.ok, (w.error, c.error)
        a, b = c.result.trajectory, w.result.trajectory
        assert np.abs(a.matrix("tension") - b.matrix("tension")).max() < 1.0
        for axis in "xyz":
            assert np.abs(a[f"pos_{axis}/com"] - b[f"pos_{axis}/com"]).max() < 1e-3
    nominal, rebuilt = (r.result.trajectory for r in warp)
    assert np.abs(rebuilt.matrix("tension") - nominal.matrix("tension")).max() > 1.0


def test_inputs_held_on_the_device_are_reloaded_at_the_right_step(monkeypatch):
    # with room for one record interval of inputs, the rows are reloaded before every record;
    # a row taken from the wrong step (one early or late) would change the V* the motors see
    import tensim.sim._warp_inputs as held

    p = preset("tetraspine3")
    structure = p.build()
    compiled = compile_structure(structure)
    gait = load_controller("tetraspine3_cpg", structure).with_duration(0.3).build(
        compiled.model.opt.timestep)
    trials = [Trial(gait), Trial(gait, physics=PhysicsScale(friction=1.5))]
    whole = run_batch(compiled, trials, 0.3, backend="warp", device="cpu")
    monkeypatch.setattr(held, "INPUT_BYTES", 1)
    reloaded = run_batch(compiled, trials, 0.3, backend="warp", device="cpu")
    for a, b in zip(whole, reloaded, strict=True):
        assert a.ok and b.ok, (a.error, b.error)
        for channel in ("tension", "rest_length", "setpoint"):
            np.testing.assert_array_equal(a.result.trajectory.matrix(channel),
                                          b.result.trajectory.matrix(channel))


def test_learning_evaluates_a_generation_on_warp():
    from tensim.learn.executors import ThreadBatchExecutor
    from tensim.learn.families import default_base
    from tensim.learn.problem import TrialProblem

    structure = preset("tetraspine3").build()
    problem = TrialProblem(structure, default_base("tetraspine3", "cpg", structure), "cpg", 0.5)
    points = np.random.default_rng(1).random((3, problem.dimension))
    tasks = list(enumerate(points))
    cpu = sorted(ThreadBatchExecutor(problem, 1).run(tasks), key=lambda e: e.index)
    warp = sorted(ThreadBatchExecutor(problem, 1, engine="warp").run(tasks),
                  key=lambda e: e.index)
    for a, b in zip(cpu, warp, strict=True):
        assert b.status == "ok", b.reason
        assert b.score == pytest.approx(a.score, abs=2e-4)  # metres walked in 0.5 s


def test_warp_runs_dc_motors_as_the_cpu_engine():
    """A mass hanging from a DC-motor cable (actdim 3) that reels it up: the kernel's DC branch
    against the compiled law. No contacts, so only float32 rounding separates the two."""
    from tensim.model import WorldOptions
    from tensim.sim import Simulation
    from tensim.structure import Cable, DCMotor, Motor, Node, PointMass, Structure

    s = Structure("hanging", (Node("top", (0.0, 0.0, 2.0), fixed=True),
                              Node("bob", (0.0, 0.0, 1.4))),
                  cables=(Cable("c", ("top", "bob"), 500.0, damping=5.0, rest_length=0.55,
                                motor=Motor(max_tension=1e3, dc=DCMotor(stall_torque=0.3))),),
                  point_masses=(PointMass("bob", 1.0),))
    compiled = compile_structure(s, WorldOptions(ground=False))

    class ReelIn:
        def configure(self, sim: Simulation) -> None:
            sim.drive.rest_command[0] = 0.3

    duration = 0.5
    warp = run_batch(compiled, [Trial(ReelIn())], duration, backend="warp", device="cpu")[0]
    cpu = run_batch(compiled, [Trial(ReelIn())], duration)[0]
    assert warp.ok and cpu.ok, (warp.error, cpu.error)
    a, b = cpu.result.trajectory, warp.result.trajectory
    assert a["rest_length/c"][-1] < 0.53  # the spool did reel in (from 0.55 m)
    # float32 rounding only: measured 5.9e-7 m and 4.8e-4 N at most (of 25 N); about ten times
    np.testing.assert_allclose(b["rest_length/c"], a["rest_length/c"], atol=1e-5)
    np.testing.assert_allclose(b["tension/c"], a["tension/c"], atol=5e-3)


def test_loading_warp_keeps_its_start_up_banner_quiet():
    # the banner (devices, kernel cache folder) is logged at INFO: a command using the Warp
    # back-end prints only Warp's warnings
    import logging
    import subprocess
    import sys

    probe = ("import warp; warp.config.log_level = 10; "
             "from tensim.sim._warp_batch import warp_available; "
             "print(warp_available(), warp.config.log_level)")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["True", str(logging.WARNING)]


def test_a_diverging_world_is_reported_failed_and_the_others_run_on():
    # 10^4 times the cable stiffness: the explicit step diverges within a few steps, on MuJoCo
    # Warp (which does not check accelerations itself) as on the CPU engine
    p = preset("tetraspine3")
    compiled = compile_structure(p.build())
    trials = [Trial(p.controller()), Trial(p.controller(), physics=PhysicsScale(stiffness=1e4))]
    warp = run_batch(compiled, trials, 0.05, backend="warp", device="cpu")
    cpu = run_batch(compiled, trials, 0.05)
    for results in (warp, cpu):
        assert results[0].ok and not results[1].ok
        assert "unstable" in results[1].error and "non-finite acceleration" in results[1].error
    assert "reset" not in warp[1].error  # MuJoCo Warp keeps the state it reached
    assert np.isfinite(warp[0].result.trajectory.matrix("tension")).all()


@pytest.mark.parametrize("law", ["implicit", "implicitfast"])
def test_warp_runs_the_implicit_laws_as_the_cpu_engine(law):
    """Tetraspine3 pushed in free space under an implicit law: the kernel's pull and force and
    MuJoCo Warp's derivatives of the gain term against the CPU engine. Measured over 0.5 s:
    tensions within 0.014 N (implicit, as close as the explicit law's 0.037 N) and 0.32 N
    (implicitfast: the two engines keep different parts of a cable's damping between two free
    bodies, docs/architecture.md) of 24 N; the bounds are about five times those."""
    from tensim.model import WorldOptions

    p = preset("tetraspine3")
    world = WorldOptions(cable_law=law, timestep=0.002, ground=False, gravity=(0.0, 0.0, 0.0))
    compiled = compile_structure(p.build(), world)
    push = ramp_hold_release("s2_tip", (0.0, 1.0, 0.5), 8.0, 0.1, 0.1, 0.1, 0.1)
    trial = [Trial(p.controller(), loads=(push,))]
    (w,), (c,) = (run_batch(compiled, trial, 0.5, backend="warp", device="cpu"),
                  run_batch(compiled, trial, 0.5))
    assert w.ok and c.ok, (w.error, c.error)
    bound = {"implicit": 0.07, "implicitfast": 1.6}[law]
    a, b = c.result.trajectory.matrix("tension"), w.result.trajectory.matrix("tension")
    assert np.abs(a - b).max() < bound
    assert np.abs(a).max() > 20.0  # the push loads the cables


def test_held_inputs_give_each_step_its_own_row():
    import warp as wp

    from tensim.sim._warp_inputs import HeldInputs

    worlds, nu, steps = 3, 2, 7
    rows = (1000.0 * np.arange(worlds)[:, None, None] + 10.0 * np.arange(steps)[None, :, None]
            + np.arange(nu)[None, None, :])  # group w, step j, input u: 1000 w + 10 j + u
    with wp.ScopedDevice("cpu"):
        # worlds 0 and 3 share group 0's rows, world 2 has group 2's, world 1 group 1's
        group = np.array([0, 1, 2, 0])
        held = HeldInputs(group, nu, record_steps=1, total_steps=steps)
        assert held.next_rows(1) == steps  # everything the run needs fits: one load
        held.staging(steps)[:] = rows
        held.load(steps)
        ctrl = wp.zeros((len(group), nu), dtype=float)
        for j in range(steps):
            held.apply(ctrl)
            np.testing.assert_array_equal(ctrl.numpy(), rows[group, j])
        held.consumed(steps)
        assert held.left() == 0 and held.remaining == 0


def test_a_world_out_of_room_for_contacts_fails_with_a_message(monkeypatch):
    # MuJoCo Warp drops contacts past its allocation and steps on (wrong physics, a printed
    # warning): tensim fails such a world instead, saying what to raise
    import tensim.sim._warp_batch as warp_batch

    monkeypatch.setattr(warp_batch, "world_capacity", lambda model: (8, 1))
    p = preset("tetraspine3")
    compiled = compile_structure(p.build())  # stands on several feet: more than one contact
    result = run_batch(compiled, [Trial(p.controller())], 0.02, backend="warp", device="cpu")[0]
    assert not result.ok and "ran out of room for contacts" in result.error


def test_warp_runs_a_lagged_motor_as_the_cpu_engine():
    """A held cable let out under a first-order lag (Motor.lag_time): the kernel's lag against
    the compiled law; float32 rounding of rest lengths near 0.5 m is ~3e-8 m a step."""
    from tensim.control.rest import RestCommand
    from tensim.model import WorldOptions
    from tensim.structure import Cable, Motor, Node, Structure

    s = Structure("held", (Node("a", (0.0, 0.0, 1.0), fixed=True),
                           Node("b", (0.5, 0.0, 1.0), fixed=True)),
                  cables=(Cable("c", ("a", "b"), 100.0, rest_length=0.45,
                                motor=Motor(max_speed=10.0, lag_time=0.1)),))
    compiled = compile_structure(s, WorldOptions(ground=False))
    trial = [Trial(RestCommand(("c",), (0.55,)))]
    (w,), (c,) = (run_batch(compiled, trial, 0.3, backend="warp", device="cpu"),
                  run_batch(compiled, trial, 0.3))
    a, b = c.result.trajectory["rest_length/c"], w.result.trajectory["rest_length/c"]
    assert a[-1] > 0.5 and np.abs(a - b).max() < 1e-5


def test_warp_runs_a_pd_motor_as_the_cpu_engine():
    """A bob swinging on a tension-only PD servo (Motor.pd_stiffness): the kernel's servo
    against the compiled law. float32 rounding of lengths near 0.5 m (~3e-8 m) a step, grown
    by the lightly damped swing; a servo that pushed or ignored its target would be off by
    centimetres."""
    from tensim.control.rest import RestCommand
    from tensim.model import WorldOptions
    from tensim.structure import Cable, Motor, Node, PointMass, Structure

    s = Structure("bob", (Node("top", (0.0, 0.0, 2.0), fixed=True),
                          Node("bob", (0.0, 0.0, 1.5))),
                  cables=(Cable("c", ("top", "bob"), 100.0, rest_length=2.0,
                                motor=Motor(max_tension=30.0, pd_stiffness=400.0,
                                            pd_damping=8.0)),),
                  point_masses=(PointMass("bob", 1.0),))
    compiled = compile_structure(s, WorldOptions(ground=False, timestep=1e-3))
    trial = [Trial(RestCommand(("c",), (0.45,)))]
    (w,), (c,) = (run_batch(compiled, trial, 0.3, backend="warp", device="cpu"),
                  run_batch(compiled, trial, 0.3))
    a, b = c.result.trajectory["length/c"], w.result.trajectory["length/c"]
    assert a.min() < 0.48 and np.abs(a - b).max() < 1e-4
    ta, tb = c.result.trajectory["tension/c"], w.result.trajectory["tension/c"]
    assert ta.max() > 10.0 and np.abs(ta - tb).max() < 0.05  # 400 N/m x 1e-4 m


def test_per_world_fields_found_from_the_buffers_equal_a_field_by_field_comparison():
    """The fast search (one comparison of each model's whole buffer, mapped back to fields)
    finds exactly the fields a field-by-field comparison finds: one element changed in a
    random field of a random model, over many draws; and a model of other sizes is refused."""
    import copy

    from tensim.sim._warp_batch import per_world_fields

    compiled = compile_structure(preset("tetraspine3").build())
    batch = compiled.model
    per_world = ("body_mass", "geom_friction", "actuator_gainprm", "dof_damping",
                 "body_inertia", "tendon_stiffness", "geom_solref", "actuator_biasprm")
    rng = np.random.default_rng(3)
    for _ in range(20):
        models = [copy.copy(batch) for _ in range(5)]
        changed = set(rng.choice(per_world, size=rng.integers(1, 4), replace=False))
        for name in changed:
            a = getattr(models[rng.integers(5)], name).reshape(-1)
            a[rng.integers(a.size)] += 0.25
        reference = {name for name in dir(batch) if not name.startswith("_")
                     and isinstance(v := getattr(batch, name), np.ndarray)
                     and any(not np.array_equal(getattr(m, name), v) for m in models)}
        assert reference == changed
        assert set(per_world_fields(batch, models)) == changed
    assert per_world_fields(batch, [copy.copy(batch)]) == []
    # a field MuJoCo Warp holds once for all worlds is refused with its name and trial
    models = [copy.copy(batch), copy.copy(batch)]
    models[1].jnt_type[0] = 3
    with pytest.raises(ValueError, match=r"trial 1: .*jnt_type"):
        per_world_fields(batch, models)
    other = compile_structure(preset("prism3").build()).model
    with pytest.raises(ValueError, match="trial 0: its model differs in size"):
        per_world_fields(batch, [other])


def test_worlds_share_computed_inputs_only_where_their_plans_give_the_same_rows():
    """A batch computes the inputs of worlds on one gait once (InputPlan.sharing_key): equal
    keys for one gait under other physics, other keys for another gait, an added load or
    another rest-length command; and equal keys do give equal rows."""
    import copy

    from tensim.sim._trials import setup_trial

    p = preset("tetraspine3")
    structure = p.build()
    compiled = compile_structure(structure, load_nodes=("s2_tip",))
    dt = compiled.model.opt.timestep
    cpg = load_controller("tetraspine3_cpg", structure).with_duration(0.5)
    gait, other = cpg.build(dt), load_controller("tetraspine3_sine", structure) \
        .with_duration(0.5).build(dt)
    push = ramp_hold_release("s2_tip", (0.0, 1.0, 0.5), 8.0, 0.1, 0.1, 0.1, 0.1)
    trials = [Trial(gait), Trial(gait, physics=PhysicsScale(friction=1.5, stiffness=1.2)),
              Trial(other), Trial(gait, loads=(push,)), Trial(p.controller())]
    plans = [setup_trial(compiled, copy.copy(compiled.model), t, dt) for t in trials]
    keys = [plan.sharing_key() for plan in plans]
    assert keys[0] == keys[1]
    assert len({keys[0], keys[2], keys[3], keys[4]}) == 4
    np.testing.assert_array_equal(plans[0].control(7, 300), plans[1].control(7, 300))
    assert np.abs(plans[0].control(7, 300) - plans[2].control(7, 300)).max() > 1e-3


def test_stepping_ahead_while_the_host_stores_a_sample_changes_no_result(monkeypatch):
    """On a GPU the next record interval is launched before the host stores the last sample
    and checks the worlds (on copies taken with the sample). Run that way on Warp's CPU device,
    a batch with a gait, a push, another gait's friction and a diverging world gives exactly
    the results of stepping after the sample: every channel, peak, error and failure time."""
    import tensim.sim._warp_batch as warp_batch

    p = preset("tetraspine3")
    structure = p.build()
    compiled = compile_structure(structure)
    gait = load_controller("tetraspine3_cpg", structure).with_duration(0.5).build(
        compiled.model.opt.timestep)
    push = ramp_hold_release("s2_tip", (0.0, 1.0, 0.5), 8.0, 0.05, 0.1, 0.1, 0.1)
    trials = [Trial(gait), Trial(p.controller(), loads=(push,)),
              Trial(gait, physics=PhysicsScale(friction=2.0)),
              Trial(p.controller(), physics=PhysicsScale(stiffness=1e4))]
    after = run_batch(compiled, trials, 0.5, backend="warp", device="cpu")
    monkeypatch.setattr(warp_batch, "PIPELINE_ON_CPU", True)
    ahead = run_batch(compiled, trials, 0.5, backend="warp", device="cpu")
    assert [r.ok for r in after] == [True, True, True, False]
    for a, b in zip(after, ahead, strict=True):
        assert a.error == b.error
        if a.result is None:
            continue
        for channel in ("tension", "rest_length", "setpoint", "length"):
            np.testing.assert_array_equal(a.result.trajectory.matrix(channel),
                                          b.result.trajectory.matrix(channel))
        np.testing.assert_array_equal(a.result.trajectory["pos_x/com"],
                                      b.result.trajectory["pos_x/com"])
        np.testing.assert_array_equal(a.result.peak_tension, b.result.peak_tension)


def test_the_warp_benchmark_times_tensim_beside_mujoco_warp_alone():
    """bench --backend warp on Warp's CPU device: per batch size a tensim row whose figures
    are the steps it ran over its loop's time, with its share of MuJoCo Warp alone, then the
    MuJoCo Warp row it is divided by, then the CPU engine's row."""
    from tensim.benchmarks.warp import bench_warp, format_row

    report = bench_warp(worlds=(2,), duration=0.02, cases=("tetraspine3_cpg",), device="cpu",
                        cpu_trials=4)
    warp, alone, cpu = report["rows"]
    assert (warp["engine"], alone["engine"], cpu["engine"][:3]) == ("warp", "mjwarp", "cpu")
    steps = round(0.02 / 0.001)
    for row in (warp, alone):
        assert row["worlds"] == 2 and row["failed"] == 0
        assert row["steps_per_s"] * row["loop_s"] == pytest.approx(2 * steps)
    assert warp["of_alone"] == pytest.approx(alone["loop_s"] / warp["loop_s"])
    assert "of MuJoCo Warp alone" in format_row(warp)
