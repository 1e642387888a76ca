"""The viewer's clock: how many fixed physics steps each drawn frame advances, and key controls.

Kept apart from the window so it can be tested with a fake clock. In real time, simulated time
since the last sync point follows wall-clock time since it, however long a frame takes to draw.
Stepping may take ``budget`` of the wall time between frames: a simulation slower than real time
drops the rest of its debt and takes a new sync point, so it runs as fast as it can while the
window stays live; a stall longer than ``max_lag`` (the window dragged, the process stopped) is
dropped too rather than caught up in a burst, as MuJoCo's own viewer does. Faster than real
time, each frame steps for ``budget`` of the time between frames, then draws.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import threading
import time
from collections.abc import Callable

# GLFW key codes (the passive viewer's key callback receives these)
KEY_SPACE, KEY_ENTER, KEY_BACKSPACE, KEY_RIGHT = 32, 257, 259, 262
_SPEED_WINDOW_S = 2.0  # wall time over which the shown speed is measured

KEY_HELP = "space: pause   right arrow: one step   backspace: reset   enter: fast / real time   " \
           "double-click a body, then ctrl + right drag: push it   tab: MuJoCo's panels"


@dataclasses.dataclass
class ViewerControls:
    """Playback state set by keys in the window's thread and read by the simulation loop.

    Attributes:
        paused: no stepping, except single steps.
        fast: as fast as possible instead of real time.
        pending_steps: single steps asked for while paused.
        reset_requested: start again from the build pose.
    """

    paused: bool = False
    fast: bool = False
    pending_steps: int = 0
    reset_requested: bool = False
    _lock: threading.Lock = dataclasses.field(default_factory=threading.Lock, repr=False,
                                              compare=False)

    def on_key(self, key: int) -> None:
        """Handles one key press (GLFW key code)."""
        with self._lock:
            if key == KEY_SPACE:
                self.paused = not self.paused
            elif key == KEY_RIGHT and self.paused:
                self.pending_steps += 1
            elif key == KEY_BACKSPACE:
                self.reset_requested = True
            elif key == KEY_ENTER:
                self.fast = not self.fast

    def take_steps(self) -> int:
        """The single steps asked for since the last call."""
        with self._lock:
            steps, self.pending_steps = self.pending_steps, 0
            return steps

    def take_reset(self) -> bool:
        """Whether a reset was asked for since the last call."""
        with self._lock:
            asked, self.reset_requested = self.reset_requested, False
            return asked


class Pacer:
    """Decides each frame's physics steps and when the next frame is due.

    Args:
        dt: physics step [s].
        fps: drawing rate [frames/s].
        clock: wall clock [s] (``time.perf_counter``; tests pass a fake one).
        max_lag: a simulated-time debt above this (a stall: the window dragged, the process
            stopped) is dropped rather than caught up in a burst [s].
        budget: share of the wall time between frames that stepping may take; a simulation
            slower than real time drops its debt once it has used that share, so drawing
            goes on.
        chunk_s: simulated time stepped between clock checks [s].
    """

    def __init__(self, dt: float, fps: float = 60.0, clock: Callable[[], float] = time.perf_counter,
                 max_lag: float = 1.0, budget: float = 0.7, chunk_s: float = 0.005):
        if not (dt > 0 and fps > 0 and max_lag > 0 and 0 < budget <= 1):
            raise ValueError("dt, fps and max_lag must be > 0 and budget in (0, 1]")
        self.dt, self.period, self.clock = dt, 1.0 / fps, clock
        self.max_lag, self.budget = max_lag, budget
        self.chunk = max(1, round(chunk_s / dt))
        self.steps = 0
        self._anchor: tuple[float, int] | None = None  # (wall time, steps) of the sync point
        self._last = clock()  # wall time of the last advance
        self._next_frame = self._last
        self._history: collections.deque[tuple[float, int]] = collections.deque()

    def advance(self, controls: ViewerControls, step: Callable[[int], None]) -> int:
        """Runs this frame's physics steps through ``step(n)``; returns how many."""
        now = self.clock()
        budget = self.budget * max(self.period, now - self._last)  # stepping time allowed
        self._last = now
        if controls.paused:
            self._anchor = None  # resume without a burst
            n = controls.take_steps()
            self._step(step, n)
        elif controls.fast:
            self._anchor = None
            n = self._run(step, None, now + budget)
        else:
            n = self._real_time(step, now, budget)
        wall = self.clock()
        self._history.append((wall, self.steps))
        while wall - self._history[0][0] > _SPEED_WINDOW_S:
            self._history.popleft()
        return n

    def _real_time(self, step: Callable[[int], None], now: float, budget: float) -> int:
        if self._anchor is None:
            self._anchor = (now - self.period, self.steps)  # this frame covers one period
        wall, steps = self._anchor
        due = math.floor((now - wall) / self.dt + 1e-9) - (self.steps - steps)
        if due * self.dt > self.max_lag:  # a stall: carry on from here, no burst
            due = round(self.period / self.dt)
            self._anchor = (now - due * self.dt, self.steps)
        n = self._run(step, max(due, 0), now + budget)
        if n < due:  # slower than real time: drop the rest of the debt
            self._anchor = (self.clock(), self.steps)
        return n

    def _run(self, step: Callable[[int], None], due: int | None, deadline: float) -> int:
        """Steps in chunks until ``due`` steps are done (None: no limit) or the deadline."""
        n = 0
        while due is None or n < due:
            k = self.chunk if due is None else min(self.chunk, due - n)
            self._step(step, k)
            n += k
            if self.clock() >= deadline:
                break
        return n

    def _step(self, step: Callable[[int], None], n: int) -> None:
        if n > 0:
            step(n)
            self.steps += n

    @property
    def speed(self) -> float:
        """Simulated seconds per wall-clock second over the last two seconds."""
        if len(self._history) < 2:
            return 0.0
        (wall0, steps0), (wall1, steps1) = self._history[0], self._history[-1]
        return (steps1 - steps0) * self.dt / (wall1 - wall0) if wall1 > wall0 else 0.0

    def wait(self) -> float:
        """Seconds to sleep before the next frame is due (60 Hz drawing); 0 if late."""
        now = self.clock()
        self._next_frame += self.period
        if self._next_frame < now:  # late: draw now, and count the next period from here
            self._next_frame = now
        return self._next_frame - now
