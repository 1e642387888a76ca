"""The cable law as MuJoCo actuator callbacks: the compiled one, and the Python reference.

Each cable is an actuator with user dynamics and user bias (see ``tensim.model``): its parameters
are in the model (``actuator_dynprm``, ``actuator_biasprm``), its rest length and peak tension,
line speed and power in ``act`` (and a DC motor's speed), its command in ``ctrl``. The law is
therefore a pure function of (model, data): :func:`cable_law` is the reference in Python, built on
:mod:`tensim.sim._laws`, and ``_cable.c`` the same operations compiled, installed as
``mjcb_act_dyn``/``mjcb_act_bias``.
Being stateless, the compiled law runs on any number of threads (``mujoco.rollout``,
``mujoco.batch``). The callbacks are process-wide: :func:`install` sets them once, under a lock,
and hands actuators that are not tensim cables to a compiled callback installed before it. The
body of the law is chosen per model, by the marker in its actuators (``_law_layout``):
:func:`use_reference_law` marks a simulation's own model for the Python reference.
"""

from __future__ import annotations

import ctypes
import logging
import math
import threading
from typing import Any, NamedTuple

import mujoco
import numpy as np

from tensim._native import load_library
from tensim.model._law_layout import (
    A_PEAK,
    A_PEAK_POWER,
    A_PEAK_SPEED,
    A_REST,
    A_SPEED,
    B_BACK_DRIVABLE,
    B_COULOMB,
    B_LAG_TIME,
    B_MASS,
    B_NO_LOAD_SPEED,
    B_POSITION_TIME,
    B_SATURATE,
    B_STALL_FORCE,
    B_VISCOUS,
    CABLE_MARKER,
    DC_ACTDIM,
    G_DAMPING,
    G_PD_DAMPING,
    G_PD_STIFFNESS,
    G_STIFFNESS,
    MODE_IMPEDANCE,
    MODE_PD,
    MODE_REST,
    P_GAIN_B,
    P_GAIN_K,
    P_MARKER,
    P_MAX_SPEED,
    P_MAX_TENSION,
    P_MIN_LENGTH,
    P_MIN_REST,
    P_MODE,
    P_OFFSET,
    P_TARGET_LENGTH,
    REFERENCE_MARKER,
    implicit,
    is_cable,
    layout_id,
    motor_actdim,
    theta,
)
from tensim.sim import _laws

log = logging.getLogger(__name__)

__all__ = ["MODE_IMPEDANCE", "MODE_REST", "LawRates", "cable_actuators", "cable_law",
           "compiled_available", "install", "installed_backend"]


class LawRates(NamedTuple):
    """What the cable law writes for each cable: act_dot and the actuator force.

    Attributes:
        rest_rate: (n,) d(rest length)/dt [m/s].
        peak_rate: (n,) d(peak tension)/dt [N/s].
        speed_rate: (n,) d(line speed)/dt of DC motors [m/s^2] (0 for kinematic motors).
        force: (n,) the actuator force -f [N] (under the implicit law, MuJoCo's sum of the
            gain term and the law's bias, clamped to <= 0, as MuJoCo forms it).
        pull_rate: (n,) d(pull)/dt of implicit-law cables [1/s] (0 for the explicit law).
        peak_speed_rate: (n,) d(peak line speed |rest_rate|)/dt [m/s^2].
        peak_power_rate: (n,) d(peak power, load-cell tension x line speed)/dt [W/s].
    """

    rest_rate: np.ndarray
    peak_rate: np.ndarray
    speed_rate: np.ndarray
    force: np.ndarray
    pull_rate: np.ndarray
    peak_speed_rate: np.ndarray
    peak_power_rate: np.ndarray

_ACT = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int)
_MARKERS = (CABLE_MARKER, REFERENCE_MARKER)


def _load_library() -> ctypes.CDLL | None:
    lib = load_library("tensim.sim._cable", "compiled cable law", "using the slower Python law")
    if lib is None:
        return None
    header = lib.tensim_header_version()
    if header != mujoco.mj_version():
        log.warning("compiled cable law was built for MuJoCo %s but %s is installed; using the "
                    "slower Python law (reinstall tensim to rebuild)", header, mujoco.mj_version())
        return None
    lib.tensim_marker.restype = ctypes.c_double
    built = getattr(lib, "tensim_layout_id", None)
    if built is not None:
        built.restype = ctypes.c_uint
    if built is None or built() != layout_id() or lib.tensim_marker() != CABLE_MARKER:
        log.warning("compiled cable law was built for another parameter layout than "
                    "tensim.model._law_layout's; using the slower Python law (reinstall "
                    "tensim to rebuild)")
        return None
    lib.tensim_set_previous.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
    lib.tensim_set_reference.argtypes = [_ACT, _ACT]
    return lib


