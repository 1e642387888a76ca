"""Per-cable impedance control (paper eq. 3) as a controller description."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from tensim.sim import MODE_IMPEDANCE, CableSetup


@dataclasses.dataclass(frozen=True)
class ImpedanceGains:
    """One cable's impedance law T_set = max(0, T0 + K (L - L*) + B (V - V*)).

    Attributes:
        offset_tension: T0 [N].
        stiffness_gain: K [N/m].
        damping_gain: B [N s/m].
        target_length: L* [m].
    """

    offset_tension: float
    stiffness_gain: float
    damping_gain: float
    target_length: float

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if not value >= 0:
                raise ValueError(f"{field.name} must be >= 0 for a stable law, got {value}")


@dataclasses.dataclass(frozen=True)
class ImpedanceController:
    """Impedance laws for the named cables; other cables keep their rest length.

    Attributes:
        gains: cable name -> its gains.
        target_velocity: V* [m/s], one constant for all cables (gait generators set a table).
    """

    gains: Mapping[str, ImpedanceGains]
    target_velocity: float = 0.0

    def configure(self, sim: CableSetup) -> None:
        """Writes the gains into ``sim.drive`` (the model the simulation steps)."""
        drive = sim.drive
        for name, g in self.gains.items():
            i = sim.index.cable_id(name)
            drive.mode[i] = MODE_IMPEDANCE
            drive.offset_tension[i] = g.offset_tension
            drive.gain_k[i] = g.stiffness_gain
            drive.gain_b[i] = g.damping_gain
            drive.target_length[i] = g.target_length
        if self.target_velocity:
            table = np.full((1, sim.compiled.n_cables), self.target_velocity)
            drive.set_target_velocity(table, 1.0)
