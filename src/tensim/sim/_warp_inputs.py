# mypy: disable-error-code="valid-type, misc"
# (Warp kernel signatures annotate arguments with calls such as wp.array(dtype=float), and
# wp.tid() returns a tuple inside a kernel: mypy reads both as plain Python and cannot follow.)
"""A Warp batch's inputs held on the device (the optional ``tensim[gpu]`` extra).

The host computes the ``ctrl`` rows of every group of worlds that share their inputs (one
gait and clock under other physics) for a stretch of steps once and uploads them; before each
step a kernel copies each world's group's current row into ``ctrl`` and moves a device-side
row index on. Nothing in a record interval then needs the host, so the interval can be captured
as one CUDA graph and replayed with new inputs.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import warp as wp

INPUT_BYTES = 256 * 2**20  # device memory for the held rows of every world [bytes]


@wp.kernel(module="unique", enable_backward=False)
def _use_row(rows: wp.array3d(dtype=float), group: wp.array(dtype=int),
             row: wp.array(dtype=int), ctrl: wp.array2d(dtype=float)):
    """ctrl[world, j] = input j of the current row of the world's group."""
    world, j = wp.tid()
    ctrl[world, j] = rows[group[world], row[0], j]


@wp.kernel(module="unique", enable_backward=False)
def _next_row(row: wp.array(dtype=int)):
    row[0] = row[0] + 1


class HeldInputs:
    """The ``ctrl`` rows of every group of worlds for a stretch of steps, on the device, and
    the index of the next row, also on the device: a kernel copies each world's group's row
    into ``ctrl`` and moves the index on, so a captured sequence of steps replays with new
    inputs and no host work.

    Args:
        group: (worlds,) each world's group: worlds of one group get the same inputs.
        nu: the model's inputs.
        record_steps: physics steps per record (rows are held in whole records).
        total_steps: the steps the run will take (no more rows are ever held).
    """

    def __init__(self, group: np.ndarray, nu: int, record_steps: int, total_steps: int):
        self.device = wp.get_device()
        self.worlds, self.groups = len(group), int(group.max(initial=0)) + 1
        self.nu = max(nu, 1)
        per_record = self.groups * self.nu * record_steps * 4
        records = max(1, INPUT_BYTES // per_record)
        self.capacity = max(record_steps, min(records * record_steps, total_steps))
        self.rows = wp.zeros((self.groups, self.capacity, self.nu), dtype=float)
        self.host = np.zeros((self.groups, self.capacity, self.nu), dtype=np.float32)
        self.group: Any = wp.array(np.asarray(group, dtype=np.int32), dtype=int)
        self.row = wp.zeros(1, dtype=int)
        self.loaded = self.used = 0
        self.remaining = total_steps

    def left(self) -> int:
        """Rows loaded and not yet used."""
        return self.loaded - self.used

    def next_rows(self, nstep: int) -> int:
        """How many rows to load for an advance of ``nstep`` steps: as many as are held, no
        more than the run has left, at least ``nstep``."""
        if nstep > self.capacity:
            raise ValueError(f"an advance of {nstep} steps exceeds the {self.capacity} rows "
                             "held on the device")
        return max(nstep, min(self.capacity, self.remaining))

    def staging(self, rows: int) -> np.ndarray:
        """The host's (groups, rows, nu) buffer to fill with the next ``rows`` rows (one
        buffer, reused: refilled rows, stale ones beyond, which are never read)."""
        return self.host[:, :rows]

    def load(self, rows: int) -> None:
        """Uploads the first ``rows`` rows of :meth:`staging` and starts at the first."""
        self.rows.assign(self.host)
        self.row.zero_()
        self.loaded, self.used = rows, 0

    def consumed(self, nstep: int) -> None:
        """Books ``nstep`` rows as used by the steps just taken."""
        self.used += nstep
        self.remaining -= nstep

    def apply(self, ctrl: Any) -> None:
        """Launches the copy of the next row into ``ctrl`` (worlds, nu) and moves on."""
        if ctrl.shape[1] > 0:  # a model with inputs
            wp.launch(_use_row, dim=(self.worlds, ctrl.shape[1]),
                      inputs=[self.rows, self.group, self.row], outputs=[ctrl])
        wp.launch(_next_row, dim=1, inputs=[self.row])
