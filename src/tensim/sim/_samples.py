"""Recorded samples of a run, and the named channels derived from them.

A sample holds state only: cable lengths and rates, rest lengths, commands, body poses.
Tension, applied force and setpoint are derived afterwards by the laws of
:mod:`tensim.sim._laws` with the model's parameters, exactly as the compiled law computed
them during the step, so single runs and batches record through the same function.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from tensim.model import CompiledModel, ModelIndex
from tensim.model import _law_layout as layout
from tensim.sim import _laws
from tensim.sim._timeseries import TimeSeries

COM = "com"  # the item name of the whole robot's centre of mass in recorded pose channels
CABLE_QUANTITIES = ("tension", "setpoint", "applied", "length", "velocity", "rest_length")


@dataclasses.dataclass
class SampleBuffers:
    """Per-sample state, (n, ...) arrays.

    Attributes:
        time: (n,) sample times [s].
        length, velocity: (n, n_cables) cable length [m] and its rate [m/s].
        rest: (n, n_cables) rest lengths [m].
        command: (n, n_cables) the cable commands of the step (V* [m/s] or rest length [m]).
        pos: (n, n_bodies + 1, 3) body positions, then the centre of mass [m].
        quat: (n, n_bodies, 4) body orientations (w, x, y, z).
        bead: (n, n_beads, 3) positions of the contact cables' beads [m].
    """

    time: np.ndarray
    length: np.ndarray
    velocity: np.ndarray
    rest: np.ndarray
    command: np.ndarray
    pos: np.ndarray
    quat: np.ndarray
    bead: np.ndarray

    @classmethod
    def empty(cls, compiled: CompiledModel, n: int, lead: tuple[int, ...] = ()) -> SampleBuffers:
        """Zeroed buffers for n samples (with leading dimensions ``lead``, e.g. trials)."""
        c, b = compiled.n_cables, len(compiled.index.bodies)
        shape = (*lead, n)
        return cls(np.zeros(shape), np.zeros((*shape, c)), np.zeros((*shape, c)),
                   np.zeros((*shape, c)), np.zeros((*shape, c)), np.zeros((*shape, b + 1, 3)),
                   np.zeros((*shape, b, 4)), np.zeros((*shape, len(compiled.index.beads), 3)))

    def head(self, k: int) -> SampleBuffers:
        """The first k samples."""
        return SampleBuffers(**{f.name: getattr(self, f.name)[:k]
                                for f in dataclasses.fields(self)})

    def put(self, ids: np.ndarray | slice, k: np.ndarray | int, time: np.ndarray,
            fields: dict[str, np.ndarray], index: ModelIndex) -> None:
        """Stores sample k[j] of trial ids[j] from MjData fields, one row per trial.

        Args:
            ids, k: (m,) trials and their sample positions (or every trial, ``slice(None)``,
                at one position).
            time: (m,) the samples' times [s].
            fields: ten_length, ten_velocity, act, ctrl, xpos, xquat, subtree_com, (m, ...).
            index: the model's ids.
        """
        n = len(index.cables)
        self.time[ids, k] = time
        self.length[ids, k] = fields["ten_length"][:, index.tendon]
        self.velocity[ids, k] = fields["ten_velocity"][:, index.tendon]
        self.rest[ids, k] = index.cable_act(fields["act"])
        self.command[ids, k] = fields["ctrl"][:, :n]
        self.pos[ids, k, :-1] = fields["xpos"][:, index.body]
        self.pos[ids, k, -1] = fields["subtree_com"][:, 0]
        self.quat[ids, k] = fields["xquat"][:, index.body]
        if index.beads:
            self.bead[ids, k] = fields["xpos"][:, index.bead]

    def trial(self, i: int) -> SampleBuffers:
        """Trial i's samples, for buffers with a leading trial dimension."""
        return SampleBuffers(**{f.name: getattr(self, f.name)[i]
                                for f in dataclasses.fields(self)})


