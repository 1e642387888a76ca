"""The DC-motor cable drive against closed-form motor mechanics, and the compiled law against
the reference on models that mix DC and kinematic motors.

In cable coordinates the spool obeys M ds/dt = T + F_s (u - s / v0) - c s - F_c sgn(s), with
F_s = stall torque / R, v0 = no-load speed x R, M = J / R^2 (tensim.structure.DCMotor.line).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from tensim.model import WorldOptions, compile_structure
from tensim.model._law_layout import A_PEAK_POWER, A_PEAK_SPEED, A_SPEED, ACTDIM, DC_ACTDIM
from tensim.models import preset
from tensim.sim import PhysicsScale, Simulation, Trial, cable_law, compiled_available, run_batch
from tensim.sim._laws import dc_drive, dc_motor_speed
from tensim.structure import (
    Cable,
    DCMotor,
    Motor,
    Node,
    Structure,
    StructureError,
    structure_from_dict,
    structure_to_dict,
)

BACKENDS = [
    "python",
    pytest.param("compiled", marks=pytest.mark.skipif(
        not compiled_available(), reason="compiled cable callback not built for this MuJoCo")),
]
DT = 1e-3
# a spool of 1 cm: stall force 50 N, no-load line speed 0.1 m/s, reflected mass 5 kg
MOTOR = DCMotor(spool_radius=0.01, stall_torque=0.5, no_load_speed=10.0, rotor_inertia=5e-4,
                viscous_friction=0.0, coulomb_friction=0.0)
F_S, V0, M = 50.0, 0.1, 5.0


def _speed(steps: int, tension: float, drive: float, motor: DCMotor = MOTOR,
           speed: float = 0.0, back_drivable: bool = True) -> np.ndarray:
    """The line speed after each of ``steps`` law steps under a constant tension and drive."""
    line = motor.line()
    out = np.empty(steps)
    s = np.array([speed])
    for i in range(steps):
        s = dc_motor_speed(s, np.array([drive]), np.array([tension]),
                           np.array([line["stall_force"]]),
                           np.array([line["no_load_line_speed"]]), np.array([line["mass"]]),
                           np.array([line["viscous"]]), np.array([line["coulomb"]]),
                           np.array([1.0 if back_drivable else 0.0]), DT)
        out[i] = s[0]
    return out


def test_line_coordinates():
    line = MOTOR.line()
    assert line["stall_force"] == pytest.approx(F_S)
    assert line["no_load_line_speed"] == pytest.approx(V0)
    assert line["mass"] == pytest.approx(M)


@pytest.mark.parametrize("load", [0.0, 10.0, 35.0])
@pytest.mark.parametrize("viscous", [0.0, 2e-4])
def test_steady_speed_under_load_follows_the_torque_speed_curve(load, viscous):
    motor = dataclasses.replace(MOTOR, viscous_friction=viscous)
    c = viscous / 0.01**2  # N s/m
    s = _speed(3000, load, -1.0, motor)  # reeling in at full voltage against the load
    # 0 = T - F_s - (F_s / v0 + c) s: with c = 0 the no-load speed x (1 - load / stall)
    expected = (load - F_S) / (F_S / V0 + c)
    if viscous == 0.0:
        assert expected == pytest.approx(-V0 * (1 - load / F_S))
    # the backward-Euler step's fixed point is the exact steady state (rounding only)
    assert s[-1] == pytest.approx(expected, rel=1e-12)


def test_time_constant_is_inertia_times_resistance_over_kt_ke():
    # a motor given by its constants: K_t = K_e = 0.02 N m/A, 2 ohm, 12 V, 100:1, rotor 2e-6
    kt, resistance, volts, ratio, rotor = 0.02, 2.0, 12.0, 100.0, 2e-6
    motor = DCMotor.from_constants(kt, resistance, volts, ratio, spool_radius=0.01,
                                   rotor_inertia=rotor * ratio**2, coulomb_friction=0.0)
    tau = rotor * resistance / (kt * kt)  # J R / (K_t K_e) = 10 ms
    v0 = motor.line()["no_load_line_speed"]
    s = _speed(200, 0.0, 1.0, motor)  # from rest, full voltage, no load
    # backward Euler: s_n = v0 (1 - r^n), r = 1 / (1 + dt / tau), exactly
    n = np.arange(1, 201)
    np.testing.assert_allclose(s, v0 * (1 - (1 / (1 + DT / tau)) ** n), rtol=1e-12)
    # against the continuous exp(-t / tau): the step's error is O(dt / tau) = 10 %
    np.testing.assert_allclose(s, v0 * (1 - np.exp(-n * DT / tau)), atol=0.05 * v0)
    # the time to 63 % of the no-load speed is tau, to the step's O(dt / 2 tau) = 5 %
    t63 = np.interp((1 - np.exp(-1)) * v0, s, n * DT)
    assert t63 == pytest.approx(tau, rel=0.06)


def test_stall_and_back_driving():
    # a tension above stall force: a back-drivable spool pays out against the full voltage
    s = _speed(3000, 80.0, -1.0)
    assert s[-1] == pytest.approx(V0 * (80.0 / F_S - 1.0), rel=1e-12)  # > 0: paying out
    # a worm gear holds it, exactly
    assert np.all(_speed(3000, 80.0, -1.0, back_drivable=False) == 0.0)
    # ... while it still reels in below stall, at the same speed as a back-drivable spool
    np.testing.assert_array_equal(_speed(500, 20.0, -1.0, back_drivable=False),
                                  _speed(500, 20.0, -1.0))
    # ... and with no drive does not move under any tension
    assert np.all(_speed(100, 30.0, 0.0, back_drivable=False) == 0.0)


def test_coulomb_friction_holds_then_slips():
    motor = dataclasses.replace(MOTOR, coulomb_friction=0.1)  # F_c = 10 N
    # the net force 5 N (tension 5 N, no drive) is within F_c: the spool sticks, exactly
    assert np.all(_speed(100, 5.0, 0.0, motor) == 0.0)
    # 15 N is not: it slips, and settles where 15 - F_c = (F_s / v0) s
    s = _speed(3000, 15.0, 0.0, motor)
    assert s[-1] == pytest.approx((15.0 - 10.0) / (F_S / V0), rel=1e-12)


def test_position_loop_saturates_at_the_documented_error():
    # full voltage at an error of v0 t_p = 0.1 m/s x 0.05 s = 5 mm
    rest = np.zeros(5)
    target = np.array([-0.02, -0.005, 0.0025, 0.005, 0.02])
    u = dc_drive(rest, target, np.full(5, V0), np.full(5, 0.05))
    np.testing.assert_allclose(u, [-1.0, -1.0, 0.5, 1.0, 1.0])


# -- in a simulation ------------------------------------------------------------------------


def _held(motor: Motor, pretension: float = 5.0) -> object:
    """One cable between two world-fixed nodes 0.5 m apart (k = 100 N/m)."""
    s = Structure(
        "held",
        (Node("a", (0.0, 0.0, 1.0), fixed=True), Node("b", (0.5, 0.0, 1.0), fixed=True)),
        cables=(Cable("c", ("a", "b"), 100.0, pretension=pretension, motor=motor),),
    )
    return compile_structure(s, WorldOptions(ground=False))


def _stall_approach(t: np.ndarray, start: float, stall: float = F_S) -> np.ndarray:
    """Tension of the held cable (k = 100 N/m) under full reel-in voltage: dT/dt = -k s with
    the quasi-static s = v0 (T / F_s - 1), so T - F_s decays at the rate k v0 / F_s."""
    return stall + (start - stall) * np.exp(-100.0 * V0 / stall * t)


@pytest.mark.parametrize("backend", BACKENDS)
def test_reeling_in_slows_along_the_torque_speed_curve_toward_stall(backend):
    compiled = _held(Motor(max_tension=1e3, dc=MOTOR))
    with Simulation(compiled, backend=backend) as sim:
        sim.drive.rest_command[0] = 0.05  # far below anything reachable: full voltage
        ts = sim.run(6.0)
    tension, t = ts["tension/c"], ts.time
    # the spool's inertia (tau = M v0 / F_s = 10 ms) makes it lag the quasi-static speed:
    # about dT/dt x tau <= k v0 x 10 ms = 0.1 N
    late = t > 0.1
    np.testing.assert_allclose(tension[late], _stall_approach(t[late], tension[0]), atol=0.15)
    assert tension.max() < F_S  # it never pulls past stall


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_cable_above_stall_drives_the_spool_back_unless_worm_geared(backend):
    # 40 N pretension, more than the 20 N the motor holds
    weak = dataclasses.replace(MOTOR, stall_torque=0.2)
    free = _held(Motor(max_tension=1e3, dc=weak), pretension=40.0)
    worm = _held(Motor(max_tension=1e3, dc=dataclasses.replace(weak, back_drivable=False)),
                 pretension=40.0)
    with Simulation(free, backend=backend) as sim:
        sim.drive.rest_command[0] = 0.05
        pulled = sim.run(3.0)
    with Simulation(worm, backend=backend) as sim:
        sim.drive.rest_command[0] = 0.05
        held = sim.run(3.0)
    # back-driven against the full voltage: the spool pays out, the tension falls to stall
    assert np.all(np.diff(pulled["rest_length/c"]) > 0)
    # lagging by the spool's tau = M v0 / F_s = 25 ms: dT/dt x tau <= k v0 x 25 ms = 0.25 N
    t = pulled.time
    np.testing.assert_allclose(pulled["tension/c"][t > 0.1], _stall_approach(
        t[t > 0.1], pulled["tension/c"][0], 20.0), atol=0.35)
    # the worm gear holds the rest length, exactly (the motor cannot reel in either)
    assert np.all(held["rest_length/c"] == held["rest_length/c"][0])


def _mixed(structure: Structure) -> Structure:
    """Every other cable with a DC motor."""
    return dataclasses.replace(structure, cables=tuple(
        dataclasses.replace(c, motor=dataclasses.replace(c.motor, dc=DCMotor(
            stall_torque=0.3, coulomb_friction=0.005)))
        if k % 2 else c for k, c in enumerate(structure.cables)))


@pytest.mark.skipif(not compiled_available(), reason="compiled cable callback not built")
def test_compiled_law_equals_the_reference_with_dc_motors():
    """For random states of a robot whose cables alternate DC and kinematic motors, the
    compiled callbacks write the act_dot and actuator force of tensim.sim.cable_law."""
    p = preset("tetraspine3")
    compiled = compile_structure(_mixed(p.build()))
    m = compiled.model
    assert list(m.actuator_actnum[:4]) == [ACTDIM, DC_ACTDIM, ACTDIM, DC_ACTDIM]
    rng = np.random.default_rng(11)
    with Simulation(compiled, controller=p.controller()) as sim:
        d, n, rest = sim.data, compiled.n_cables, compiled.index.rest_act
        dc = m.actuator_actnum[:n] == DC_ACTDIM
        for trial in range(20):
            sim.drive.mode[:] = rng.integers(0, 2, n)
            d.qvel[:] = rng.normal(0, 0.5, m.nv)
            d.act[rest] = compiled.rest_length * rng.uniform(0.8, 1.2, n)
            d.act[rest + 1] = rng.uniform(0, 30, n)
            d.act[rest[dc] + A_SPEED] = rng.normal(0, 0.05, dc.sum())
            d.act[rest + A_PEAK_SPEED] = rng.uniform(0, 0.1, n)  # m/s
            d.act[rest + A_PEAK_POWER] = rng.uniform(0, 1.0, n)  # W
            d.ctrl[:n] = np.where(sim.drive.mode == 1, rng.normal(0, 0.05, n),
                                  compiled.rest_length * rng.uniform(0.8, 1.2, n))
            mujoco.mj_forward(m, d)
            rates = cable_law(m, d)
            assert np.abs(rates.speed_rate[dc]).max() > 0, trial  # the spools do accelerate
            np.testing.assert_array_equal(d.act_dot[rest], rates.rest_rate)
            np.testing.assert_array_equal(d.act_dot[rest + 1], rates.peak_rate)
            np.testing.assert_array_equal(d.act_dot[rest[dc] + A_SPEED], rates.speed_rate[dc])
            np.testing.assert_array_equal(d.act_dot[rest + A_PEAK_SPEED], rates.peak_speed_rate)
            np.testing.assert_array_equal(d.act_dot[rest + A_PEAK_POWER], rates.peak_power_rate)
            np.testing.assert_array_equal(d.actuator_force[:n], rates.force)


def test_physics_scale_equals_a_recompiled_motor():
    """run_batch's motor multipliers give the run of the structure with those motors."""
    p = preset("tetraspine3")
    structure = _mixed(p.build())
    compiled = compile_structure(structure)
    scaled = dataclasses.replace(structure, cables=tuple(
        dataclasses.replace(c, motor=dataclasses.replace(c.motor, dc=dataclasses.replace(
            c.motor.dc, stall_torque=0.6 * c.motor.dc.stall_torque,
            rotor_inertia=2.0 * c.motor.dc.rotor_inertia)))
        if c.motor.dc else c for c in structure.cables))
    runs = run_batch(compiled, [
        Trial(p.controller(), physics=PhysicsScale(motor_stall=0.6, motor_inertia=2.0)),
        Trial(p.controller(), compiled=compile_structure(scaled)),
        Trial(p.controller())], 0.5)
    a, b, nominal = (r.result.trajectory.matrix("tension") for r in runs)
    # the same law on parameters that differ by the rounding of 0.6 x (0.3 / 0.01)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-6)
    assert np.abs(a - nominal).max() > 0.1  # and the multipliers do change the run


