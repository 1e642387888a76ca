"""Per-simulation cable state, and the MuJoCo control callback that applies the cable laws.

A :class:`CableDrive` owns every array the callback reads or writes for one ``MjData``: cable
and motor parameters, the controller's commands (mode, gains, targets, the V* table), the motor
state (rest lengths) and the outputs (tensions, setpoints). Two callbacks implement the same
laws: the compiled one (``_cable.c``, run by MuJoCo inside ``mj_step`` without returning to
Python) and a Python one built on :mod:`tensim.sim._laws`, used as the reference in tests and
as the fallback when the extension is missing.
"""

from __future__ import annotations

import ctypes
import importlib.util
import logging
import weakref
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np

from tensim.model import CompiledModel
from tensim.sim import _laws
from tensim.sim._loads import NodeLoad

log = logging.getLogger(__name__)

MODE_REST = 0  # the motor follows a commanded rest length
MODE_IMPEDANCE = 1  # the motor realises the impedance law's tension setpoint

_P = ctypes.c_void_p


class _Context(ctypes.Structure):
    """Mirror of ``tensim_context`` in ``_cable.c``."""

    _fields_ = [
        ("data", _P), ("ncable", ctypes.c_int), ("tendon", _P), ("actuator", _P),
        ("stiffness", _P), ("damping", _P), ("max_speed", _P), ("max_tension", _P),
        ("min_rest", _P), ("min_length", _P),
        ("mode", _P), ("rest_command", _P), ("offset_tension", _P), ("gain_k", _P),
        ("gain_b", _P), ("target_length", _P),
        ("vstar", _P), ("vstar_rows", ctypes.c_int), ("vstar_dt", ctypes.c_double),
        ("rest", _P), ("tension", _P), ("applied", _P), ("setpoint", _P), ("peak", _P),
        ("last_time", _P),
        ("nload", ctypes.c_int), ("load_body", _P), ("load_point", _P), ("load_start", _P),
        ("load_count", _P), ("knot_time", _P), ("knot_force", _P),
    ]


def _load_library() -> ctypes.CDLL | None:
    spec = importlib.util.find_spec("tensim.sim._cable")
    if spec is None or spec.origin is None:
        return None
    lib = ctypes.CDLL(spec.origin)
    header = lib.tensim_header_version()
    if header != mujoco.mj_version():
        log.warning("compiled cable callback was built for MuJoCo %s but %s is installed; "
                    "using the slower Python callback (reinstall tensim to rebuild)",
                    header, mujoco.mj_version())
        return None
    lib.tensim_register.argtypes = [ctypes.POINTER(_Context)]
    lib.tensim_unregister.argtypes = [_P]
    lib.tensim_control.argtypes = [_P, _P]
    return lib


_LIB = _load_library()
_CALLBACK = ctypes.CFUNCTYPE(None, _P, _P)
_C_CONTROL = ctypes.cast(_LIB.tensim_control, _CALLBACK) if _LIB is not None else None
_python_drives: dict[int, weakref.ref[CableDrive]] = {}
_compiled_count = 0


def compiled_available() -> bool:
    """Whether the compiled cable callback is built and matches the installed MuJoCo."""
    return _LIB is not None


def _python_control(m: mujoco.MjModel, d: mujoco.MjData) -> None:
    ref = _python_drives.get(d._address)
    drive = ref() if ref is not None else None
    if drive is not None:
        drive.python_callback(d)
    elif _LIB is not None:  # a compiled drive while the Python dispatcher is installed
        _LIB.tensim_control(m._address, d._address)


def _install() -> None:
    if _python_drives:
        mujoco.set_mjcb_control(_python_control)
    elif _compiled_count:
        mujoco.set_mjcb_control(_C_CONTROL)
    else:
        mujoco.set_mjcb_control(None)


def _arr(values: Any, dtype: type = np.float64) -> np.ndarray:
    return np.ascontiguousarray(values, dtype=dtype).copy()


