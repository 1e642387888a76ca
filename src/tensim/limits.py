"""Bounds on the work one command may ask for, checked before anything is allocated or run.

A simulation of ``duration`` seconds at physics step ``dt`` takes ``duration / dt`` steps and
records ``duration / record_dt`` samples; terrains and hardware logs have sizes too. A request
past these bounds (a typo such as ``--dt 1e-9`` or ``--duration 1e9`` more often than a wish)
is refused with the figure and the limit; ``tensim --force ...`` runs it anyway.
"""

from __future__ import annotations

import math

from tensim._input import MAX_NODES as MAX_YAML_VALUES
from tensim._input import InputError

MAX_STEPS = 100_000_000  # physics steps of one simulation (about an hour of compute)
MAX_SAMPLES = 10_000_000  # recorded samples of one simulation or log
MAX_TERRAIN_BOXES = 10_000  # boxes of one terrain (steps, blocks)
MAX_GRID_CELLS = 4_000_000  # cells of one height field
MAX_BEADS = 10_000  # contact-cable beads of one model (three degrees of freedom each)
__all__ = ["MAX_BEADS", "MAX_GRID_CELLS", "MAX_SAMPLES", "MAX_STEPS", "MAX_TERRAIN_BOXES",
           "MAX_YAML_VALUES", "check_count", "check_run"]


def check_count(what: str, count: float, limit: int, *, force: bool = False,
                forceable: bool = True) -> None:
    """Refuses ``count`` items of ``what`` past ``limit`` unless forced.

    Raises:
        InputError: naming the figure, the limit and (if ``forceable``) how to force it.
    """
    if not math.isfinite(count) or (count > limit and not force):
        hint = ", or run `tensim --force ...` to go past the limit" if forceable else ""
        raise InputError(f"{what}: {count:.4g} is more than the limit of {limit:.4g}; "
                         f"ask for less{hint}")


def check_run(duration: float, dt: float, record_dt: float | None = None, *,
              force: bool = False) -> None:
    """Refuses a simulation of ``duration`` [s] at step ``dt`` [s] (recorded every ``record_dt``
    [s]) that would take more than :data:`MAX_STEPS` steps or :data:`MAX_SAMPLES` samples.

    Raises:
        InputError: a non-finite or non-positive time, or a run past a limit (unless forced).
    """
    for name, value in (("duration", duration), ("dt", dt), ("record_dt", record_dt)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise InputError(f"{name} must be a finite time > 0 s, got {value!r}")
    if duration < dt:
        raise InputError(f"duration {duration:g} s is shorter than one physics step ({dt:g} s)")
    check_count(f"{duration:g} s at a physics step of {dt:g} s: physics steps",
                duration / dt, MAX_STEPS, force=force)
    if record_dt is not None:
        check_count(f"{duration:g} s recorded every {record_dt:g} s: recorded samples",
                    duration / record_dt, MAX_SAMPLES, force=force)
