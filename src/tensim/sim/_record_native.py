"""Loads and calls the compiled record loop (``_record.c``): the records of one simulation's
run that need no Python (steps, the ringing check's forces, the sample, the stability bounds),
stepped by MuJoCo's own ``mj_step`` in one call, the same arithmetic as the Python back-end of
:mod:`tensim.sim._simulation` (the reference) to the bit.

The library is optional (built where a C compiler was found at install time); without it, on
the Python cable law, with a callback per record (``on_record``), or where MuJoCo's library or
its error hook cannot be reached, runs record in Python.

MuJoCo's errors: the loop calls ``mj_step`` outside the bindings, whose per-thread error hook
turns an error into ``mujoco.FatalError``; so on loading, where ``mju_user_error`` is unset, this
module sets it to the library's handler, which carries an error inside the loop back out as the
same exception (on any other call, which the bindings' own hook does not cover, it does what
MuJoCo's default does: prints the error and exits). Where another library has set the hook,
runs record in Python.
"""

from __future__ import annotations

import ctypes
import os
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from tensim._native import load_library, log
from tensim.model._law_layout import A_PEAK
from tensim.sim._loop import (
    CHECK_EVERY,
    RING_BAND,
    RING_EVERY,
    RING_FLOOR,
    RING_STEPS,
    next_step,
)

if TYPE_CHECKING:
    from tensim.sim._loop import StabilityLimits
    from tensim.sim._samples import SampleRows
    from tensim.sim._simulation import Simulation

VERSION = 3  # TENSIM_RECORD_VERSION of the sources these bindings were written for
REACHED, CHECK, FAILED, NO_HANDLER = 0, 1, -1, -2
SNAPSHOTS = 16  # energy checks passed in C per call, at most
_P = ctypes.c_void_p


class RecordSpec(ctypes.Structure):
    """What stays the same through a run (``RecordSpec`` in _record.c)."""

    _fields_ = [("step", _P), ("user_error", _P), ("m", _P), ("d", _P),
                *[(name, ctypes.c_int) for name in ("nstep", "n_samples", "check_every",
                                                      "ring_every", "ring_steps",
                                                      "python_checks")],
                ("flat", _P), ("columns", _P), ("ncolumns", ctypes.c_int), ("rows", _P),
                ("times", _P), ("n_cables", ctypes.c_int), ("max_speed", ctypes.c_double),
                ("max_tension", ctypes.c_double), ("peak_act", _P), ("peak_seen", _P),
                ("force", _P), ("count", _P), ("ring_floor", _P), ("n_lin", ctypes.c_int),
                ("lin", _P), ("lin_mass", _P), ("n_free", ctypes.c_int), ("ang", _P),
                ("inertia", _P), ("body", _P), ("mass", _P), ("gravity", _P), ("tendon", _P),
                ("rest", _P), ("stiffness", _P), ("limit", ctypes.c_double),
                ("snapshots", _P), ("snapshot_size", ctypes.c_int),
                ("snapshot_capacity", ctypes.c_int)]


class RecordCursor(ctypes.Structure):
    """Where a run is (``RecordCursor`` in _record.c)."""

    _fields_ = [("k", ctypes.c_longlong), ("sample", ctypes.c_longlong), ("control", _P),
                ("cuts", _P), ("nu", ctypes.c_int), ("done", ctypes.c_longlong),
                ("cut", ctypes.c_longlong), ("pushed", ctypes.c_int), ("checked", ctypes.c_int),
                ("peak_time", ctypes.c_double), ("lowest", ctypes.c_double),
                ("snapshots", ctypes.c_int), ("error", ctypes.c_char * 1024)]


def _mujoco_library() -> ctypes.CDLL | None:
    """MuJoCo's shared library as the bindings loaded it (the same instance: its callbacks
    are the ones the bindings set), or None."""
    folder = os.path.dirname(mujoco.__file__)
    names = sorted(n for n in os.listdir(folder)
                   if n.startswith("libmujoco.so")
                   or (n.startswith("libmujoco.") and n.endswith(".dylib")) or n == "mujoco.dll")
    if not names:
        return None
    try:
        return ctypes.CDLL(os.path.join(folder, names[0]))
    except OSError:
        return None


