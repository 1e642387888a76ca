"""The implicit cable laws against closed forms: a point mass on one stiff, damped cable.

Under ``cable_law="implicitfast"`` MuJoCo's ``implicitfast`` integrator takes each taut cable's
damping implicitly: with the cable's force f(y, v) = -k y - b v about the static stretch, one
step is (m + h b) (v' - v) = h f(y, v), y' = y + h v'. Under ``"implicit"`` MuJoCo's
``discrete`` integrator is handed half of the stiffness and damping (the pull is -1/2), a
trapezoidal step: (m + (h b + h^2 k) / 2) (v' - v) = h (f(y, v) - h k v / 2). Both maps are
linear, so their period, decay and fixed point follow from a 2 x 2 matrix; the runs must follow
them to rounding, and the maps approach the continuous oscillator as h shrinks (first order:
MuJoCo moves the positions by h v'; for the damper alone the half share is the trapezoidal
rule, second order, which is what strongly damped cables gain).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tensim.control import load_controller
from tensim.model import WorldOptions, compile_structure
from tensim.models import preset
from tensim.sim import (
    PhysicsScale,
    Simulation,
    SimulationError,
    Trial,
    compiled_available,
    ramp_hold_release,
    run_batch,
    simulate,
)
from tensim.structure import Cable, Node, PointMass, Structure

G = 9.81
# a lab's stiff cable on a 4 kg body: w0 = 50 rad/s; damping ratio 0.75 (B) or 2.5 (B_LAB)
MASS, K, B, B_LAB, REST, TOP = 4.0, 1e4, 300.0, 1000.0, 0.5, 2.0
STATIC = MASS * G / K  # static stretch [m]
LAWS = ["implicitfast", "implicit"]
BACKENDS = [
    "python",
    pytest.param("compiled", marks=pytest.mark.skipif(
        not compiled_available(), reason="compiled cable callback not built for this MuJoCo")),
]


def _hanging(law: str, dt: float, damping: float = B, below: float = 0.01, rest: float = REST):
    """A bob hanging from a fixed anchor, released from rest ``below`` [m] under equilibrium."""
    s = Structure(
        "bob",
        (Node("top", (0.0, 0.0, TOP), fixed=True),
         Node("bob", (0.0, 0.0, TOP - (REST + STATIC + below)))),
        cables=(Cable("c", ("top", "bob"), K, damping=damping, rest_length=rest),),
        point_masses=(PointMass("bob", MASS),),
    )
    return compile_structure(s, WorldOptions(timestep=dt, ground=False, cable_law=law))


def _step_matrix(law: str, dt: float, damping: float) -> np.ndarray:
    """The linear map (y, v) -> (y', v') of one step of the law's integrator."""
    theta = 0.5 if law == "implicit" else 1.0  # the share of k and b taken implicitly
    stiff = K * dt * dt if law == "implicit" else 0.0
    lag = dt * K if law == "implicit" else 0.0  # the linearised spring's h k v
    inertia = MASS + theta * (dt * damping + stiff)
    velocity = np.array([-dt * K, inertia - dt * (damping + theta * lag)]) / inertia
    return np.array([[1.0, 0.0], [0.0, 0.0]]) + np.outer([dt, 1.0], velocity)


def _simulated_offset(law: str, dt: float, duration: float, damping: float = B,
                      backend: str = "auto") -> np.ndarray:
    ts = simulate(_hanging(law, dt, damping), duration, record_dt=dt, backend=backend).trajectory
    return ts["pos_z/bob"] - (TOP - REST - STATIC)


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("dt", [0.004, 0.01])
@pytest.mark.parametrize("damping", [B, B_LAB])
def test_a_run_is_the_implicit_step_map(law, dt, damping):
    y = _simulated_offset(law, dt, 0.6, damping)
    state, predicted = np.array([y[0], 0.0]), [y[0]]
    step = _step_matrix(law, dt, damping)
    for _ in range(len(y) - 1):
        state = step @ state
        predicted.append(state[0])
    # the same arithmetic in another order: rounding of 1e-2 m offsets, ~1e-16 a step
    np.testing.assert_allclose(y, predicted, rtol=0, atol=1e-11)


