"""Whole-run oracles for the engine's timing and motor rules, each derived independently of the
code that implements it: integer step counts for the V* rows, the peak tension's definition
for the load cell, the set-valued Coulomb friction's stick condition, and a band for the
shipped gait. Each would fail if the rule it guards were broken (a row boundary one step off,
the peak taken before the motor step, a spool that slips within F_c, a worm gear that gives).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tensim.control import load_controller
from tensim.model import WorldOptions, compile_structure
from tensim.models import preset
from tensim.sim import PhysicsScale, Simulation, Trial, run_batch, simulate
from tensim.structure import Cable, DCMotor, Motor, Node, Structure

ROW_STEPS = 13  # a V* row lasts 13 physics steps (0.013 s at dt = 1 ms: 1.3e-2 is inexact)


class _Rows:
    """The preset's impedance gains, then a V* table whose row r is distinct for every cable."""

    def __init__(self, rows: int, n: int, dt: float):
        self.base = preset("tetraspine3").controller()
        r = np.arange(rows)[:, None]
        self.table = 0.002 * np.sin(0.7 * r + np.arange(n)[None, :])  # [m/s], all distinct
        self.table_dt = ROW_STEPS * dt

    def configure(self, sim: object) -> None:
        self.base.configure(sim)  # type: ignore[arg-type]
        sim.drive.set_target_velocity(self.table, self.table_dt)  # type: ignore[attr-defined]


