"""A tension-only PD on length (``Motor.pd_stiffness``/``pd_damping``), a lab's position
servo on a tendon whose force range lets it only pull, against closed forms: its static pull,
the damped response of a hanging mass, a slack servo; and the law's three bodies agreeing."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from tensim.model import WorldOptions, compile_structure
from tensim.model import _law_layout as layout
from tensim.sim import Simulation, cable_law, compiled_available
from tensim.structure import Cable, Motor, Node, PointMass, Structure, StructureError

BACKENDS = [
    "python",
    pytest.param("compiled", marks=pytest.mark.skipif(
        not compiled_available(), reason="compiled cable callback not built for this MuJoCo")),
]
DT = 1e-3  # s
KP, KD, CAP = 400.0, 8.0, 30.0  # N/m, N s/m, N


def _pd(**fields: float) -> Motor:
    return Motor(**{"max_tension": CAP, "pd_stiffness": KP, "pd_damping": KD, **fields})


def _held(law: str = "explicit"):
    """One PD cable between two world-fixed nodes 0.5 m apart; its spring (100 N/m, rest
    length 0.6 m) is slack, so every pull is the servo's."""
    s = Structure("held", (Node("a", (0.0, 0.0, 1.0), fixed=True),
                           Node("b", (0.5, 0.0, 1.0), fixed=True)),
                  cables=(Cable("c", ("a", "b"), 100.0, rest_length=0.6, motor=_pd()),))
    return compile_structure(s, WorldOptions(timestep=DT, ground=False, cable_law=law))


def test_the_servo_starts_relaxed_at_the_build_length_and_its_gains_have_their_slots():
    compiled = _held()
    m = compiled.model
    assert m.actuator_dynprm[0, layout.P_MODE] == layout.MODE_PD
    assert m.actuator_gainprm[0, layout.G_PD_STIFFNESS] == KP
    assert m.actuator_gainprm[0, layout.G_PD_DAMPING] == KD
    # the target starts at the build length (0.5 m), where the servo pulls nothing
    assert compiled.command[0] == pytest.approx(0.5, abs=1e-12)
    assert compiled.rest_length[0] == 0.6
    # or at its pd_target, pulling kp (0.5 - 0.47) = 12 N from the first step
    s = compiled.structure
    s = dataclasses.replace(s, cables=(dataclasses.replace(
        s.cables[0], motor=_pd(pd_target=0.47)),))
    with Simulation(compile_structure(s, compiled.world)) as sim:
        assert sim.drive.rest_command[0] == 0.47
        sim.step(1)
        assert sim.drive.tension[0] == pytest.approx(12.0, abs=1e-12)  # rounding of 0.03 m


@pytest.mark.parametrize("law", ["explicit", "implicit"])
@pytest.mark.parametrize("backend", BACKENDS)
def test_static_pull_is_kp_times_the_stretch_past_the_target_clamped(backend, law):
    """T = min(max(0, kp (x - L)), max_tension) on a held cable (x = 0.5 m, at rest): 20 N at
    L = 0.45 m, capped at 30 N at L = 0.4 m, nothing at L = 0.55 m (no push)."""
    with Simulation(_held(law), backend=backend) as sim:
        for target, expected in ((0.45, KP * 0.05), (0.4, CAP), (0.55, 0.0), (0.5, 0.0)):
            sim.drive.rest_command[0] = target
            sim.step(2)
            # rounding of 0.5 - L near 0.5 m, times 400 N/m
            assert sim.drive.tension[0] == pytest.approx(expected, abs=1e-12)
            assert sim.drive.applied[0] == pytest.approx(expected, abs=1e-12)
            assert sim.drive.rest[0] == 0.6  # the servo leaves the spring's rest length
            assert -sim.data.actuator_force[0] == pytest.approx(expected, abs=1e-12)


G, MASS, OFFSET = 9.81, 1.0, 0.01  # m/s^2, kg, m


