"""Loads and calls the compiled CPG integrator (``_cpg.c``: scipy's DOP853 for eq. 4-5, in C).

The library is optional (built where a C compiler was found at install time);
:func:`available` says whether it is here, and :mod:`tensim.control.cpg` falls back to scipy
without it.
"""

from __future__ import annotations

import ctypes
from typing import NamedTuple

import numpy as np

from tensim._native import load_library

# status codes of tensim_cpg_dop853
OK, AMPLITUDE, EVALUATIONS, WALL_TIME, STEP_TOO_SMALL, NO_MEMORY = range(6)

_DOUBLES = ctypes.POINTER(ctypes.c_double)
_INTS = ctypes.POINTER(ctypes.c_int)


def _load_library() -> ctypes.CDLL | None:
    lib = load_library("tensim.control._cpg", "compiled CPG integrator",
                       "integrating CPGs with scipy")
    if lib is None:
        return None
    lib.tensim_cpg_dop853.restype = ctypes.c_int
    lib.tensim_cpg_dop853.argtypes = [
        ctypes.c_int, ctypes.c_int, _DOUBLES, _DOUBLES, _DOUBLES, _INTS, _INTS, _DOUBLES,
        _DOUBLES, _DOUBLES, ctypes.c_double, ctypes.c_int, _DOUBLES, ctypes.c_double,
        ctypes.c_double, ctypes.c_double, ctypes.c_longlong, ctypes.c_double, _DOUBLES,
        _DOUBLES]
    return lib


_LIB = _load_library()


def available() -> bool:
    """Whether the compiled CPG integrator is built."""
    return _LIB is not None


class Result(NamedTuple):
    """What one compiled integration gave.

    Attributes:
        status: ``OK`` or the guard that stopped it (``AMPLITUDE``, ``EVALUATIONS``, ...).
        samples: (n_times, 2 n) θ [rad] and r [m/s] at the sample times (valid when ``OK``).
        stop_time: time the integration reached [s].
        evaluations: right-hand side evaluations made.
    """

    status: int
    samples: np.ndarray
    stop_time: float
    evaluations: int


def _doubles(array: np.ndarray) -> ctypes._Pointer:
    return array.ctypes.data_as(_DOUBLES)


def dop853(omega: np.ndarray, target: np.ndarray, convergence: np.ndarray, ci: np.ndarray,
           cj: np.ndarray, weight: np.ndarray, phase: np.ndarray, y0: np.ndarray,
           t_bound: float, times: np.ndarray, rtol: float, atol: float, bound: float,
           max_evaluations: int, max_wall_s: float) -> Result:
    """Integrates eq. 4-5 as ``solve_ivp(method="DOP853", t_eval=times)`` would.

    Args:
        omega, target, convergence: (n,) 2πν [rad/s], R [m/s], a [1/s].
        ci, cj, weight, phase: (m,) couplings i <- j, w [rad/m], φ [rad].
        y0: (3 n,) initial θ, r, dr/dt.
        t_bound: end time [s].
        times: ascending sample times in [0, t_bound] [s].
        rtol, atol: tolerances.
        bound: max|r| that stops the integration [m/s].
        max_evaluations, max_wall_s: guards.

    Raises:
        RuntimeError: the library is not built.
    """
    if _LIB is None:
        raise RuntimeError("the compiled CPG integrator is not built; reinstall tensim with a "
                           "C compiler, or use SolverSettings(backend='scipy')")
    n, m = omega.size, ci.size
    f64 = [np.ascontiguousarray(x, dtype=np.float64) for x in (omega, target, convergence,
                                                               y0, times)]
    wcos = np.ascontiguousarray(weight * np.cos(phase), dtype=np.float64)
    wsin = np.ascontiguousarray(weight * np.sin(phase), dtype=np.float64)
    idx = [np.ascontiguousarray(x, dtype=np.intc) for x in (ci, cj)]
    out = np.empty((times.size, 2 * n))
    info = np.zeros(2)
    status = _LIB.tensim_cpg_dop853(
        n, m, _doubles(f64[0]), _doubles(f64[1]), _doubles(f64[2]),
        idx[0].ctypes.data_as(_INTS), idx[1].ctypes.data_as(_INTS), _doubles(wcos),
        _doubles(wsin), _doubles(f64[3]), float(t_bound), times.size, _doubles(f64[4]),
        float(rtol), float(atol), float(bound), int(max_evaluations), float(max_wall_s),
        _doubles(out), _doubles(info))
    return Result(int(status), out, float(info[0]), int(info[1]))