def test_every_v_star_row_starts_at_its_step_over_a_long_gait():
    # 21 s: 1615 row boundaries, across the single run's input blocks (20,000 steps)
    compiled = compile_structure(preset("tetraspine3").build())
    dt, n, steps = compiled.model.opt.timestep, compiled.n_cables, 21_000
    rows = _Rows(steps // ROW_STEPS + 2, n, dt)
    seen = []
    with Simulation(compiled, controller=rows, record_dt=dt) as sim:
        seen.append(sim.data.ctrl[:n].copy())  # the step at t = 0
        every_step = sim.run(steps * dt, on_record=lambda s: seen.append(s.data.ctrl[:n].copy()))
    # step j reads row j // 13, by integer counting (the code divides times in floating point)
    np.testing.assert_array_equal(np.array(seen), rows.table[np.arange(steps + 1) // ROW_STEPS])
    # recorded every 10 steps, the boundaries fall inside records, where runs of equal inputs
    # are stepped in one call (single run) or set step by step (batch): the same steps result
    single = simulate(compiled, steps * dt, controller=rows).trajectory
    batch = run_batch(compiled, [Trial(rows)], steps * dt)[0]
    assert batch.ok, batch.error
    for series in (single, batch.result.trajectory):
        np.testing.assert_array_equal(series.matrix("setpoint"),
                                      every_step.matrix("setpoint")[::10])
        np.testing.assert_array_equal(series["pos_y/com"], every_step["pos_y/com"][::10])


def test_peak_tension_is_the_largest_load_cell_reading_after_each_motor_step():
    p = preset("tetraspine3")
    structure = p.build()
    compiled = compile_structure(structure)
    dt = compiled.model.opt.timestep
    gait = load_controller("tetraspine3_cpg", structure).with_duration(3.0).build(dt)
    result = simulate(compiled, 3.0, controller=gait, record_dt=dt)  # every step sampled
    tension = result.trajectory.matrix("tension")
    # a sample holds the lengths of its step and the rest lengths the motors set in it, so
    # the running peak is exactly the largest reading, bit for bit
    np.testing.assert_array_equal(result.peak_tension, tension.max(axis=0))
    assert (tension.argmax(axis=0) > 0).sum() >= 6  # most came during the gait, not at t = 0


# -- the DC motor's friction and worm gear, on both batch back-ends --------------------------

K, PRETENSION, F_S, V0, T_P = 100.0, 5.0, 50.0, 0.1, 0.05
SPOOL = DCMotor(spool_radius=0.01, stall_torque=0.5, no_load_speed=10.0, rotor_inertia=5e-5,
                viscous_friction=0.0, coulomb_friction=0.1, position_time=T_P)  # F_c = 10 N


def _held(motor: DCMotor, pretension: float = PRETENSION) -> object:
    """One DC-motor cable between two world-fixed nodes 0.5 m apart (k = 100 N/m), its
    commanded rest length the built one: the position loop's drive is zero until it slips."""
    s = Structure("held", (Node("a", (0.0, 0.0, 1.0), fixed=True),
                           Node("b", (0.5, 0.0, 1.0), fixed=True)),
                  cables=(Cable("c", ("a", "b"), K, pretension=pretension,
                                motor=Motor(max_tension=1e3, dc=motor)),))
    return compile_structure(s, WorldOptions(ground=False))


def _backends() -> list[dict[str, str]]:
    try:
        import mujoco_warp  # noqa: F401
    except ImportError:
        return [{}]
    return [{}, {"backend": "warp", "device": "cpu"}]


@pytest.mark.parametrize("backend", _backends(), ids=lambda b: b.get("backend", "cpu"))
def test_coulomb_friction_sticks_within_its_force_and_slips_beyond(backend):
    compiled = _held(SPOOL)
    built = compiled.rest_length[0]  # type: ignore[attr-defined]
    # float64 rounding; in MuJoCo Warp's float32 the creep below stalls where a step's
    # increment falls under half an ulp of the rest length: 1.5e-8 m / (20 /s x 1 ms) = 0.7 um
    rounding = 1e-2 if backend else 1e-6
    # F_c = 10 N holds the 5 N pretension; scaled by 0.2 (2 N) it does not
    stick, slip = run_batch(compiled, [Trial(), Trial(physics=PhysicsScale(motor_friction=0.2))],
                            1.0, **backend)
    assert stick.ok and slip.ok, (stick.error, slip.error)
    held = stick.result.trajectory["rest_length/c"]
    assert np.all(held == held[0]) and held[0] == pytest.approx(built, rel=1e-7)  # never turned
    # the slipping spool pays out until the net force on it, T + F_s u with T = T0 - k delta
    # and the position loop's u = -delta / (v0 t_p), has fallen to F_c: it creeps onto
    # delta = (T0 - F_c) / (k + F_s / (v0 t_p)), the edge of the stick region, from below
    delta = slip.result.trajectory["rest_length/c"] - built
    edge = (PRETENSION - 2.0) / (K + F_S / (V0 * T_P))
    assert np.all(np.diff(delta) >= 0) and delta[-1] == pytest.approx(edge, rel=rounding)
    assert delta[-1] <= edge * (1 + rounding)


@pytest.mark.parametrize("backend", _backends(), ids=lambda b: b.get("backend", "cpu"))
def test_a_worm_gear_holds_a_tension_past_stall(backend):
    # 40 N on a spool that stalls at 20 N and has no friction: back-drivable it pays out,
    # worm-geared it holds, exactly
    free = dataclasses.replace(SPOOL, coulomb_friction=0.0, stall_torque=0.2)
    results = [run_batch(_held(motor, 40.0), [Trial()], 0.5, **backend)[0]
               for motor in (free, dataclasses.replace(free, back_drivable=False))]
    assert all(r.ok for r in results), [r.error for r in results]
    pulled, held = (r.result.trajectory["rest_length/c"] for r in results)
    assert pulled[-1] - pulled[0] > 1e-3
    assert np.all(held == held[0])


def test_the_shipped_cpg_gait_moves_the_robot_about_a_metre_to_its_left():
    """60 s of the shipped Tetraspine3 CPG gait (README: 1.048 m toward +y, 77 deg): within
    10 % and 10 deg of that, whatever the rounding of the platform."""
    structure = preset("tetraspine3").build()
    compiled = compile_structure(structure)
    config = load_controller("tetraspine3_cpg", structure)
    result = simulate(compiled, config.duration,
                      controller=config.build(compiled.model.opt.timestep))
    series = result.trajectory
    k0 = int(np.searchsorted(series.time, 1.0 - 1e-9))  # after settling, as the experiment
    dx = series["pos_x/com"][-1] - series["pos_x/com"][k0]
    dy = series["pos_y/com"][-1] - series["pos_y/com"][k0]
    assert config.duration == 60.0
    assert 0.94 <= np.hypot(dx, dy) <= 1.15
    assert 67.0 <= np.degrees(np.arctan2(dy, dx)) <= 87.0