def _hanging(law: str):
    s = Structure("bob", (Node("top", (0.0, 0.0, 2.0), fixed=True),
                          Node("bob", (0.0, 0.0, 1.5))),
                  cables=(Cable("c", ("top", "bob"), 100.0, rest_length=2.0, motor=_pd()),),
                  point_masses=(PointMass("bob", MASS),))
    return compile_structure(s, WorldOptions(timestep=DT, ground=False, cable_law=law))


@pytest.mark.parametrize("law", ["explicit", "implicit"])
@pytest.mark.parametrize("backend", BACKENDS)
def test_a_hanging_mass_follows_the_damped_second_order_solution(backend, law):
    """A 1 kg bob on a PD cable (its spring slack): with y = x - (L + m g / kp),
    m y'' = -kp y - kd y', an underdamped oscillator (w = 20 rad/s, zeta = 0.2), started
    1 cm below the target's equilibrium at rest. The pull stays within 9.81 +- 5.6 N: never
    clamped. The first step still holds the build target (the simulation's time convention:
    the command set before a run acts from the second step), so the bob falls freely for one
    step, then y(t) = e^(-zeta w s) (y1 cos wd s + (v1 + zeta w y1) / wd sin wd s), s = t - dt.
    The semi-implicit Euler recursion of the same law is matched to rounding."""
    target = 0.5 - MASS * G / KP - OFFSET
    with Simulation(_hanging(law), backend=backend, record_dt=DT) as sim:
        sim.drive.rest_command[0] = target
        ts = sim.run(1.0)
    length = ts["length/c"]
    # the discrete flow: v += dt (g - T / m), x += dt v, T = kp (x - L) + kd v
    x, v, flow = 0.5, 0.0, [0.5]
    for n in range(len(length) - 1):
        pull = KP * (x - (0.5 if n == 0 else target)) + KD * v
        v += DT * (G - max(pull, 0.0) / MASS)
        x += DT * v
        flow.append(x)
    # rounding of ~1000 steps' lengths near 0.5 m
    np.testing.assert_allclose(length, flow, rtol=0, atol=1e-12)
    w, zeta = np.sqrt(KP / MASS), KD / (2 * np.sqrt(KP * MASS))
    wd = w * np.sqrt(1 - zeta**2)
    y1, v1, s = 0.5 + G * DT * DT - (target + MASS * G / KP), G * DT, ts.time - DT
    y = np.exp(-zeta * w * s) * (y1 * np.cos(wd * s) + (v1 + zeta * w * y1) / wd * np.sin(wd * s))
    # the exact flow: semi-implicit Euler at 1 ms is off by a phase and decay error of order
    # w dt = 0.02 of the 1 cm swing
    np.testing.assert_allclose(length[1:], (target + MASS * G / KP + y)[1:], rtol=0, atol=2e-4)
    assert np.ptp(length[500:]) < 0.2 * np.ptp(length[:500])  # it does decay
    assert ts["tension/c"][1:].min() > 3.0  # never slack, never clamped


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_slack_servo_pulls_nothing_even_while_the_cable_shortens(backend):
    """The bob is thrown up at 1 m/s with the target 40 cm beyond the length: kp (x - L) < 0
    and the cable shortens, so the servo (and the slack spring) pull nothing, and the bob
    flies freely: after n steps z = z0 + v0 n dt - g dt^2 n (n + 1) / 2 (semi-implicit
    Euler's free flight)."""
    v0 = 1.0  # m/s
    with Simulation(_hanging("explicit"), backend=backend) as sim:
        sim.drive.rest_command[0] = 0.9
        z0 = sim.data.qpos[2]
        sim.data.qvel[2] = v0
        for _ in range(100):
            sim.step(1)
            assert sim.drive.applied[0] == 0.0 and sim.data.actuator_force[0] == 0.0
        n = 100
        # rounding of ~100 steps' positions near 1.5 m
        assert sim.data.qpos[2] == pytest.approx(z0 + v0 * n * DT - G * DT * DT * n * (n + 1) / 2,
                                                 abs=1e-12)