_LIB = _load_library()
_C_DYN = ctypes.cast(_LIB.tensim_act_dyn, _ACT) if _LIB is not None else None
_C_BIAS = ctypes.cast(_LIB.tensim_act_bias, _ACT) if _LIB is not None else None
_lock = threading.Lock()
_installed: str | None = None


def compiled_available() -> bool:
    """Whether the compiled cable law is built and matches the installed MuJoCo."""
    return _LIB is not None


def installed_backend() -> str | None:
    """``"compiled"``, ``"python"`` or None: the callbacks MuJoCo runs now (the compiled
    dispatcher, which also serves models on the reference law, or the Python law alone)."""
    return _installed


# -- the reference law -----------------------------------------------------------------------

def cable_law(m: mujoco.MjModel, d: mujoco.MjData, ids: np.ndarray | None = None) -> LawRates:
    """The law for cable actuators ``ids`` (all cables by default), from model and data.

    Needs the position and velocity stages of ``d`` (ten_length, ten_velocity).

    Returns:
        The rates and forces, as the compiled law writes them into act_dot and
        actuator_force.
    """
    if ids is None:
        ids = cable_actuators(m)
    p, b = m.actuator_dynprm[ids], m.actuator_biasprm[ids]
    g = m.actuator_gainprm[ids]
    adr, tendon = m.actuator_actadr[ids], m.actuator_trnid[ids, 0]
    x, v = d.ten_length[tendon], d.ten_velocity[tendon]
    k, damping = g[:, G_STIFFNESS], g[:, G_DAMPING]
    rest, peak = d.act[adr + A_REST], d.act[adr + A_PEAK]
    command = d.ctrl[m.actuator_ctrladr[ids]]
    dt = m.opt.timestep
    measured, _ = _laws.cable_tension(x, v, rest, k, damping)
    setpoint = _laws.impedance_setpoint(x, v, p[:, P_OFFSET], p[:, P_GAIN_K], p[:, P_GAIN_B],
                                        p[:, P_TARGET_LENGTH], command)
    impedance, pd = p[:, P_MODE] == MODE_IMPEDANCE, p[:, P_MODE] == MODE_PD
    # a PD motor's command is its target length: its rest length stays where it is
    target = np.where(impedance, _laws.impedance_rest_target(rest, setpoint, measured, k),
                      np.where(pd, rest, command))
    new = _laws.motor_step(rest, target, x, k, p[:, P_MAX_SPEED], p[:, P_MAX_TENSION],
                           p[:, P_MIN_REST], p[:, P_MIN_LENGTH], dt,
                           _laws.lag_share(b[:, B_LAG_TIME], dt), b[:, B_SATURATE])
    speed_rate = np.zeros(len(ids))
    dc = motor_actdim(m)[ids] == DC_ACTDIM
    if dc.any():
        new[dc], speed_rate[dc] = _dc_step(p[dc], g[dc], b[dc], d.act[adr[dc] + A_SPEED],
                                           rest[dc], target[dc], x[dc], v[dc], dt)
    rest_rate = (new - rest) / dt
    next_rest = rest + rest_rate * dt
    # a PD motor pulls beside the spring; the load cell reads both
    spring, applied = _laws.motor_cable_tension(x, v, next_rest, k, damping, pd, command,
                                                g[:, G_PD_STIFFNESS], g[:, G_PD_DAMPING],
                                                p[:, P_MAX_TENSION])
    peak_rate = (np.maximum(peak, spring) - peak) / dt
    # the running maxima of the line speed |dl/dt| and of the power it takes, tension x speed
    speed = np.abs(rest_rate)
    power = spring * speed
    peak_speed, peak_power = d.act[adr + A_PEAK_SPEED], d.act[adr + A_PEAK_POWER]
    peak_speed_rate = (np.maximum(peak_speed, speed) - peak_speed) / dt
    peak_power_rate = (np.maximum(peak_power, power) - peak_power) / dt
    force, pull_rate = -applied, np.zeros(len(ids))
    native = implicit(m)[ids]
    if native.any():
        # the pull, and MuJoCo's force: its gain term plus the law's bias, clamped
        last = adr[native] + m.actuator_actnum[ids][native] - 1
        pull_rate[native] = (_laws.pull(x[native], next_rest[native], theta(m))
                             - d.act[last]) / dt
        pull = d.act[last] + pull_rate[native] * dt
        out = m.actuator_outadr[ids][native]
        term = _laws.gain_term(d.actuator_length[out], d.actuator_velocity[out], k[native],
                               damping[native], pull)
        force[native] = np.minimum(term + (force[native] - term), 0.0)
    return LawRates(rest_rate, peak_rate, speed_rate, force, pull_rate, peak_speed_rate,
                    peak_power_rate)


