"""Figures of the reality gap: tension overlays as in the paper (hardware red, simulation
black, setpoint blue) and the load-cell calibration as in its Fig. 2."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from tensim.hardware.compare import Comparison
from tensim.hardware.loadcell import CalibrationFit
from tensim.viz.plots import new_figure, save_figure

HARDWARE, SIMULATION, SETPOINT = "tab:red", "black", "tab:blue"


def plot_overlay(comparison: Comparison, path: Path, *, title: str = "", columns: int = 3
                 ) -> Path:
    """One panel per cable: logged tension (red), simulated (black), logged setpoint (blue).

    Args:
        comparison: the aligned series.
        path: PNG file to write (atomically).
        title: figure title.
        columns: panels per row.
    """
    cables = comparison.cables
    rows = math.ceil(len(cables) / columns)
    fig = new_figure((4.2 * columns, 2.4 * rows))
    axes = fig.subplots(rows, columns, sharex=True, squeeze=False)
    t = comparison.time
    for k, (ax, name) in enumerate(zip(axes.flat, cables, strict=False)):
        if comparison.setpoint is not None and np.isfinite(comparison.setpoint[:, k]).any():
            ax.plot(t, comparison.setpoint[:, k], color=SETPOINT, lw=0.8, ls="--",
                    label="hardware setpoint")
        ax.plot(t, comparison.hardware[:, k], color=HARDWARE, lw=1.0, label="hardware")
        ax.plot(t, comparison.simulated[:, k], color=SIMULATION, lw=1.0, label="simulation")
        ax.set_title(name, fontsize=9)
        ax.set_ylabel("tension [N]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(cables):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]", fontsize=8)
    axes.flat[0].legend(fontsize=7, loc="best")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path, dpi=90)


def plot_system(comparison: Comparison, path: Path, *, title: str = "") -> Path:
    """The largest cable tension at each sample, logged (red) and simulated (black)."""
    fig = new_figure((8, 3))
    ax = fig.subplots()
    with np.errstate(all="ignore"):
        hw = np.nanmax(comparison.hardware, axis=1)
        sim = np.nanmax(comparison.simulated, axis=1)
    ax.plot(comparison.time, hw, color=HARDWARE, lw=1.0, label="hardware")
    ax.plot(comparison.time, sim, color=SIMULATION, lw=1.0, label="simulation")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("max cable tension [N]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path, dpi=90)


def plot_calibration(fit: CalibrationFit, path: Path) -> Path:
    """Applied force against ADC counts with the fitted line, and the residuals (paper Fig. 2)."""
    fig = new_figure((6, 5.5))
    top, bottom = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": (3, 1.3)})
    cell = fit.loadcell
    span = np.linspace(fit.adc.min(), fit.adc.max(), 2)
    top.plot(fit.adc, fit.force, "o", color=HARDWARE, ms=4, label="calibration pairs")
    sign = "-" if cell.offset < 0 else "+"
    top.plot(span, cell.to_newtons(span), color=SIMULATION, lw=1.0,
             label=f"f = {cell.gain:.4f} ADC {sign} {abs(cell.offset):.4f}")
    top.axhline(cell.max_force, color="gray", lw=0.8, ls=":",
                label=f"max measurable {cell.max_force:g} N")
    top.set_ylabel("force [N]")
    top.legend(fontsize=8)
    top.grid(alpha=0.3)
    top.set_title(f"load-cell calibration: {cell.gain:.4f} N per count, "
                  f"R² = {fit.r_squared:.5f}", fontsize=10)
    bottom.axhline(0.0, color="gray", lw=0.8)
    bottom.plot(fit.adc, fit.residuals, "o", color=HARDWARE, ms=3)
    bottom.set_xlabel("ADC [counts]")
    bottom.set_ylabel("residual [N]")
    bottom.grid(alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path, dpi=90)
