"""Loads and calls the compiled observation (``_observe.c``): the rolling observation's terms
of many robots in one call, the same values as
:meth:`tensim.rl._worlds.Worlds.observe_numpy` (the reference) to the bit.

The library is optional (built where a C compiler was found at install time); without it, or
for an observation with a term it does not write (``pose``, ``rest_length``, ``tension``), a
robot without ground contact sensors, or more rod ends than it holds, the environments observe
with NumPy.
"""

from __future__ import annotations

import ctypes
from typing import Any

import numpy as np

from tensim._native import load_library, log

TERMS = ("height", "velocity", "rod_axis", "cable_length", "contact", "end_contact", "task",
         "previous_action", "position")  # the terms it writes (with the layout's names)
MAX_ENDS = 256  # rod ends the kernel's buffer holds
VERSION = 1  # TENSIM_OBSERVE_VERSION of the sources these bindings were written for
_FIELDS = ("subtree_com", "xipos", "xpos", "xmat", "cvel", "ten_length", "sensordata")
_TASKS = {"direction": 1, "goal": 2}  # any other task observes (0, 0)
_P = ctypes.c_void_p


class Spec(ctypes.Structure):
    """The kernel's arguments that stay the same from call to call (``Spec`` in _observe.c)."""

    _fields_ = [
        *[(name, _P) for name in _FIELDS],
        *[(f"{name}_stride", ctypes.c_longlong) for name in _FIELDS],
        ("target", _P), ("previous", _P),
        ("n_bodies", ctypes.c_int), ("body", _P), ("root", _P), ("mass", _P),
        ("n_ends", ctypes.c_int), ("end_body", _P), ("end_local", _P),
        ("n_cables", ctypes.c_int), ("tendon", _P), ("n_motors", ctypes.c_int),
        ("sensor_adr", _P), ("slots", ctypes.c_int), ("most", ctypes.c_int),
        ("body_ends", _P), ("task", ctypes.c_int),
        *[(name, ctypes.c_int) for name in ("height", "velocity", "rod_axis", "cable_length",
                                              "contact", "end_contact", "task_column",
                                              "previous_action", "position", "size")]]


def _load_library() -> ctypes.CDLL | None:
    lib = load_library("tensim.rl._observe", "compiled RL observation",
                       "observing with NumPy")
    if lib is None:
        return None
    version = getattr(lib, "tensim_observe_version", None)
    if version is None or version() != VERSION or \
            lib.tensim_observe_spec_size() != ctypes.sizeof(Spec):
        log.warning("compiled RL observation was built from other sources; observing with "
                    "NumPy (reinstall tensim to rebuild)")
        return None
    lib.tensim_observe.restype = ctypes.c_int
    lib.tensim_observe.argtypes = [ctypes.POINTER(Spec), ctypes.c_int, _P, _P, _P, _P, _P]
    return lib


_LIB = _load_library()


def available() -> bool:
    """Whether the compiled observation is built."""
    return _LIB is not None


def kernel(fields: dict[str, np.ndarray], arrays: dict[str, np.ndarray],
           index: dict[str, Any], layout: dict[str, tuple[int, int]], task: str
           ) -> Kernel | None:
    """The compiled observation of these robots, or None where it cannot write it (not built,
    a term it does not write, contact terms without the ground sensors, more than
    :data:`MAX_ENDS` rod ends, or fields it cannot read in place). Arguments: :class:`Kernel`.
    """
    terms = set(layout) - {"history"}
    contact = bool({"contact", "end_contact"} & terms)
    rows = [fields[k] for k in _FIELDS if k in fields] + [arrays["target"], arrays["previous"]]
    if (_LIB is None or not terms <= set(TERMS) or (contact and index["sensor_adr"] is None)
            or len(index["end_body"]) > MAX_ENDS
            or not all(a.dtype == np.float64 and a[0].flags.c_contiguous for a in rows)
            or not all(a.flags.c_contiguous for a in (arrays["target"], arrays["previous"]))):
        return None
    return Kernel(fields, arrays, index, layout, task)


