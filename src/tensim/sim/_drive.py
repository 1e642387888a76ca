"""What a controller sets up for one simulation: law parameters in the model, command inputs.

A :class:`CableDrive` exposes the per-cable law parameters as live views of the model's
actuator parameters (so a controller writing ``drive.gain_k[i]`` edits the ``MjModel`` the
simulation steps), and holds the commands that enter through ``ctrl``: the V* table of
impedance-mode cables and the commanded rest lengths of rest-mode cables. :class:`InputPlan`
turns those commands and the external node loads into the ``ctrl`` rows of a range of steps,
the one definition of the inputs that single runs and batches share.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from tensim.model import CompiledModel
from tensim.model._law_layout import (
    A_PEAK,
    A_PEAK_POWER,
    A_PEAK_SPEED,
    A_REST,
    MODE_IMPEDANCE,
    MODE_PD,
    MODE_REST,
    LawParameters,
)
from tensim.sim import _laws
from tensim.sim._loads import NodeLoad

__all__ = ["MODE_IMPEDANCE", "MODE_PD", "MODE_REST", "CableDrive", "InputPlan"]

_ROW_SLACK = 1e-9  # a step whose time is within this many rows of a row start is in that row


class CableDrive(LawParameters):
    """The cable law's parameters and commands for one simulation.

    Attributes (all (n_cables,) unless stated); the law's parameters are the live views of
    :class:`~tensim.model.LawParameters` (stiffness, damping, mode, motor limits, impedance
    gains), so a controller writing ``drive.gain_k[i]`` edits the model.
    Commands, entering through ``ctrl``:
        rest_command: commanded rest length of MODE_REST cables, target length of MODE_PD
            ones [m].
        target_velocity: (rows, n_cables) V* table [m/s], row r for t in [r, r+1) * table_dt.
    Outputs (with ``data``): rest, peak, peak_speed, peak_power, tension, applied, setpoint;
    see the properties.
    """

    def __init__(self, compiled: CompiledModel, model: mujoco.MjModel,
                 data: mujoco.MjData | None = None):
        n = compiled.n_cables
        if not np.array_equal(compiled.index.actuator, np.arange(n)):
            raise ValueError("cable actuators must be the model's first actuators")
        super().__init__(model, n)
        self._compiled, self._model, self._data = compiled, model, data
        self.tendon = compiled.index.tendon
        self.rest_command = compiled.command
        self.target_velocity = np.zeros((1, n))
        self.table_dt = 1.0

    def set_target_velocity(self, table: np.ndarray, table_dt: float) -> None:
        """Sets the V* table: (rows, n_cables) [m/s], row r holding for t in [r, r+1)·table_dt."""
        table = np.ascontiguousarray(table, dtype=float)
        if table.ndim == 1:
            table = table[None, :]
        if table.ndim != 2 or table.shape[1] != self.stiffness.size or table.shape[0] < 1 \
                or not table_dt > 0:
            raise ValueError(f"target velocity table must be (rows, {self.stiffness.size}) with "
                             f"table_dt > 0, got {table.shape} and {table_dt}")
        if not np.all(np.isfinite(table)):
            raise ValueError("target velocity table holds non-finite values")
        self.target_velocity, self.table_dt = table, float(table_dt)

    def commands(self, steps: np.ndarray, dt: float) -> np.ndarray:
        """(len(steps), n_cables) each cable's ``ctrl`` at physics steps ``steps``.

        The step that starts at t = j dt reads V* row floor(t / table_dt), clamped to the table.
        """
        rows = np.floor(steps * dt / self.table_dt + _ROW_SLACK).astype(np.int64)
        np.clip(rows, 0, self.target_velocity.shape[0] - 1, out=rows)
        if not rows.size:
            return np.empty((0, self.stiffness.size))
        # the commands of each V* row these steps read, once; then a row per step
        low, high = int(rows.min()), int(rows.max())
        table = np.where(self.mode == MODE_IMPEDANCE, self.target_velocity[low:high + 1],
                         self.rest_command)
        return table[rows - low]

    # -- outputs, from the data ---------------------------------------------------------------

    def _need_data(self) -> mujoco.MjData:
        if self._data is None:
            raise RuntimeError("this drive has no simulation data")
        return self._data

    @property
    def rest(self) -> np.ndarray:
        """(n,) the motors' rest lengths [m] (a live view of the activations unless some
        cable has a DC motor)."""
        return self._compiled.index.cable_act(self._need_data().act, A_REST)

    @property
    def peak(self) -> np.ndarray:
        """(n,) running maximum of the load-cell tension over every step [N] (live view,
        as :attr:`rest`)."""
        return self._compiled.index.cable_act(self._need_data().act, A_PEAK)

    @property
    def peak_speed(self) -> np.ndarray:
        """(n,) running maximum of the motors' line speed |dl/dt| over every step [m/s]."""
        return self._compiled.index.cable_act(self._need_data().act, A_PEAK_SPEED)

    @property
    def peak_power(self) -> np.ndarray:
        """(n,) running maximum of the load-cell tension times the line speed over every
        step [W]."""
        return self._compiled.index.cable_act(self._need_data().act, A_PEAK_POWER)

    def _tensions(self) -> tuple[np.ndarray, np.ndarray]:
        d = self._need_data()
        return _laws.motor_cable_tension(
            d.ten_length[self.tendon], d.ten_velocity[self.tendon], self.rest, self.stiffness,
            self.damping, self.mode == MODE_PD, d.ctrl[:self.stiffness.size],
            self.pd_stiffness, self.pd_damping, self.max_tension)

    @property
    def tension(self) -> np.ndarray:
        """(n,) load-cell reading k max(0, x - l) of the latest step, with a PD motor's
        static pull [N]."""
        return self._tensions()[0]

    @property
    def applied(self) -> np.ndarray:
        """(n,) force applied in the latest step, with damping [N]."""
        return self._tensions()[1]

    @property
    def setpoint(self) -> np.ndarray:
        """(n,) impedance setpoint T_set of the latest step [N] (NaN for MODE_REST cables)."""
        d = self._need_data()
        x, v = d.ten_length[self.tendon], d.ten_velocity[self.tendon]
        n = self.stiffness.size
        set_ = _laws.impedance_setpoint(x, v, self.offset_tension, self.gain_k,
                                             self.gain_b, self.target_length, d.ctrl[:n])
        return np.where(self.mode == MODE_IMPEDANCE, set_, np.nan)