def _load() -> tuple[ctypes.CDLL, int, ctypes.c_void_p] | None:
    lib = load_library("tensim.sim._record", "compiled record loop", "recording in Python")
    if lib is None:
        return None
    version = getattr(lib, "tensim_record_version", None)
    if version is None or version() != VERSION or \
            lib.tensim_record_spec_size() != ctypes.sizeof(RecordSpec) or \
            lib.tensim_record_cursor_size() != ctypes.sizeof(RecordCursor):
        log.warning("compiled record loop was built from other sources; recording in Python "
                    "(reinstall tensim to rebuild)")
        return None
    if lib.tensim_record_header_version() != mujoco.mj_version():
        log.warning("compiled record loop was built for MuJoCo %s but %s is installed; "
                    "recording in Python (reinstall tensim to rebuild)",
                    lib.tensim_record_header_version(), mujoco.mj_version())
        return None
    engine = _mujoco_library()
    if engine is None:
        log.warning("MuJoCo's library was not found beside its bindings; recording in Python")
        return None
    lib.tensim_record_handler.restype = _P
    lib.tensim_records.restype = ctypes.c_int
    lib.tensim_records.argtypes = [ctypes.POINTER(RecordSpec), ctypes.POINTER(RecordCursor),
                                   ctypes.c_longlong]
    hook = ctypes.c_void_p.in_dll(engine, "mju_user_error")
    handler = lib.tensim_record_handler()
    if hook.value is None:  # the bindings report their own errors through a per-thread hook
        hook.value = handler
    if hook.value != handler:
        log.info("mju_user_error is set by another library; recording in Python")
        return None
    step = ctypes.cast(engine.mj_step, _P).value
    assert step is not None
    return lib, step, hook


_LIB = _load()


def available() -> bool:
    """Whether the compiled record loop is built and MuJoCo's library reachable."""
    return _LIB is not None


_checked: list[bool] = []  # whether MuJoCo's library found is the bindings' (checked once)


def usable(sim: Simulation) -> bool:
    """Whether ``sim`` can record with the compiled loop (see :func:`usable_backend`)."""
    return usable_backend(sim.backend)


def usable_backend(backend: str) -> bool:
    """Whether a simulation on the cable law ``backend`` (resolved: ``"compiled"`` or
    ``"python"``) can record with the compiled loop: it is built, the law is the compiled
    one, and the MuJoCo library found beside the bindings is the one they step (its law
    callback is the one tensim installed through them)."""
    if _LIB is None or backend != "compiled" or RING_STEPS != 3:
        return False
    if not _checked:
        from tensim.sim import _law

        lib = _mujoco_library()
        law = ctypes.cast(_law._C_DYN, _P).value if _law._C_DYN is not None else None
        _checked.append(lib is not None and law is not None
                        and ctypes.c_void_p.in_dll(lib, "mjcb_act_dyn").value == law)
        if not _checked[0]:
            log.warning("MuJoCo's library beside its bindings is not the one they step; "
                        "recording in Python")
    return _checked[0]