class SampleRows:
    """Samples of one MjData as rows of one preallocated array, each row filled by one gather.

    Every value a sample holds (cable lengths, rates, rest lengths, commands, body poses, the
    centre of mass, beads) sits in MjData's one buffer of ``mjtNum``, so a single flat view
    over the span of those fields and one index array fetch a whole sample with one
    ``np.take``: no Python per cable or per field while the run records. The columns are
    split into :class:`SampleBuffers` once, at the end.

    Args:
        data: the MjData sampled (kept alive with this object).
        compiled: its compiled model (the cables', bodies' and beads' ids).
        n: samples to hold.
    """

    def __init__(self, data: mujoco.MjData, compiled: CompiledModel, n: int):
        index, c = compiled.index, compiled.n_cables
        self._data, self.k = data, 0
        parts = [("length", data.ten_length, index.tendon),
                 ("velocity", data.ten_velocity, index.tendon),
                 ("rest", data.act, index.rest_act), ("command", data.ctrl, np.arange(c)),
                 ("pos", data.xpos, index.body), ("com", data.subtree_com, np.zeros(1, int)),
                 ("quat", data.xquat, index.body), ("bead", data.xpos, index.bead)]
        self._flat, starts = _flat_view([field for _, field, _ in parts])
        columns, self._spans, at = [], {}, 0
        for (name, field, ids), start in zip(parts, starts, strict=True):
            width = field.shape[1] if field.ndim == 2 else 1
            flat_ids = start + (np.asarray(ids, np.intp)[:, None] * width
                                + np.arange(width)).ravel()
            columns.append(flat_ids)
            self._spans[name] = (at, at + flat_ids.size, width)
            at += flat_ids.size
        self._columns = np.concatenate(columns)
        self._rows = np.empty((n, at))
        self._time = np.empty(n)

    def take(self) -> None:
        """Stores the data's current sample as the next row."""
        self._flat.take(self._columns, out=self._rows[self.k])  # the method: no wrapper
        self._time[self.k] = self._data.time
        self.k += 1

    def buffers(self, dt: float) -> SampleBuffers:
        """The rows taken so far as :class:`SampleBuffers` (sample times from the data's
        times and the physics step ``dt`` [s], see :func:`tensim.sim._loop.sample_time`)."""
        k = self.k

        def part(name: str) -> np.ndarray:
            start, stop, width = self._spans[name]
            block = self._rows[:k, start:stop]
            return block.reshape(k, (stop - start) // width, width) if width > 1 else block

        time = (np.rint(self._time[:k] / dt) - 1) * dt
        pos = np.concatenate([part("pos"), part("com")], axis=1)
        return SampleBuffers(time, part("length"), part("velocity"), part("rest"),
                             part("command"), pos, part("quat"), part("bead"))


def _flat_view(fields: list[np.ndarray]) -> tuple[np.ndarray, list[int]]:
    """One read-only float64 view spanning ``fields`` (arrays in one buffer of float64s, as
    MjData's are) and each field's first element's position in it.

    Raises:
        ValueError: a field is not a C-contiguous float64 array on an 8-byte offset from the
            first (MuJoCo built with another ``mjtNum``).
    """
    held = [f for f in fields if f.size] or [np.zeros(1)]  # an empty field has no place
    address = [f.ctypes.data for f in held]  # (each .ctypes builds an object: once each)
    base = min(address)
    first = held[address.index(base)]
    end = max(a + f.nbytes for a, f in zip(address, held, strict=True))
    for a, f in zip(address, held, strict=True):
        if f.dtype != np.float64 or not f.flags.c_contiguous or (a - base) % 8:
            raise ValueError("MjData's sampled fields must be contiguous float64 arrays in one "
                             "buffer")
    flat = np.lib.stride_tricks.as_strided(first.reshape(-1), shape=((end - base) // 8,),
                                           strides=(8,), writeable=False)
    at = iter(address)
    return flat, [(next(at) - base) // 8 if f.size else 0 for f in fields]


def sample_channels(samples: SampleBuffers, index: ModelIndex, dynprm: np.ndarray,
                    gainprm: np.ndarray) -> TimeSeries:
    """The named channels of recorded samples.

    Args:
        samples: the samples.
        index: the model's names.
        dynprm, gainprm: (n_cables, 10) the cable actuators' law parameters.
    """
    p, g = dynprm, gainprm
    x, v = samples.length, samples.velocity
    tension, applied = _laws.motor_cable_tension(
        x, v, samples.rest, g[:, layout.G_STIFFNESS], g[:, layout.G_DAMPING],
        p[:, layout.P_MODE] == layout.MODE_PD, samples.command, g[:, layout.G_PD_STIFFNESS],
        g[:, layout.G_PD_DAMPING], p[:, layout.P_MAX_TENSION])
    setpoint = _laws.impedance_setpoint(x, v, p[:, layout.P_OFFSET], p[:, layout.P_GAIN_K],
                                        p[:, layout.P_GAIN_B], p[:, layout.P_TARGET_LENGTH],
                                        samples.command)
    setpoint = np.where(p[:, layout.P_MODE] == layout.MODE_IMPEDANCE, setpoint, np.nan)
    cables = {"tension": tension, "setpoint": setpoint, "applied": applied, "length": x,
              "velocity": v, "rest_length": samples.rest}
    # each quantity copied once with its samples last: every channel a contiguous row of it
    channels: dict[str, np.ndarray] = {}
    for q in CABLE_QUANTITIES:
        channels.update(zip([f"{q}/{name}" for name in index.cables],
                            np.ascontiguousarray(cables[q].T), strict=True))
    for prefix, axes, names, values in (
            ("pos", "xyz", (*index.bodies, COM), samples.pos),
            ("quat", "wxyz", index.bodies, samples.quat),
            ("bead", "xyz", index.beads, samples.bead)):  # beads: for drawing replays
        rows = np.ascontiguousarray(np.moveaxis(values, 0, -1))  # (items, axes, samples)
        for name, item in zip(names, rows, strict=True):
            channels.update(zip([f"{prefix}_{axis}/{name}" for axis in axes], item,
                                strict=True))
    return TimeSeries(samples.time.copy(), channels)