@pytest.mark.parametrize("law", LAWS)
def test_period_and_decay_at_long_steps_approach_the_oscillator(law):
    """The map's eigenvalues give the period and decay of the run (the run shows the same
    period); the continuous oscillator's are 2 pi / w_d and b / 2m. The maps' errors are first
    order in the step."""
    w_d = np.sqrt(K / MASS - (B / (2 * MASS)) ** 2)
    errors = {}
    for dt in (0.004, 0.002, 0.001):
        eig = np.linalg.eigvals(_step_matrix(law, dt, B))[0]
        period, decay = 2 * np.pi * dt / abs(np.angle(eig)), -np.log(abs(eig)) / dt
        errors[dt] = (period / (2 * np.pi / w_d) - 1, decay / (B / (2 * MASS)) - 1)
        # the run shows the same period: zero crossings of the offset, 1 ms samples
        y = _simulated_offset(law, dt, 0.5)
        i = np.nonzero(np.sign(y[:-1]) != np.sign(y[1:]))[0]
        t = (i - y[i] / (y[i + 1] - y[i])) * dt
        np.testing.assert_allclose(2 * np.diff(t), period, rtol=2e-3)  # linear interpolation
    # the decay's error is first order: halving the step halves it (to within a fifth); the
    # period's shrinks too
    for (a, b) in ((0.004, 0.002), (0.002, 0.001)):
        assert 1.6 < errors[a][1] / errors[b][1] < 2.4, (law, errors)
        assert abs(errors[a][0]) > abs(errors[b][0]), (law, errors)
    # at 4 ms (w0 h = 0.2): implicitfast's period is 1.1 % short and its decay 12.5 % slow;
    # the discrete integrator's half-implicit spring makes the period 9.7 % long, the decay
    # 6.5 % fast (all of it implicit, as backward Euler: 15.5 % long, 2.4 % slow)
    bound = {"implicitfast": (0.015, 0.16), "implicit": (0.11, 0.075)}[law]
    assert abs(errors[0.004][0]) < bound[0] and abs(errors[0.004][1]) < bound[1], errors


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("backend", BACKENDS)
def test_a_lab_cable_settles_at_its_static_stretch_at_10_ms(law, backend):
    """Damping 1000 N s/m on 4 kg: the explicit law's Euler step is unstable at 10 ms (h b / m =
    2.5 > 2); the implicit ones settle, overdamped, at m g / k below the rest length (the
    map's fixed point, whatever the step), holding m g."""
    ts = simulate(_hanging(law, 0.01, B_LAB), 3.0, record_dt=0.01, backend=backend).trajectory
    y = ts["pos_z/bob"] - (TOP - REST - STATIC)
    assert np.all(np.diff(y) >= -1e-12) and abs(y[-1]) < 1e-9  # no overshoot: overdamped
    np.testing.assert_allclose(ts["applied/c"][-100:], MASS * G, rtol=1e-6)
    # the explicit law rings at the step frequency instead (the tension-only clamp holds the
    # blow-up, the applied force flips between 0 and about 2 m g every other step): the run
    # stops and names the cable and a step that holds it
    with pytest.raises(SimulationError, match=r"cable 'c' rings at the step frequency, its "
                       r"tension jumping between 0 and .* Use --dt"):
        simulate(_hanging("explicit", 0.01, B_LAB), 3.0, record_dt=0.01)


@pytest.mark.parametrize("law", ["explicit", *LAWS])
@pytest.mark.parametrize("backend", BACKENDS)
def test_a_slack_cable_neither_pushes_nor_damps(law, backend):
    """A bob thrown down from above its anchor's reach: the cable is slack (x < l) and
    lengthening fast, b v > k (l - x), so a damper acting while slack would pull. It must not:
    the cable's force is exactly 0 and the bob falls as it would with no cable at all."""
    dt = 0.004
    compiled = _hanging(law, dt, B_LAB, rest=REST + STATIC + 0.05)  # 4 cm slack at the start
    bare = compile_structure(Structure("free", compiled.structure.nodes,
                                       point_masses=compiled.structure.point_masses),
                             WorldOptions(timestep=dt, ground=False, cable_law=law))
    runs = []
    for model in (compiled, bare):
        with Simulation(model, backend=backend, record_dt=dt) as sim:
            sim.data.qvel[2] = -1.0  # m/s downward: the cable lengthens at 1 m/s
            z = []
            for _ in range(6):  # 24 ms: 2.2 cm further, still slack
                sim.step(1)
                z.append(sim.data.qpos[2])
                if model is compiled:
                    assert sim.data.actuator_force[0] == 0.0
                    assert sim.drive.tension[0] == 0.0
            runs.append(np.array(z))
    assert B_LAB * 1.0 > K * 0.04  # a damper would pull at first: 1000 N against 400 N
    np.testing.assert_array_equal(runs[0], runs[1])


