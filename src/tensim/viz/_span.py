"""A shaded time span of a figure (plain data: importing it loads no plotting library)."""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Span:
    """A shaded time span of a tension plot: ``start`` to ``stop`` [s], named in the legend."""

    start: float
    stop: float
    label: str
    alpha: float = 0.12
    color: str = "tab:orange"
