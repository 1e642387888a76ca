"""A log on its own, without simulating: what it holds (rates, channels, gaps, loads,
experiment) and the tension jumps that no logged load explains."""

from __future__ import annotations

from typing import Any

import numpy as np

from tensim.hardware.loads import column_loads, load_window, log_experiment, replay_loads
from tensim.hardware.logs import HardwareLog

JUMP_FACTOR = 5.0  # a jump is this many times the cable's median step between samples...
JUMP_MIN_N = 0.5  # ...and at least this many newtons
JUMP_SETTLE_S = 1.5  # the build transient before this time is not a jump


def unexplained_jumps(log: HardwareLog, settle: float = JUMP_SETTLE_S
                      ) -> list[tuple[float, list[str]]]:
    """Times where tensions jump between consecutive samples while no logged load changes.

    A jump is a step of more than ``JUMP_FACTOR`` times the cable's median step (after
    ``settle`` [s]) and more than ``JUMP_MIN_N``; it is explained when a load changes between
    the two samples. A heuristic: a gait's steps are within 3 times their median, a 22 N push
    ramped over 1 s makes steps of 5-10 times it on the pushed cables.

    Returns:
        (time from the log's start [s], cables) per unexplained jump.
    """
    cables = log.cables("tension")
    times, values = log.samples("tension", cables)
    values = values[times >= settle]
    times = times[times >= settle]
    if times.size < 3:
        return []
    steps = np.abs(np.diff(values, axis=0))
    typical = np.nanmedian(steps, axis=0)
    big = (steps > JUMP_FACTOR * typical) & (steps > JUMP_MIN_N)
    loads = replay_loads(log)
    out = []
    for row in np.flatnonzero(big.any(axis=1)):
        t0, t1 = times[row], times[row + 1]
        probe = np.linspace(t0, t1, 5)
        if any(np.ptp(load.forces_at(probe), axis=0).max() > 0 for load in loads):
            continue
        out.append((float(t1), [c for c, b in zip(cables, big[row], strict=True) if b]))
    return out


def _rate(times: np.ndarray) -> dict[str, float | None]:
    if times.size < 2:
        return {"period_s": None, "max_gap_s": None}
    gaps = np.diff(times)
    return {"period_s": round(float(np.median(gaps)), 6), "max_gap_s": round(float(gaps.max()), 6)}


def summarize_log(log: HardwareLog) -> dict[str, Any]:
    """JSON-ready: duration, rows, per quantity its items, rate and largest gap, the loads
    (node, peak force, window), the experiment, and unexplained tension jumps."""
    quantities: dict[str, Any] = {}
    for quantity in dict.fromkeys(c.partition("/")[0] for c in log.series.channels):
        items = log.series.items(quantity)
        times, _ = log.samples(quantity, items)
        quantities[quantity] = {"items": len(items), "samples": int(times.size),
                                **_rate(times)}
    loads = column_loads(log)
    named = log_experiment(log)
    window = load_window(replay_loads(log))
    return {"log": log.source, "duration_s": round(log.duration, 6),
            "rows": int(log.series.time.size), "quantities": quantities,
            "experiment": None if named is None else {"name": named[0], "params": named[1]},
            "loads": {ld.node: round(float(np.linalg.norm(ld.forces, axis=1).max()), 6)
                      for ld in loads},
            "loads_from": "columns" if loads else ("experiment header" if named else None),
            "load_window_s": list(window) if window else None,
            "unexplained_jumps": [{"time_s": round(t, 6), "cables": c}
                                  for t, c in unexplained_jumps(log)]}
