# mypy: disable-error-code="valid-type, misc"
# (Warp kernel signatures annotate arguments with calls such as wp.array(dtype=float), and
# wp.tid() returns a tuple inside a kernel: mypy reads both as plain Python and cannot follow.)
"""A Warp batch's inputs held on the device (the optional ``tensim[gpu]`` extra).

The host computes every world's ``ctrl`` rows for a stretch of steps once and uploads them;
before each step a kernel copies the current row into ``ctrl`` and moves a device-side row
index on. Nothing in a record interval then needs the host, so the interval can be captured
as one CUDA graph and replayed with new inputs.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import warp as wp

INPUT_BYTES = 256 * 2**20  # device memory for the held rows of every world [bytes]


@wp.kernel(module="unique", enable_backward=False)
def _use_row(rows: wp.array3d(dtype=float), row: wp.array(dtype=int),
             ctrl: wp.array2d(dtype=float)):
    """ctrl[world, j] = the current row's input j of that world."""
    world, j = wp.tid()
    ctrl[world, j] = rows[world, row[0], j]


@wp.kernel(module="unique", enable_backward=False)
def _next_row(row: wp.array(dtype=int)):
    row[0] = row[0] + 1


class HeldInputs:
    """Every world's ``ctrl`` rows for a stretch of steps, on the device, and the index of the
    next row, also on the device: a kernel copies that row into ``ctrl`` and moves the index
    on, so a captured sequence of steps replays with new inputs and no host work.

    Args:
        worlds, nu: the batch's worlds and the model's inputs.
        record_steps: physics steps per record (rows are held in whole records).
        total_steps: the steps the run will take (no more rows are ever held).
    """

    def __init__(self, worlds: int, nu: int, record_steps: int, total_steps: int):
        self.device = wp.get_device()
        self.worlds, self.nu = worlds, max(nu, 1)
        per_record = worlds * self.nu * record_steps * 4
        records = max(1, INPUT_BYTES // per_record)
        self.capacity = max(record_steps, min(records * record_steps, total_steps))
        self.rows = wp.zeros((worlds, self.capacity, self.nu), dtype=float)
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

    def load(self, control: np.ndarray) -> None:
        """Replaces the held rows by ``control`` (worlds, rows, nu) and starts at its first."""
        held = np.zeros((self.worlds, self.capacity, self.nu), dtype=np.float32)
        held[:, :control.shape[1], :control.shape[2]] = control
        self.rows.assign(held)
        self.row.zero_()
        self.loaded, self.used = control.shape[1], 0

    def consumed(self, nstep: int) -> None:
        """Books ``nstep`` rows as used by the steps just taken."""
        self.used += nstep
        self.remaining -= nstep

    def apply(self, ctrl: Any) -> None:
        """Launches the copy of the next row into ``ctrl`` (worlds, nu) and moves on."""
        if ctrl.shape[1] > 0:  # a model with inputs
            wp.launch(_use_row, dim=(self.worlds, ctrl.shape[1]),
                      inputs=[self.rows, self.row], outputs=[ctrl])
        wp.launch(_next_row, dim=1, inputs=[self.row])
