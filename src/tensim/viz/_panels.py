"""Which cables share a panel of a per-cable figure (plain data: importing it loads no
plotting library, so the command's process can tell what a figure will draw)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

# More cables than this share panels: one panel per group of cables (see cable_panels), so a
# robot of hundreds of cables still gets a figure of a few rows that draws in seconds.
MAX_PANELS = 30

Panel = tuple[str, tuple[str, ...]]  # a panel's title and the cables it draws


def cable_panels(cables: Sequence[str], tags: Mapping[str, Sequence[str]] | None = None,
                 limit: int = MAX_PANELS) -> tuple[Panel, ...]:
    """The panels of a per-cable figure: one per cable up to ``limit`` cables, else groups.

    Groups are the finest of these partitions with at most ``limit`` groups (and at least
    two): by the cables' name paths (``p1/spine/string_0`` in ``p1/spine`` or ``p1``, as the
    NTRT importer names them) and by their first tag (``outer_left``). Where none fits, the
    cables in their order in ``limit`` runs of equal size.

    Args:
        cables: cable names, in panel order.
        tags: each cable's tags (None: group by names alone).
        limit: most panels.

    Returns:
        (title, cables) per panel.
    """
    if len(cables) <= limit:
        return tuple((name, (name,)) for name in cables)
    tags = tags or {}
    depths = range(1, max(name.count("/") for name in cables) + 1)
    partitions = [[_path(name, d) for name in cables] for d in depths]
    partitions.append([next(iter(tags.get(name, ())), "(untagged)") for name in cables])
    best: dict[str, list[str]] = {}
    for keys in partitions:
        groups: dict[str, list[str]] = {}
        for key, name in zip(keys, cables, strict=True):
            groups.setdefault(key, []).append(name)
        if len(best) < len(groups) <= limit:
            best = groups
    if len(best) >= 2:
        return tuple((f"{key} ({len(group)} cables)", tuple(group))
                     for key, group in best.items())
    size = math.ceil(len(cables) / limit)
    runs = [tuple(cables[k:k + size]) for k in range(0, len(cables), size)]
    return tuple((f"{run[0]} ... {run[-1]} ({len(run)} cables)", run) for run in runs)


def _path(name: str, depth: int) -> str:
    """The first ``depth`` parts of a cable name's path (``p1/spine/string_0``: ``p1``,
    ``p1/spine``)."""
    return "/".join(name.split("/")[:-1][:depth]) or "(top level)"
