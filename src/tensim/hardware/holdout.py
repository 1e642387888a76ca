"""Which samples of a log can judge a fit: the default hold-out window, chosen where the log
moves, and whether a hold-out holds any excitation at all.

A fit is judged on samples it never saw; on samples where the robot sits still at its rest
tensions, every model that gets the pretension right scores alike, so a poor fit passes. The
*excitation* of a sample row is how far its logged tensions are from the log's typical state:
the root mean square over cables of the reading less that cable's median over the log, less
the log's quietest level (its 10th percentile: the part that never changes, such as the offset
of a median taken over a push). A window's excitation is the mean square of that over its
rows, against the log's mean over all rows.

:func:`default_hold_out` takes, among windows of a quarter of the samples' span, the latest
that is about as excited as a typical window (at least half their median and twice
:data:`MIN_EXCITATION`): a steady gait keeps the last quarter, a push log holds out part of
its push rather than the still robot after it (a log's settling start counts as excitation,
but being short it does not set the typical window). Where no window qualifies, the one
that leaves both itself and the fit's samples the most excited. :func:`hold_out_excitation`
measures a given hold-out; below :data:`MIN_EXCITATION` of the log's mean the fit is not
recommended.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tensim.hardware.logs import HardwareLog

HOLD_OUT = 0.25  # the share of the samples' span held out when no window is given
MIN_EXCITATION = 0.1  # a hold-out below this share of the log's mean excitation checks nothing
_CANDIDATES = 16  # hold-out windows tried, evenly spaced over the span
_QUIET = 10.0  # percentile of the rows' distance from the typical state taken as its floor
_TYPICAL = 0.5  # a default hold-out holds at least this share of the median window's excitation


def excitation(log: HardwareLog) -> tuple[np.ndarray, np.ndarray]:
    """Times [s] from the log's start and each tension row's excitation [N] (see the module)."""
    times, tensions = log.samples("tension")
    typical = np.nanmedian(tensions, axis=0)
    distance = np.sqrt(np.nanmean((tensions - typical) ** 2, axis=1))
    return times, np.maximum(distance - np.percentile(distance, _QUIET), 0.0)


def _energy(logs: Sequence[HardwareLog], inside: tuple[float, float] | None,
            outside: tuple[float, float] | None = None) -> float:
    """Mean over the logs of the excitation's mean square in ``inside`` (None: all) less
    ``outside``, as a share of its mean square over all rows (1: as excited as the log)."""
    shares = []
    for log in logs:
        times, level = excitation(log)
        mean = float(np.mean(level**2))
        keep = np.ones(times.size, bool)
        if inside is not None:
            keep &= (times >= inside[0]) & (times <= inside[1])
        if outside is not None:
            keep &= ~((times >= outside[0]) & (times <= outside[1]))
        if mean <= 0:  # nothing moves anywhere: no window is better than another
            shares.append(1.0)
        elif keep.any():
            shares.append(float(np.mean(level[keep] ** 2)) / mean)
    return float(np.mean(shares)) if shares else 0.0


def default_hold_out(logs: Sequence[HardwareLog], start: float, end: float
                     ) -> tuple[float, float]:
    """The hold-out window [s] when none is given: a quarter of ``start``-``end``, placed
    where both it and the samples left to the fit are excited (see the module).

    Args:
        logs: the logs of the fit.
        start, end: the span the fit and its hold-out share [s].
    """
    width = HOLD_OUT * (end - start)
    starts = np.linspace(start, end - width, _CANDIDATES)
    held = np.array([_energy(logs, (a, a + width)) for a in starts])
    floor = max(_TYPICAL * float(np.median(held)), 2.0 * MIN_EXCITATION)
    typical = np.flatnonzero(held >= floor)
    if typical.size:
        pick = int(typical[-1])
    else:
        left = [_energy(logs, (start, end), (a, a + width)) for a in starts]
        pick = int(np.argmax(np.minimum(held, left)))
    a = float(starts[pick])
    return (a, end) if pick == len(starts) - 1 else (a, a + width)


def hold_out_excitation(logs: Sequence[HardwareLog], window: tuple[float, float]) -> float:
    """The excitation of the samples in ``window`` [s], as a share of the logs' mean (mean
    over the logs; below :data:`MIN_EXCITATION` the window cannot tell fits apart)."""
    return _energy(logs, window)
