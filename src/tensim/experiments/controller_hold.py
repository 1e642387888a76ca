"""The disturbance test with its controller updated every few physics steps: which part of a
long step sets the test's error (``python -m tensim.experiments.implicit_probe hold``).

Under the cable law the impedance laws and the motors are updated at every physics step, from
the state at the step's start. :func:`held_run` runs the physics at one step and the laws and
motors at a multiple of it: every ``period`` steps the law is evaluated at the period's length
(its rest-length rates, under its speed limit, exactly as a run at that step would take them),
and the motors follow those rates in a straight line over the period's physics steps (each cable
set to follow a commanded rest length, its command moved by rate x step each step). With a
period of one it is the plain run (tests/test_controller_hold.py). So a 4 ms controller on 1 ms
physics, against the 4 ms run and the 1 ms run, says how much of the 4 ms error is the
controller's update at the long step and how much the physics' step.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Sequence

import mujoco
import numpy as np

from tensim.control import ControllerConfig
from tensim.experiments.disturbance import DURATION, START, disturbance_loads
from tensim.model import BUILD_KEY, WorldOptions, compile_structure
from tensim.model._law_layout import A_PEAK, A_REST, MODE_REST, P_MAX_SPEED, P_MODE
from tensim.models import preset
from tensim.sim import Simulation
from tensim.sim._law import cable_actuators, cable_law

WINDOW_S = (34.0, 40.0)  # the end of the push's rise and its hold [s]


@dataclasses.dataclass(frozen=True)
class HeldRun:
    """A run of :func:`held_run`.

    Attributes:
        peak_tension: (n_cables,) each cable's peak load-cell tension over the run [N].
        rest_length: (n_cables,) the rest lengths at the run's end [m].
        rest_rates: (k, n_cables) the motors' rest-length rates set at each update inside
            ``window`` [m/s].
        velocities: (k, n_cables) the cables' length rates at those updates [m/s].
        max_speed: (n_cables,) the motors' speed limits [m/s].
    """

    peak_tension: np.ndarray
    rest_length: np.ndarray
    rest_rates: np.ndarray
    velocities: np.ndarray
    max_speed: np.ndarray

    def at_limit(self) -> float:
        """The share of the motor updates in the window that run at the speed limit."""
        return float(np.mean(np.abs(self.rest_rates) >= self.max_speed * (1.0 - 1e-9)))

    def rate_jumps(self) -> float:
        """The rms change of the cables' length rates from one update to the next [m/s]."""
        return float(np.sqrt(np.mean(np.diff(self.velocities, axis=0) ** 2)))


def held_run(dt: float, period: int = 1, cable_law_name: str = "explicit",
             duration: float = DURATION, window: tuple[float, float] = WINDOW_S,
             push_delay: float = 0.0) -> HeldRun:
    """Tetraspine3's disturbance test at physics step ``dt`` [s], its impedance laws and motors
    updated every ``period`` steps (see the module's docstring), under ``cable_law_name``, the
    push starting ``push_delay`` [s] later than the test's.

    Raises:
        ValueError: a period below 1.
        TypeError: the preset lost its impedance laws.
    """
    if period < 1:
        raise ValueError(f"period must be >= 1 physics step, got {period}")
    model = preset("tetraspine3")
    laws = model.controller()
    if laws is None:
        raise TypeError("tetraspine3 no longer has its impedance laws")
    compiled = compile_structure(model.build(), WorldOptions(timestep=dt,
                                                             cable_law=cable_law_name))
    controller = ControllerConfig(laws, model="tetraspine3").build(dt)
    loads = disturbance_loads(start=START + push_delay)
    with Simulation(compiled, controller=controller, loads=loads, record_dt=dt) as sim:
        m = sim.model
        steps = round(duration / dt)
        control = sim.inputs().control(0, steps)  # V* and the loads, as the plain run reads
        law = copy.copy(m)  # the impedance laws, at the controller's period
        law.opt.timestep = period * dt
        ids = cable_actuators(m)
        m.actuator_dynprm[ids, P_MODE] = MODE_REST  # the motors follow the rates set below
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, m.key(BUILD_KEY).id)
        return _loop(m, d, law, ids, control, period, window)


def _loop(m: mujoco.MjModel, d: mujoco.MjData, law: mujoco.MjModel, ids: np.ndarray,
          control: np.ndarray, period: int, window: tuple[float, float]) -> HeldRun:
    dt = m.opt.timestep
    rest_adr, tendons = m.actuator_actadr[ids] + A_REST, m.actuator_trnid[ids, 0]
    commands = m.actuator_ctrladr[ids]
    rates, velocities = [], []
    rate = start = np.zeros(len(ids))
    for j in range(control.shape[0]):
        d.ctrl[:] = control[j]
        if j % period == 0:
            # the law at the period's length, from the state at its start
            mujoco.mj_fwdPosition(m, d)
            mujoco.mj_fwdVelocity(m, d)
            rate, start = cable_law(law, d, ids).rest_rate, d.act[rest_adr].copy()
            if window[0] <= j * dt < window[1]:
                rates.append(rate)
                velocities.append(d.ten_velocity[tendons].copy())
        d.ctrl[commands] = start + rate * (dt * (j % period + 1))
        mujoco.mj_step(m, d)
    return HeldRun(d.act[m.actuator_actadr[ids] + A_PEAK].copy(), d.act[rest_adr].copy(),
                   np.array(rates),
                   np.array(velocities), m.actuator_dynprm[ids, P_MAX_SPEED].copy())


HOLD_ROWS = tuple((law, dt, period, 0.0) for law in ("explicit", "implicit")
                  for dt, period in ((1e-3, 1), (1e-3, 4), (4e-3, 1))) + tuple(
    (law, 4e-3, 1, delay) for law in ("explicit", "implicit") for delay in (-2e-3, 2e-3))


def hold_study(rows: Sequence[tuple[str, float, int, float]] = HOLD_ROWS) -> list[str]:
    """Per (law, physics step [s], period [steps], push delay [s]): the worst cable's
    max-tension change against the 0.05 ms explicit reference [%], the share of the motors'
    updates over the window at their speed limit, and the rms change of the cables' length
    rates between updates [mm/s]."""
    from tensim.experiments import laws

    reference = laws._tetraspine3(WorldOptions(timestep=5e-5))
    peak = reference.peak_tension
    lines = []
    for name, dt, period, delay in rows:
        run = held_run(dt, period, name, push_delay=delay)
        change = 100.0 * (run.peak_tension - peak) / peak
        worst = float(change[np.argmax(np.abs(change))])
        pushed = f", push {delay * 1e3:+g} ms" if delay else ""
        lines.append(f"  {name:<9} physics {dt * 1e3:g} ms, controller every "
                     f"{dt * period * 1e3:g} ms{pushed}: max tension {worst:+.2f} %, motor "
                     f"updates at the speed limit {100 * run.at_limit():3.0f} %, rate changes "
                     f"{run.rate_jumps() * 1e3:.1f} mm/s rms")
    return lines
