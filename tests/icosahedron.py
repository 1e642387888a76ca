"""The symmetric six-bar's (expanded octahedron's) node positions, shared by the rolling tests."""

from __future__ import annotations

import numpy as np


def six_bar_points(strut: float) -> dict[str, np.ndarray]:
    """The 12 nodes [m] of six struts of length ``strut`` in three parallel pairs, ``strut / 2``
    apart, centred on the origin: ``"{axis}{pair}{end}"``, each pair along ``axis``."""
    h, s = strut / 2, strut / 4
    points = {}
    for axis, perm in (("x", (2, 0, 1)), ("y", (1, 2, 0)), ("z", (0, 1, 2))):
        for pair, offset in enumerate((-s, s)):
            for end, along in enumerate((-h, h)):
                points[f"{axis}{pair}{end}"] = np.array([0.0, offset, along])[list(perm)]
    return points
