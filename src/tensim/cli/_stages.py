"""CPU time of a command's stages, for ``--timings``: what a whole command costs, and where.

A stage's time is this process's CPU time (``time.process_time``) while it runs; stages do not
overlap. The start-up (Python and the imports before the command runs) is the process's CPU
time when the clock starts; child processes (the drawing process, the OpenGL frame) count
once they have been waited for.
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Iterator


class StageClock:
    """Accumulates CPU seconds per named stage, in the order stages first ran."""

    def __init__(self) -> None:
        self.start_up = time.process_time()  # the interpreter and the imports so far [s]
        self.stages: dict[str, float] = {}

    @contextlib.contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Counts the block's CPU time [s] to ``name``."""
        start = time.process_time()
        try:
            yield
        finally:
            self.stages[name] = self.stages.get(name, 0.0) + time.process_time() - start

    def lines(self) -> list[str]:
        """The table: start-up, each stage, the rest of this process, its children, the
        whole command; CPU seconds."""
        own = time.process_time()
        times = os.times()
        children = times.children_user + times.children_system
        rows = [("Python start-up and the command line's imports", self.start_up),
                *self.stages.items(),
                ("the rest of the command", own - self.start_up - sum(self.stages.values())),
                ("child processes (drawing, the OpenGL frame)", children)]
        width = max(len(name) for name, _ in rows)
        out = ["CPU time by stage [s]:"]
        out += [f"  {name:<{width}}  {seconds:6.2f}" for name, seconds in rows]
        out.append(f"  {'whole command':<{width}}  {own + children:6.2f}")
        return out
