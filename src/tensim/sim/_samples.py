"""Recorded samples of a run, and the named channels derived from them.

A sample holds state only: cable lengths and rates, rest lengths, commands, body poses.
Tension, applied force and setpoint are derived afterwards by the laws of
:mod:`tensim.sim._laws` with the model's parameters, exactly as the compiled law computed
them during the step, so single runs and batches record through the same function.
"""

from __future__ import annotations

import dataclasses

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

    def put(self, ids: np.ndarray, k: np.ndarray, time: np.ndarray,
            fields: dict[str, np.ndarray], index: ModelIndex) -> None:
        """Stores sample k[j] of trial ids[j] from MjData fields, one row per trial.

        Args:
            ids, k: (m,) trials and their sample positions.
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
    tension, applied = _laws.cable_tension(x, v, samples.rest, g[:, layout.G_STIFFNESS],
                                           g[:, layout.G_DAMPING])
    setpoint = _laws.impedance_setpoint(x, v, p[:, layout.P_OFFSET], p[:, layout.P_GAIN_K],
                                        p[:, layout.P_GAIN_B], p[:, layout.P_TARGET_LENGTH],
                                        samples.command)
    setpoint = np.where(p[:, layout.P_MODE] == layout.MODE_IMPEDANCE, setpoint, np.nan)
    cables = {"tension": tension, "setpoint": setpoint, "applied": applied, "length": x,
              "velocity": v, "rest_length": samples.rest}
    channels: dict[str, np.ndarray] = {}
    for q in CABLE_QUANTITIES:
        values = cables[q]
        for i, name in enumerate(index.cables):
            channels[f"{q}/{name}"] = values[:, i].copy()
    for i, name in enumerate((*index.bodies, COM)):
        for a, axis in enumerate("xyz"):
            channels[f"pos_{axis}/{name}"] = samples.pos[:, i, a].copy()
    for i, name in enumerate(index.bodies):
        for a, axis in enumerate("wxyz"):
            channels[f"quat_{axis}/{name}"] = samples.quat[:, i, a].copy()
    for i, name in enumerate(index.beads):  # contact cables' beads: for drawing replays
        for a, axis in enumerate("xyz"):
            channels[f"bead_{axis}/{name}"] = samples.bead[:, i, a].copy()
    return TimeSeries(samples.time.copy(), channels)