def test_yaml_round_trip_and_clear_errors():
    structure = _mixed(preset("tetraspine3").build())
    assert structure_from_dict(structure_to_dict(structure)) == structure
    data = structure_to_dict(structure)
    data["cables"][1]["motor"]["dc"]["stall_torque"] = -1.0
    with pytest.raises(StructureError, match=r"cables\[1\].*stall_torque must be > 0"):
        structure_from_dict(data)
    data["cables"][1]["motor"]["dc"] = {"stall_torqe": 1.0}
    with pytest.raises(StructureError, match=r"unknown field 'stall_torqe'"):
        structure_from_dict(data)
    with pytest.raises(StructureError, match="back_drivable must be true or false"):
        DCMotor(back_drivable="no")


def test_yaml_defaults_merge_into_each_cables_dc_motor():
    data = {"name": "two", "nodes": [{"name": "a", "position": [0, 0, 1], "fixed": True},
                                     {"name": "b", "position": [0.5, 0, 1], "fixed": True},
                                     {"name": "c", "position": [0, 0.5, 1], "fixed": True}],
            "defaults": {"cable": {"stiffness": 100.0, "pretension": 5.0,
                                   "motor": {"dc": {"stall_torque": 0.2, "spool_radius": 0.02}}}},
            "cables": [{"name": "ab", "nodes": ["a", "b"]},
                       {"name": "ac", "nodes": ["a", "c"],
                        "motor": {"dc": {"stall_torque": 0.4, "back_drivable": False}}}]}
    ab, ac = structure_from_dict(data).cables
    assert ab.motor.dc == DCMotor(stall_torque=0.2, spool_radius=0.02)
    # the cable's own entries win, the defaults fill the rest
    assert ac.motor.dc == DCMotor(stall_torque=0.4, spool_radius=0.02, back_drivable=False)