def _dc_step(p: np.ndarray, g: np.ndarray, b: np.ndarray, speed: np.ndarray,
             rest: np.ndarray, target: np.ndarray, x: np.ndarray, v: np.ndarray, dt: float
             ) -> tuple[np.ndarray, np.ndarray]:
    """DC motors: (new rest length [m], rate of the line speed [m/s^2])."""
    measured, applied = _laws.cable_tension(x, v, rest, g[:, G_STIFFNESS], g[:, G_DAMPING])
    drive = _laws.dc_drive(rest, target, b[:, B_NO_LOAD_SPEED], b[:, B_POSITION_TIME])
    # the controller's limits: no reeling in at max_tension or at min_length
    stop = (drive < 0.0) & ((measured >= p[:, P_MAX_TENSION]) | (x <= p[:, P_MIN_LENGTH]))
    drive = np.where(stop, 0.0, drive)
    new_speed = _laws.dc_motor_speed(speed, drive, applied, b[:, B_STALL_FORCE],
                                     b[:, B_NO_LOAD_SPEED], b[:, B_MASS], b[:, B_VISCOUS],
                                     b[:, B_COULOMB], b[:, B_BACK_DRIVABLE], dt)
    new = rest + new_speed * dt
    # the floor on the rest length stops the spool
    floor = new < p[:, P_MIN_REST]
    new = np.where(floor, p[:, P_MIN_REST], new)
    new_speed = np.where(floor, 0.0, new_speed)
    return new, (new_speed - speed) / dt


def cable_actuators(m: mujoco.MjModel) -> np.ndarray:
    """Ids of the actuators that are tensim cables."""
    return np.flatnonzero(is_cable(m)).astype(np.int32)


def _python_dyn(m: Any, d: Any, i: int) -> float:
    if m.actuator_dynprm[i, P_MARKER] not in _MARKERS:
        return 0.0
    ids = np.array([i])
    rates = cable_law(m, d, ids)
    adr = m.actuator_actadr[i]
    d.act_dot[adr + A_REST], d.act_dot[adr + A_PEAK] = rates.rest_rate[0], rates.peak_rate[0]
    d.act_dot[adr + A_PEAK_SPEED] = rates.peak_speed_rate[0]
    d.act_dot[adr + A_PEAK_POWER] = rates.peak_power_rate[0]
    if motor_actdim(m)[i] == DC_ACTDIM:
        d.act_dot[adr + A_SPEED] = rates.speed_rate[0]
    if implicit(m)[i]:
        d.act_dot[adr + m.actuator_actnum[i] - 1] = rates.pull_rate[0]
    return float(rates.peak_rate[0])


def _python_bias(m: Any, d: Any, i: int) -> float:
    if m.actuator_dynprm[i, P_MARKER] not in _MARKERS:
        return 0.0
    adr, tendon = m.actuator_actadr[i] + A_REST, m.actuator_trnid[i, 0]
    rest = d.act[adr] + d.act_dot[adr] * m.opt.timestep
    g = m.actuator_gainprm[i]
    k, damping = g[G_STIFFNESS:G_STIFFNESS + 1], g[G_DAMPING:G_DAMPING + 1]
    x, v = d.ten_length[tendon:tendon + 1], d.ten_velocity[tendon:tendon + 1]
    _, applied = _laws.cable_tension(x, v, np.array([rest]), k, damping)
    if m.actuator_dynprm[i, P_MODE] == MODE_PD:  # the PD motor's pull beside the spring
        applied = applied + _laws.pd_tension(
            x, v, d.ctrl[m.actuator_ctrladr[i]], g[G_PD_STIFFNESS], g[G_PD_DAMPING],
            m.actuator_dynprm[i, P_MAX_TENSION])[1]
    if not implicit(m)[i]:
        return -float(applied[0])
    # the implicit law: less MuJoCo's gain term, on the pull as actearly reads it
    last = m.actuator_actadr[i] + m.actuator_actnum[i] - 1
    pull = d.act[last] + d.act_dot[last] * m.opt.timestep
    out = m.actuator_outadr[i]
    term = _laws.gain_term(d.actuator_length[out:out + 1], d.actuator_velocity[out:out + 1],
                           k, damping, np.array([pull]))
    return float(-applied[0] - term[0])


# -- the law's body, per model ---------------------------------------------------------------

# the MjData of each simulation on the reference law, by address: the compiled dispatcher
# hands their cables to Python with bare pointers
_reference: dict[int, tuple[mujoco.MjModel, mujoco.MjData]] = {}