class InputPlan:
    """The ``ctrl`` rows of a simulation: cable commands, then node-load forces.

    Args:
        drive: the cable commands.
        loads: external node forces; their nodes must have inputs in the model.
        compiled: the model (with the load nodes' inputs).
    """

    def __init__(self, drive: CableDrive, loads: Sequence[NodeLoad], compiled: CompiledModel):
        load_nodes = compiled.index.load_nodes
        for load in loads:
            if load.node not in load_nodes:
                raise ValueError(f"load at {load.node!r}: the model has no force input there "
                                 f"(compile with load_nodes)")
        self.drive, self.loads = drive, tuple(loads)
        self._column = [compiled.n_cables + 3 * load_nodes.index(ld.node) for ld in loads]
        self.nu = compiled.n_cables + 3 * len(load_nodes)
        self.dt = float(compiled.model.opt.timestep)

    def sharing_key(self) -> tuple[object, ...]:
        """What :meth:`control` reads, by identity where it is an array of the plan's
        controller (its V* table, its loads): plans with equal keys, at once, give equal rows,
        so a batch of many worlds on few gaits computes each gait's rows once."""
        d = self.drive
        return (id(d.target_velocity), d.table_dt, d.mode.tobytes(), d.rest_command.tobytes(),
                tuple(map(id, self.loads)), tuple(self._column), self.nu, self.dt)

    def control(self, first: int, count: int) -> np.ndarray:
        """(count, nu) the ``ctrl`` of steps first .. first + count - 1."""
        steps = np.arange(first, first + count)
        n = self.drive.stiffness.size
        if self.nu == n:  # cable commands alone: their rows as they come (a 796-cable robot's
            return self.drive.commands(steps, self.dt)  # block is 16 MB: no second copy)
        out = np.zeros((count, self.nu))
        out[:, :n] = self.drive.commands(steps, self.dt)
        times = steps * self.dt
        for column, load in zip(self._column, self.loads, strict=True):
            out[:, column:column + 3] += load.forces_at(times)
        return out


def changes(control: np.ndarray) -> np.ndarray:
    """Row indices (after the first) where ``control`` differs from the row before."""
    return np.flatnonzero((control[1:] != control[:-1]).any(axis=1)) + 1
