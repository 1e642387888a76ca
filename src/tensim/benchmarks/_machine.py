"""The machine a benchmark runs on: how busy it was, and a busy mode that makes it so.

The benchmarks report CPU time beside wall time: a run's CPU time hardly changes with other
programs' load, its wall time does. :func:`core_share` tells how much of its wall time a run
held a core; :func:`machine_note` says so in one line. :func:`busy` runs a busy loop on every
core but one beside the benchmark (``tensim bench --busy``), so that figures "on a loaded
machine" are taken on one that is loaded, and by the benchmark itself.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import statistics
from collections.abc import Iterator, Sequence

# below this share of its wall time on a core, a run mostly waited for other programs
BUSY_SHARE = 0.85


def core_share(cpu: Sequence[float], wall: Sequence[float], threads: int = 1) -> float:
    """How much of its wall time a run's threads held a core: CPU time / (wall time x
    threads), the median over runs. About 1 on a machine with a free core per thread; lower
    where they waited for one (other programs' load), which stretches the wall time and not
    the CPU time.

    Args:
        cpu: CPU time of each run (any unit).
        wall: wall time of the same runs (the same unit).
        threads: threads each run kept busy.
    """
    return statistics.median(c / (w * threads) for c, w in zip(cpu, wall, strict=True))


def machine_note(shares: dict[str, float], load_at_start: float) -> str:
    """One line on how busy the machine was: its cores, the load average before the runs and
    the lowest core share among ``shares``; below ``BUSY_SHARE`` it says that the wall-time
    figures (and ratios from them) mean little and the CPU-time ones are the figures."""
    who, worst = min(shares.items(), key=lambda item: item[1])
    line = (f"machine: {os.cpu_count()} cores, load average {load_at_start:.2f} before the "
            f"runs; the runs' threads held a core {worst:.0%} of their wall time at worst "
            f"({who})")
    if worst < BUSY_SHARE:
        return line + ": TOO BUSY for the wall-time figures to mean anything; read the " \
                      "CPU-time ones"
    return line


def load_average() -> float:
    """The machine's 1-minute load average (nan where the system gives none)."""
    try:
        return os.getloadavg()[0]
    except OSError:
        return float("nan")


def _spin(stop: multiprocessing.synchronize.Event) -> None:
    """A busy loop until ``stop`` is set (pure Python: it holds a core and nothing else)."""
    count = 0
    while not stop.is_set():
        for _ in range(100_000):
            count += 1


@contextlib.contextmanager
def busy(loops: int | None = None) -> Iterator[int]:
    """Runs ``loops`` busy-loop processes beside the block (None: one per core, so that each of
    the benchmark's threads competes for its core); yields their number.

    They are separate processes (started by ``spawn``: no copy of this one), so their CPU time
    is not the benchmark's own, and they end with the block.
    """
    loops = len(os.sched_getaffinity(0)) if loops is None else loops
    context = multiprocessing.get_context("spawn")
    stop = context.Event()
    workers = [context.Process(target=_spin, args=(stop,), daemon=True) for _ in range(loops)]
    for worker in workers:
        worker.start()
    try:
        yield loops
    finally:
        stop.set()
        for worker in workers:
            worker.join(timeout=5.0)
            if worker.is_alive():
                worker.kill()