class CableDrive:
    """Cable, motor and controller state for one ``MjData``, registered with the callback.

    Attributes (all (n_cables,) unless stated):
        mode: MODE_REST or MODE_IMPEDANCE per cable.
        rest_command: commanded rest length for MODE_REST cables [m].
        offset_tension, gain_k, gain_b, target_length: impedance T0 [N], K [N/m], B [N s/m],
            L* [m].
        target_velocity: (rows, n_cables) V* table [m/s], row r for t in [r, r+1) * table_dt.
        rest: motor state, the current rest lengths [m].
        tension: load-cell reading k max(0, x - l) [N].
        applied: total applied force, with damping [N].
        setpoint: impedance setpoint T_set [N] (NaN for MODE_REST cables).
        peak: running maximum of ``tension`` over every step [N].
    """

    def __init__(self, compiled: CompiledModel, data: mujoco.MjData, loads: Sequence[NodeLoad],
                 backend: str):
        n = compiled.n_cables
        self._compiled, self._data = compiled, data
        self.tendon = _arr(compiled.index.tendon, np.int32)
        self.actuator = _arr(compiled.index.actuator, np.int32)
        self.stiffness, self.damping = _arr(compiled.stiffness), _arr(compiled.damping)
        self.max_speed, self.max_tension = _arr(compiled.max_speed), _arr(compiled.max_tension)
        self.min_rest, self.min_length = _arr(compiled.min_rest_length), _arr(compiled.min_length)
        self.mode = np.zeros(n, dtype=np.int32)
        self.rest_command = _arr(compiled.rest_length)
        self.offset_tension, self.gain_k, self.gain_b = np.zeros(n), np.zeros(n), np.zeros(n)
        self.target_length = _arr(compiled.rest_length)
        self.target_velocity = np.zeros((1, n))
        self.table_dt = 1.0
        self.rest = _arr(compiled.rest_length)
        self.tension, self.applied = np.zeros(n), np.zeros(n)
        self.setpoint = np.full(n, np.nan)
        self.peak = np.zeros(n)
        self.last_time = np.array([-np.inf])
        self._set_loads(loads)
        if backend == "auto":
            backend = "compiled" if _LIB is not None else "python"
        if backend == "compiled" and _LIB is None:
            raise RuntimeError("the compiled cable callback is not available; reinstall tensim "
                               "with a C compiler, or use backend='python'")
        if backend not in ("compiled", "python"):
            raise ValueError(f"backend must be 'auto', 'compiled' or 'python', got {backend!r}")
        self.backend = backend
        self._registered = False
        self.register()

    def _set_loads(self, loads: Sequence[NodeLoad]) -> None:
        index = self._compiled.index
        for load in loads:
            if load.node not in index.node_body:
                raise KeyError(f"load at unknown node {load.node!r}")
            if index.node_body[load.node] == 0:
                raise ValueError(f"load at {load.node!r}: the node is fixed to the world")
        self.loads = tuple(loads)
        self.load_body = _arr([index.node_body[ld.node] for ld in loads] or [0], np.int32)
        self.load_point = _arr([index.node_local[ld.node] for ld in loads] or [[0, 0, 0]])
        counts = [ld.times.size for ld in loads]
        self.load_count = _arr(counts or [0], np.int32)
        self.load_start = _arr(np.concatenate([[0], np.cumsum(counts)[:-1]]) if loads else [0],
                               np.int32)
        self.knot_time = _arr(np.concatenate([ld.times for ld in loads]) if loads else [0.0])
        self.knot_force = _arr(np.concatenate([ld.forces for ld in loads]) if loads
                               else [[0.0, 0.0, 0.0]])

    def set_target_velocity(self, table: np.ndarray, table_dt: float) -> None:
        """Sets the V* table: (rows, n_cables) [m/s], row r holding for t in [r, r+1)·table_dt."""
        table = np.ascontiguousarray(table, dtype=float)
        if table.ndim == 1:
            table = table[None, :]
        if table.shape[1] != self.stiffness.size or table.shape[0] < 1 or table_dt <= 0:
            raise ValueError(f"target velocity table must be (rows, {self.stiffness.size}) with "
                             f"table_dt > 0, got {table.shape} and {table_dt}")
        self.target_velocity, self.table_dt = table, float(table_dt)
        self.register()

    # -- registration with the callback -------------------------------------------------------

    def _context(self) -> _Context:
        def p(a: np.ndarray) -> int:
            return a.ctypes.data

        return _Context(
            self._data._address, self.stiffness.size, p(self.tendon), p(self.actuator),
            p(self.stiffness), p(self.damping), p(self.max_speed), p(self.max_tension),
            p(self.min_rest), p(self.min_length), p(self.mode), p(self.rest_command),
            p(self.offset_tension), p(self.gain_k), p(self.gain_b), p(self.target_length),
            p(self.target_velocity), self.target_velocity.shape[0], self.table_dt,
            p(self.rest), p(self.tension), p(self.applied), p(self.setpoint), p(self.peak),
            p(self.last_time),
            len(self.loads), p(self.load_body), p(self.load_point), p(self.load_start),
            p(self.load_count), p(self.knot_time), p(self.knot_force),
        )

    def register(self) -> None:
        """(Re)registers this drive's arrays with the callback; call after replacing an array."""
        global _compiled_count
        if self.backend == "compiled":
            self._ctx = self._context()
            assert _LIB is not None
            if _LIB.tensim_register(ctypes.byref(self._ctx)) != 0:
                raise RuntimeError("too many simultaneous simulations for the cable callback")
            if not self._registered:
                _compiled_count += 1
        else:
            _python_drives[self._data._address] = weakref.ref(self)
        self._registered = True
        _install()

    def unregister(self) -> None:
        """Detaches this drive from the callback (the MjData then steps without cables)."""
        global _compiled_count
        if not self._registered:
            return
        if self.backend == "compiled":
            assert _LIB is not None
            _LIB.tensim_unregister(self._data._address)
            _compiled_count -= 1
        else:
            _python_drives.pop(self._data._address, None)
        self._registered = False
        _install()

    def __del__(self) -> None:
        try:
            self.unregister()
        except Exception:  # interpreter shutdown: module globals may be gone
            pass

    # -- the reference implementation ---------------------------------------------------------

    def python_callback(self, d: mujoco.MjData) -> None:
        """The laws of :mod:`tensim.sim._laws`, applied as the compiled callback does."""
        x, v = d.ten_length[self.tendon], d.ten_velocity[self.tendon]
        if d.time > self.last_time[0]:
            self._advance_motors(d, x, v)
            self.last_time[0] = d.time
        spring, applied = _laws.cable_tension(x, v, self.rest, self.stiffness, self.damping)
        self.tension[:], self.applied[:] = spring, applied
        np.maximum(self.peak, spring, out=self.peak)
        d.ctrl[self.actuator] = -applied
        self._apply_loads(d)

    def _advance_motors(self, d: mujoco.MjData, x: np.ndarray, v: np.ndarray) -> None:
        row = int(np.clip(np.floor(d.time / self.table_dt + 1e-9), 0,
                          self.target_velocity.shape[0] - 1))
        measured, _ = _laws.cable_tension(x, v, self.rest, self.stiffness, self.damping)
        setpoint = _laws.impedance_setpoint(x, v, self.offset_tension, self.gain_k, self.gain_b,
                                            self.target_length, self.target_velocity[row])
        impedance = self.mode == MODE_IMPEDANCE
        target = np.where(impedance,
                          _laws.impedance_rest_target(self.rest, setpoint, measured,
                                                      self.stiffness),
                          self.rest_command)
        self.setpoint[:] = np.where(impedance, setpoint, np.nan)
        self.rest[:] = _laws.motor_step(self.rest, target, x, self.stiffness, self.max_speed,
                                        self.max_tension, self.min_rest, self.min_length,
                                        self._compiled.model.opt.timestep)

    def _apply_loads(self, d: mujoco.MjData) -> None:
        if not self.loads:
            return
        d.xfrc_applied[self.load_body] = 0.0
        for body, point, load in zip(self.load_body, self.load_point, self.loads, strict=True):
            force = load.force_at(d.time)
            rot = d.xmat[body]  # row-major 3x3, summed as the C code does (no BLAS rounding)
            arm = (rot[0::3] * point[0] + rot[1::3] * point[1] + rot[2::3] * point[2]
                   + d.xpos[body] - d.xipos[body])
            d.xfrc_applied[body, :3] += force
            d.xfrc_applied[body, 3:] += np.cross(arm, force)