def use_reference_law(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Makes ``model`` (a simulation's own copy) step its cables on the Python reference law,
    with ``data``; every other model keeps its own law. Undo with :func:`release`."""
    ids = cable_actuators(model)
    model.actuator_dynprm[ids, P_MARKER] = REFERENCE_MARKER
    with _lock:
        _reference[data._address] = (model, data)


def release(data: mujoco.MjData) -> None:
    """Forgets a simulation registered by :func:`use_reference_law` (its model keeps the
    reference marker: stepping it again needs a new registration)."""
    with _lock:
        _reference.pop(data._address, None)


def _reference_for(data: int | None) -> tuple[mujoco.MjModel, mujoco.MjData] | None:
    pair = _reference.get(data or 0)
    if pair is None:
        log.error("an MjData without a simulation stepped a model on the Python reference law: "
                  "its cable forces are NaN (step it through its Simulation)")
    return pair


def _reference_dyn(m: int | None, d: int | None, i: int) -> float:
    pair = _reference_for(d)
    return math.nan if pair is None else _python_dyn(*pair, i)


def _reference_bias(m: int | None, d: int | None, i: int) -> float:
    pair = _reference_for(d)
    return math.nan if pair is None else _python_bias(*pair, i)


_REF_DYN, _REF_BIAS = _ACT(_reference_dyn), _ACT(_reference_bias)  # kept alive here


# -- installation ----------------------------------------------------------------------------

def install(backend: str = "auto") -> str:
    """Makes MuJoCo's user-actuator callbacks run the cable law; returns the law ``backend``
    resolves to.

    The callbacks are process-wide, but the law's body is chosen per model, by the marker
    in its actuators (see :func:`use_reference_law`): the compiled law, when built, is
    installed once and runs the models marked for it, and hands the cables of models marked
    for the Python reference law to Python. So installing never switches another live
    simulation's law. Without the compiled law the Python one serves every model.
    ``"auto"`` resolves to ``"compiled"`` when it is built, else to ``"python"`` (with a
    warning). A compiled callback of the user's that was installed first keeps serving the
    user's own actuators; a Python one cannot be called from the compiled law, so it is
    replaced, with a warning.

    Raises:
        RuntimeError: ``"compiled"`` asked for but not built.
        ValueError: an unknown backend.
    """
    global _installed
    if backend not in ("auto", "compiled", "python"):
        raise ValueError(f"backend must be 'auto', 'compiled' or 'python', got {backend!r}")
    with _lock:
        if backend == "auto" and _LIB is None:
            log.warning("compiled cable law not built (no C compiler at install time?): "
                        "using the much slower Python law")
        if backend == "compiled" and _LIB is None:
            raise RuntimeError("the compiled cable law is not available; reinstall tensim with "
                               "a C compiler, or use backend='python'")
        callbacks = "compiled" if _LIB is not None else "python"
        if not (callbacks == _installed and _still_installed()):
            _chain_previous()
            if _LIB is not None:
                _LIB.tensim_set_reference(_REF_DYN, _REF_BIAS)
                mujoco.set_mjcb_act_dyn(_C_DYN)
                mujoco.set_mjcb_act_bias(_C_BIAS)
            else:
                mujoco.set_mjcb_act_dyn(_python_dyn)
                mujoco.set_mjcb_act_bias(_python_bias)
            _installed = callbacks
        return callbacks if backend == "auto" else backend


def _ours(callback: object) -> bool:
    return callback is None or callback in (_C_DYN, _C_BIAS, _python_dyn, _python_bias) or (
        isinstance(callback, ctypes._CFuncPtr)  # type: ignore[attr-defined]
        and _LIB is not None
        and ctypes.cast(callback, ctypes.c_void_p).value in (
            ctypes.cast(_LIB.tensim_act_dyn, ctypes.c_void_p).value,
            ctypes.cast(_LIB.tensim_act_bias, ctypes.c_void_p).value))


def _still_installed() -> bool:
    return _ours(mujoco.get_mjcb_act_dyn()) and _ours(mujoco.get_mjcb_act_bias()) \
        and mujoco.get_mjcb_act_dyn() is not None


def _chain_previous() -> None:
    """Hands the user's own compiled callbacks to the compiled law; warns about Python ones."""
    previous = {"dyn": mujoco.get_mjcb_act_dyn(), "bias": mujoco.get_mjcb_act_bias()}
    pointers: dict[str, int | None] = {}
    for kind, callback in previous.items():
        if _ours(callback):
            pointers[kind] = None
        elif isinstance(callback, ctypes._CFuncPtr):  # type: ignore[attr-defined]
            pointers[kind] = ctypes.cast(callback, ctypes.c_void_p).value
            log.warning("tensim installs its cable law as mjcb_act_%s; your compiled callback "
                        "still serves your own user actuators", kind)
        else:
            pointers[kind] = None
            log.warning("tensim replaces your Python mjcb_act_%s callback with its cable law: "
                        "the compiled law cannot call Python", kind)
    if _LIB is not None:
        _LIB.tensim_set_previous(pointers["dyn"], pointers["bias"])
