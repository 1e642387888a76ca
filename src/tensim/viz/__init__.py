"""Plots of recorded runs, the viewer, offscreen rendering and run reports.

The plotting functions load matplotlib on first use (``tensim.viz.plot_path``), so importing
a light submodule (``tensim.viz.pacing``) stays fast.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from tensim.viz.plots import (
        plot_cable_tensions,
        plot_lengths,
        plot_path,
        plot_velocity_input,
    )

__all__ = ["plot_cable_tensions", "plot_lengths", "plot_path", "plot_velocity_input"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        return getattr(importlib.import_module("tensim.viz.plots"), name)
    raise AttributeError(f"module 'tensim.viz' has no attribute {name!r}")