class Kernel:
    """The compiled observation of one :class:`~tensim.rl._worlds.Worlds` (made by
    :func:`kernel`, which checks what it needs).

    Args:
        fields: the batch engine's bound fields (``Worlds.f``), which it reads in place
            (``sensordata`` may be missing where no contact term is observed).
        arrays: the environment's (n, 2) ``target`` and (n, n_motors) ``previous``, read in
            place (so written in place by their owner).
        index: ``body``, ``root`` (MuJoCo ids, (n_bodies,)), ``mass`` (n_bodies,) fractions,
            ``end_body`` (n_ends,), ``end_local`` (n_ends, 3), ``tendon`` (n_cables,),
            ``sensor_adr`` (n_bodies,) or None, ``body_ends`` (n_bodies, most; -1 padding),
            ``slots``.
        layout: each term's (start, stop) in the clean observation (before any history).
        task: the config's task.
    """

    def __init__(self, fields: dict[str, np.ndarray], arrays: dict[str, np.ndarray],
                 index: dict[str, Any], layout: dict[str, tuple[int, int]], task: str):
        none = np.zeros(0)
        self._last: tuple[tuple[np.ndarray, ...], tuple[int, ...]] = ((none,) * 4, ())
        self._over = np.zeros(len(arrays["target"]), dtype=np.uint8)  # one flag per robot
        self._over_at = int(self._over.ctypes.data)
        keep: list[np.ndarray] = []  # everything the kernel points at, alive as long as it

        def pointer(array: np.ndarray, dtype: type) -> int:
            array = np.ascontiguousarray(array, dtype=dtype)
            keep.append(array)
            return int(array.ctypes.data)

        spec = Spec()
        for name in _FIELDS:  # rows of doubles, one robot after another at a fixed stride
            field = fields.get(name, np.zeros((1, 1)))
            keep.append(field)
            setattr(spec, name, int(field.ctypes.data))
            setattr(spec, f"{name}_stride", field.strides[0] // 8 if name in fields else 0)
        for name in ("target", "previous"):
            keep.append(arrays[name])
            setattr(spec, name, int(arrays[name].ctypes.data))
        n_bodies = len(index["body"])
        sensors = index["sensor_adr"]
        for name, values in (("body", index["body"]), ("root", index["root"]),
                             ("end_body", index["end_body"]), ("tendon", index["tendon"]),
                             ("sensor_adr", np.zeros(n_bodies) if sensors is None else sensors),
                             ("body_ends", index["body_ends"])):
            setattr(spec, name, pointer(np.asarray(values), np.intc))
        for name in ("mass", "end_local"):
            setattr(spec, name, pointer(np.asarray(index[name]), np.float64))
        spec.n_bodies, spec.n_ends = n_bodies, len(index["end_body"])
        spec.n_cables, spec.n_motors = len(index["tendon"]), arrays["previous"].shape[1]
        spec.slots, spec.most = index["slots"], np.shape(index["body_ends"])[1]
        spec.task = _TASKS.get(task, 0)
        for name in TERMS:
            setattr(spec, "task_column" if name == "task" else name,
                    layout[name][0] if name in layout else -1)
        self.size = max(stop for name, (_, stop) in layout.items() if name != "history")
        spec.size = self.size
        self._spec, self._keep = spec, keep
        self._ref = ctypes.byref(spec)

    def observe(self, ids: np.ndarray, cosine: np.ndarray, sine: np.ndarray,
                out: np.ndarray) -> np.ndarray | None:
        """Writes robots ``ids``' observations into ``out`` (k, size), in the frames whose
        (k,) ``cosine`` and ``sine`` are given.

        Args:
            ids: (k,) robots (C ints).
            cosine, sine: (k,) or (k, 1) doubles.
            out: (k, size) doubles, C-contiguous.

        Returns:
            None, or where some robots' contact flags must come from their contact lists,
            those robots as a (k,) bool mask.

        Raises:
            ValueError: arrays of another type, shape or layout (the kernel reads them raw).
        """
        arrays = (ids, cosine, sine, out)
        last, pointers = self._last
        # the same arrays as the last call (the common case: the environment's own), whose
        # checks and addresses hold: held here, they cannot have been freed
        if not (ids is last[0] and cosine is last[1] and sine is last[2] and out is last[3]):
            pointers = self._pointers(arrays)
            self._last = arrays, pointers
        k = ids.size
        if not _LIB.tensim_observe(self._ref, k, *pointers, self._over_at):  # type: ignore[union-attr]
            return None
        return self._over[:k].astype(bool)

    def _pointers(self, arrays: tuple[np.ndarray, ...]) -> tuple[int, ...]:
        ids, cosine, sine, out = arrays
        k = ids.size
        if not (ids.dtype == np.intc and out.dtype == np.float64 and out.shape == (k, self.size)
                and cosine.dtype == sine.dtype == np.float64 and cosine.size == sine.size == k
                and k <= self._over.size and all(a.flags.c_contiguous for a in arrays)):
            raise ValueError("compiled observation: ids, frames or out of the wrong type, "
                             "shape or layout")
        return tuple(int(a.ctypes.data) for a in arrays)