def _mixed():
    """A 3-bar's worth of cables in a loop of free point masses: every other cable a servo."""
    from tensim.models import preset

    s = preset("tetraspine3").build()
    return dataclasses.replace(s, cables=tuple(
        dataclasses.replace(c, motor=dataclasses.replace(
            c.motor, pd_stiffness=300.0 + 10 * k, pd_damping=2.0)) if k % 2 else c
        for k, c in enumerate(s.cables)))


@pytest.mark.parametrize("law", ["explicit", "implicit"])
@pytest.mark.skipif(not compiled_available(), reason="compiled cable callback not built")
def test_compiled_law_equals_the_reference_with_pd_motors(law):
    """For random states (lengths, rates, targets on both sides of the length), the compiled
    callbacks write exactly the reference law's act_dot and actuator force."""
    compiled = compile_structure(_mixed(), WorldOptions(cable_law=law))
    m, n = compiled.model, compiled.n_cables
    pd = m.actuator_dynprm[:n, layout.P_MODE] == layout.MODE_PD
    assert pd.sum() == n // 2
    rng = np.random.default_rng(5)
    with Simulation(compiled) as sim:
        d, rest = sim.data, compiled.index.rest_act
        for trial in range(20):
            d.qvel[:] = rng.normal(0, 0.5, m.nv)
            d.act[rest] = compiled.rest_length * rng.uniform(0.8, 1.2, n)
            d.ctrl[:n] = compiled.command * rng.uniform(0.8, 1.2, n)
            mujoco.mj_forward(m, d)
            rates = cable_law(m, d)
            assert np.abs(rates.force[pd]).max() > 0, trial  # the servos do pull
            np.testing.assert_array_equal(d.act_dot[rest], rates.rest_rate)
            np.testing.assert_array_equal(d.act_dot[rest + 1], rates.peak_rate)
            np.testing.assert_array_equal(d.actuator_force[:n], rates.force)
            assert np.all(rates.rest_rate[pd] == 0.0)  # a servo leaves its rest length


def test_pd_options_are_validated_and_survive_the_structure_file(tmp_path):
    from tensim.structure import load_structure, save_structure

    for fields, words in (({"pd_stiffness": -1.0}, "pd_stiffness must be >= 0"),
                          ({"pd_damping": 2.0}, "needs pd_stiffness > 0"),
                          ({"pd_target": 0.4}, "needs pd_stiffness > 0"),
                          ({"pd_stiffness": 1.0, "pd_target": 0.0}, "pd_target must be > 0"),
                          ({"pd_stiffness": 10.0, "lag_time": 0.1}, "takes no lag_time"),
                          ({"pd_stiffness": 10.0, "saturate": True}, "takes no saturate")):
        with pytest.raises(StructureError, match=words):
            Motor(**fields)  # type: ignore[arg-type]
    for motor, written in ((_pd(), True), (Motor(), False)):
        s = dataclasses.replace(_held().structure, cables=(dataclasses.replace(
            _held().structure.cables[0], motor=motor),))
        save_structure(s, tmp_path / "s.yaml")
        assert ("pd_stiffness" in (tmp_path / "s.yaml").read_text()) is written
        assert load_structure(tmp_path / "s.yaml") == s


def test_the_step_bound_counts_the_servo():
    """The bob's only stiffness is the servo's (its spring is slack): the bound of the
    linearised Euler step is that of m x'' = -kp x - kd x', near 2 / w = 0.1 s
    (w = 20 rad/s; the damping lowers it a little), and no bound without the servo."""
    from tensim.design import stable_timestep, stiffness

    s = _hanging("explicit").structure
    bound = float(stable_timestep(stiffness(s, count=False))[0])
    assert 0.07 < bound < 0.1
    slack = dataclasses.replace(s, cables=(dataclasses.replace(s.cables[0], motor=Motor()),))
    assert not np.isfinite(float(stable_timestep(stiffness(slack, count=False))[0]))