class NativeRecords:
    """The compiled record loop of one simulation (its runs: :meth:`begin` each).

    Args:
        sim: the simulation (on the compiled cable law); not kept.
    """

    def __init__(self, sim: Simulation):
        assert _LIB is not None
        self._lib, step, hook = _LIB
        n = sim.compiled.n_cables
        self._peak_act = np.asarray(sim.index.rest_act, np.int64) + A_PEAK
        self._peak_seen = np.zeros(n)
        forces, energy, m = sim._forces, sim._energy, sim.model
        ring_floor = np.maximum(RING_BAND * forces.band, RING_FLOOR)  # as ringing() forms it
        ints = [np.ascontiguousarray(a, np.int64) for a in
                (energy._lin, energy._ang, energy.body, energy.tendon, energy.rest)]
        n_free = energy.body.size
        inertia = np.array([energy._ang_inertia[3 * k:3 * k + 3, 3 * k:3 * k + 3]
                            for k in range(n_free)]).reshape(-1) if n_free else np.zeros(9)
        floats = [np.ascontiguousarray(a, np.float64) for a in
                  (energy._lin_mass, inertia, energy.mass, energy.gravity,
                   0.5 * energy.stiffness)]
        self.fields = (m.nv, 3 * m.nbody, m.ntendon, m.na)  # a snapshot's, after its time
        self.snapshots = np.zeros((SNAPSHOTS, 1 + sum(self.fields)))
        self._keep = (self._peak_act, self._peak_seen, forces.force, forces.count, ring_floor,
                      ints, floats)
        assert forces.count.dtype == np.int64 and forces.force.flags.c_contiguous
        self.spec = RecordSpec(
            step=step, user_error=ctypes.addressof(hook), m=sim.model._address,
            d=sim.data._address, nstep=sim.record_steps, check_every=CHECK_EVERY,
            ring_every=RING_EVERY, ring_steps=RING_STEPS,
            python_checks=int(sim._contact is not None), n_cables=n,
            peak_act=self._peak_act.ctypes.data, peak_seen=self._peak_seen.ctypes.data,
            force=forces.force.ctypes.data, count=forces.count.ctypes.data,
            ring_floor=ring_floor.ctypes.data, n_lin=ints[0].size, lin=ints[0].ctypes.data,
            lin_mass=floats[0].ctypes.data, n_free=n_free, ang=ints[1].ctypes.data,
            inertia=floats[1].ctypes.data, body=ints[2].ctypes.data, mass=floats[2].ctypes.data,
            gravity=floats[3].ctypes.data, tendon=ints[3].ctypes.data, rest=ints[4].ctypes.data,
            stiffness=floats[4].ctypes.data, limit=sim._energies.limit,
            snapshots=self.snapshots.ctypes.data, snapshot_size=self.snapshots.shape[1],
            snapshot_capacity=SNAPSHOTS)
        self.cursor = RecordCursor()
        self._spec_ref, self._cursor_ref = ctypes.byref(self.spec), ctypes.byref(self.cursor)
        self.rows: SampleRows | None = None

    def begin(self, rows: SampleRows, n_samples: int, limits: StabilityLimits) -> None:
        """Starts a run of ``n_samples`` records into ``rows`` under ``limits``."""
        spec = self.spec
        spec.n_samples, spec.max_speed, spec.max_tension = \
            n_samples, limits.max_speed, limits.max_tension
        spec.flat, spec.columns, spec.ncolumns = \
            rows._flat.ctypes.data, rows._columns.ctypes.data, rows._columns.size
        spec.rows, spec.times = rows._rows.ctypes.data, rows._time.ctypes.data
        self.rows = rows  # (keeps the arrays alive)

    def run(self, sim: Simulation, k: int, stop: int, control: np.ndarray, cuts: np.ndarray,
            done: int, cut: int) -> tuple[int, int, int, int]:
        """Records k .. stop - 1 of ``sim``'s run on the block ``control`` (rows ``done`` on
        stepped; ``cut`` the run of equal rows they are in, whose ends are ``cuts``).

        Returns:
            (status, the next record, the block's rows stepped, the run they are in).

        Raises:
            mujoco.FatalError: MuJoCo raised an error.
        """
        c, rows = self.cursor, self.rows
        assert rows is not None
        c.k, c.sample, c.control, c.cuts = k, rows.k, control.ctypes.data, cuts.ctypes.data
        c.nu, c.done, c.cut, c.pushed = control.shape[1], done, cut, int(sim._forces.fresh)
        c.lowest = sim._energies.lowest[0]
        status = self._lib.tensim_records(self._spec_ref, self._cursor_ref, stop)
        if status == FAILED:
            raise mujoco.FatalError(c.error.decode(errors="replace"))
        rows.k = c.sample
        sim._forces.fresh = bool(c.pushed)
        if c.checked:
            sim._peak_seen = ((next_step(c.peak_time, sim.dt) - 1) * sim.dt,
                              self._peak_seen.copy())
        for row in self.snapshots[:c.snapshots]:  # the exact energies, in turn
            nv, nx, nt, _ = self.fields
            sim._check_energy((row[1:1 + nv][None], row[1 + nv:1 + nv + nx].reshape(1, -1, 3),
                               row[1 + nv + nx:1 + nv + nx + nt][None],
                               row[1 + nv + nx + nt:][None]),
                              (next_step(float(row[0]), sim.dt) - 1) * sim.dt)
        return status, c.k, c.done, c.cut
