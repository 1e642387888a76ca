"""Helpers shared by the gait generators: broadcasting, sample grids, spine joints, V* tables."""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence

import numpy as np

from tensim.control.impedance import ImpedanceController
from tensim.sim import CableSetup
from tensim.structure import Cable

_JOINT_TAG = re.compile(r"joint_(\d+)")


# -- helpers shared by the gait generators --------------------------------------------------------


def joint_index(cable: Cable) -> int:
    """The spine joint a cable spans, from its ``joint_<j>`` tag.

    Raises:
        ValueError: the cable has no ``joint_<j>`` tag, or more than one.
    """
    joints = [int(m.group(1)) for tag in cable.tags if (m := _JOINT_TAG.fullmatch(tag))]
    if len(joints) != 1:
        raise ValueError(f"cable {cable.name!r} needs exactly one 'joint_<j>' tag to place it "
                         f"on the spine, has tags {cable.tags!r}")
    return joints[0]


def has_joint_tag(cable: Cable) -> bool:
    """Whether a cable carries a ``joint_<j>`` tag."""
    return any(_JOINT_TAG.fullmatch(tag) for tag in cable.tags)


def sample_times(duration: float, sample_dt: float) -> np.ndarray:
    """Sample times 0, dt, 2 dt, ... up to ``duration`` inclusive [s].

    Args:
        duration: covered time [s], > 0.
        sample_dt: sampling period [s], > 0.

    Raises:
        ValueError: a non-positive or non-finite duration or period.
    """
    if not (math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a finite time > 0 s, got {duration}")
    if not (math.isfinite(sample_dt) and sample_dt > 0):
        raise ValueError(f"sample_dt must be a finite period > 0 s, got {sample_dt}")
    n = math.floor(duration / sample_dt + 1e-9) + 1
    return np.arange(n) * sample_dt


def check_driven(impedance: ImpedanceController, cables: Iterable[str]) -> None:
    """Raises ValueError if a cable given a V* is not under the impedance law (V* is unused)."""
    missing = [c for c in cables if c not in impedance.gains]
    if missing:
        raise ValueError(f"cables {missing} get a target velocity but have no impedance gains, "
                         "so V* would have no effect; add them to the ImpedanceController")


def write_target_velocity(sim: CableSetup, cables: Sequence[str], table: np.ndarray,
                          table_dt: float) -> None:
    """Writes a gait's V* table into ``sim.drive``; cables not named get V* = 0.

    Args:
        sim: the simulation.
        cables: the names of ``table``'s columns.
        table: (rows, len(cables)) target velocities [m/s], row r for t in [r, r+1)·table_dt.
        table_dt: row period [s].

    Raises:
        KeyError: an unknown cable.
        ValueError: a table that does not match ``cables``.
    """
    sim.drive.set_target_velocity(full_table(sim, cables, table), table_dt)


def full_table(sim: CableSetup, cables: Sequence[str], table: np.ndarray) -> np.ndarray:
    """(rows, n_cables) ``table``'s columns placed at their cables, zeros elsewhere [m/s].

    Raises:
        KeyError: an unknown cable.
        ValueError: a table that does not match ``cables``.
    """
    table = np.asarray(table, dtype=float)
    if table.ndim != 2 or table.shape[1] != len(cables):
        raise ValueError(f"table must be (rows, {len(cables)}), got {table.shape}")
    full = np.zeros((table.shape[0], sim.compiled.n_cables))
    for column, name in enumerate(cables):
        full[:, sim.index.cable_id(name)] = table[:, column]
    return full


def per_item(value: float | Sequence[float], n: int, what: str, item: str = "cable"
             ) -> tuple[float, ...]:
    """A scalar broadcast to ``n`` items, or ``n`` given values; all finite.

    Raises:
        ValueError: wrong count or a non-finite value, naming ``what``.
    """
    array = np.asarray(value)  # as np.ndim would; tolist() hands back the items as given
    values = (float(array),) * n if array.ndim == 0 else tuple(float(v) for v in array.tolist())
    if len(values) != n:
        raise ValueError(f"{what} needs one value per {item} ({n}), got {len(values)}")
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"{what} must be finite, got {values}")
    return values


def as_tuple(value: float | tuple[float, ...]) -> tuple[float, ...]:
    """A per-item record field as the tuple its ``__post_init__`` made of it."""
    return value if isinstance(value, tuple) else (value,)
