"""Commanded rest lengths: the motors wind each cable toward its command at their max_speed.

A cable under a rest-length command is in the drive's rest mode: each step its motor moves the
rest length toward the command, at most ``max_speed`` x dt (the motor law of
:mod:`tensim.sim`; this module only writes the commands, and may lower ``max_speed`` for a
slow, nearly quasi-static wind). It is how an inverse-statics answer
(:func:`tensim.design.inverse_statics`) is applied to a standing robot, and what a controller
file's ``rest_lengths`` section holds.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

from tensim._input import InputError

if TYPE_CHECKING:
    from tensim.sim import CableSetup


@dataclasses.dataclass(frozen=True)
class RestCommand:
    """A controller that commands the named cables' rest lengths (the motors wind there at
    their max_speed); other cables keep theirs.

    Attributes:
        cables: cable names.
        rest_lengths: commanded rest lengths, in the order of ``cables`` [m].
        speed: line speed the motors wind at [m/s], capped by each motor's max_speed (a
            kinematic motor's; None: at max_speed).
    """

    cables: tuple[str, ...]
    rest_lengths: tuple[float, ...]
    speed: float | None = None

    def __post_init__(self) -> None:
        if len(self.cables) != len(self.rest_lengths):
            raise ValueError(f"{len(self.cables)} cables but {len(self.rest_lengths)} rest "
                             "lengths")
        if len(set(self.cables)) != len(self.cables):
            raise ValueError(f"a cable is commanded twice in {list(self.cables)}")
        for name, rest in zip(self.cables, self.rest_lengths, strict=True):
            if not (math.isfinite(rest) and rest > 0):
                raise ValueError(f"rest length of {name!r} must be a finite length > 0 m, "
                                 f"got {rest}")
        if self.speed is not None and not (math.isfinite(self.speed) and self.speed > 0):
            raise ValueError(f"speed must be a finite speed > 0 m/s or None, got {self.speed}")

    def as_dict(self) -> dict[str, float]:
        """Cable name -> commanded rest length [m]."""
        return dict(zip(self.cables, self.rest_lengths, strict=True))

    def configure(self, sim: CableSetup) -> None:
        """Writes the commands into the simulation's drive (cables matched by name).

        Raises:
            InputError: a cable the simulation does not have.
        """
        order = {name: i for i, name in enumerate(sim.index.cables)}
        missing = sorted(set(self.cables) - set(order))
        if missing:
            raise InputError(f"rest-length command names unknown cables {missing}")
        drive = sim.drive
        for name, rest in zip(self.cables, self.rest_lengths, strict=True):
            drive.rest_command[order[name]] = rest
            if self.speed is not None:
                drive.max_speed[order[name]] = min(drive.max_speed[order[name]], self.speed)