# -- the bodies of the law agree, and a batch equals its single runs --------------------------

@pytest.mark.skipif(not compiled_available(), reason="compiled cable callback not built")
@pytest.mark.parametrize("law", LAWS)
def test_compiled_law_matches_the_reference_on_a_robot(law):
    """Tetraspine3 under its impedance controller with a push, on the ground: the compiled law
    and the Python reference agree as under the explicit law (tests/test_drive.py: 1e-9 of
    each signal; differences in a law show at 1e-4 or more)."""
    p = preset("tetraspine3")
    assert_compiled_matches_python(compile_structure(p.build(), WorldOptions(cable_law=law)))


def assert_compiled_matches_python(compiled) -> None:
    """Tetraspine3 ``compiled`` (any law) pushed for 1 s under its impedance controller: the
    compiled law's tensions, lengths, rest lengths and path equal the Python reference's to
    1e-9 of each signal, and the push moved it."""
    p = preset("tetraspine3")
    push = ramp_hold_release("s2_tip", (0.0, 1.0, 0.5), 8.0, 0.2, 0.3, 0.4, 0.3)
    a, b = (simulate(compiled, 1.0, controller=p.controller(), loads=(push,), backend=backend)
            for backend in ("compiled", "python"))
    for q in ("tension", "length", "rest_length", "pos_y"):
        x, y = a.trajectory.matrix(q), b.trajectory.matrix(q)
        assert np.abs(x - y).max() <= 1e-9 * np.abs(x).max(), q
    assert np.ptp(a.trajectory["pos_y/com"]) > 1e-3  # the push moved it


@pytest.mark.parametrize("law", LAWS)
def test_each_batch_trial_equals_its_single_run_bit_for_bit(law):
    p = preset("tetraspine3")
    structure = p.build()
    compiled = compile_structure(structure, WorldOptions(cable_law=law, timestep=0.002))
    gait = load_controller("tetraspine3_cpg", structure).with_duration(1.0).build(0.002)
    push = ramp_hold_release("s2_tip", (0.0, 1.0, 0.5), 8.0, 0.2, 0.3, 0.4, 0.3)
    cases = [Trial(gait), Trial(p.controller(), loads=(push,)),
             Trial(gait, physics=PhysicsScale(stiffness=1.2, damping=0.5))]
    results = run_batch(compiled, cases, 1.0, threads=2)
    for case, trial in zip(cases, results, strict=True):
        assert trial.ok, trial.error
        own = compiled if case.physics == PhysicsScale() else compile_structure(
            _scaled(structure, 1.2, 0.5), compiled.world)
        single = simulate(own, 1.0, controller=case.controller, loads=case.loads)
        for name, values in single.trajectory.channels.items():
            np.testing.assert_array_equal(values, trial.result.trajectory[name], err_msg=name)
        np.testing.assert_array_equal(single.peak_tension, trial.result.peak_tension)


def _scaled(structure: Structure, stiffness: float, damping: float) -> Structure:
    """The robot rebuilt with scaled cables (rest lengths kept as built)."""
    return dataclasses.replace(structure, cables=tuple(
        dataclasses.replace(c, stiffness=c.stiffness * stiffness, damping=c.damping * damping,
                            pretension=None, rest_length=structure.rest_length(c))
        for c in structure.cables))


def test_the_cable_law_is_chosen_on_the_command_line_and_kept_by_the_run_folder(tmp_path):
    import json

    import mujoco

    from tensim.cli import main
    from tensim.model._law_layout import law_of
    from tensim.viz.replay import load_run

    out = tmp_path / "run"
    assert main(["--quiet", "simulate", "prism3", "--cable-law", "implicit", "--dt", "0.004",
                 "--duration", "0.2", "--record-dt", "0.02", "--no-figures",
                 "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["cable_law"] == "implicit" and summary["dt_s"] == 0.004
    model = load_run(out).compiled.model
    assert law_of(model, 9) == "implicit"
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_DISCRETE
    with pytest.raises(ValueError, match="cable_law must be one of"):
        WorldOptions(cable_law="backward")
