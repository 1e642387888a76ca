"""Per-cable impedance control (paper eq. 3) as a controller description."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from tensim.sim import MODE_IMPEDANCE, CableSetup, load_cell_tension
from tensim.structure import Structure


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


# default gains of :func:`default_impedance`: K as stiff as the cable itself, B = K x 0.2 s
DEFAULT_DAMPING_TIME = 0.2  # s


def default_impedance(structure: Structure, stiffness_gain: float | None = None,
                      damping_time: float = DEFAULT_DAMPING_TIME) -> ImpedanceController:
    """Impedance laws that hold a structure's build pose, one per motorised cable.

    Each cable gets T0 = its build pretension k (x - l) [N] and L* = its build length x [m],
    so T_set equals the tension it was built with wherever the robot keeps its shape; K
    defaults to the cable's own stiffness k [N/m] and B = K x ``damping_time`` [N s/m].
    Passive cables (no motor) get no law.

    Args:
        structure: the robot in its build pose.
        stiffness_gain: K for every cable [N/m] (None: each cable's stiffness).
        damping_time: B / K [s].

    Raises:
        ValueError: no motorised cable, a cable wrapped around rods (its build length is known
            only once compiled: give its target length by hand), or negative gains.
    """
    gains = {}
    for cable in structure.cables:
        if cable.motor.passive:
            continue
        if cable.wrap:
            raise ValueError(f"cable {cable.name!r} wraps around rods, so its build length is "
                             "known only once compiled; write its impedance gains by hand")
        length = structure.cable_length(cable)
        k = cable.stiffness if stiffness_gain is None else stiffness_gain
        pretension = float(load_cell_tension(length, structure.rest_length(cable),
                                             cable.stiffness))
        gains[cable.name] = ImpedanceGains(round(pretension, 6), k, k * damping_time,
                                           round(length, 6))  # µN, µm: a file one reads
    if not gains:
        raise ValueError(f"{structure.name!r} has no motorised cable to control: give its "
                         "cables a 'motor' (or the file's defaults.cable a motor)")
    return ImpedanceController(gains)
