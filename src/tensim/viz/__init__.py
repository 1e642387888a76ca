"""Plots of recorded runs."""

from tensim.viz.plots import (
    plot_cable_tensions,
    plot_lengths,
    plot_path,
    plot_velocity_input,
)

__all__ = ["plot_cable_tensions", "plot_lengths", "plot_path", "plot_velocity_input"]
