"""Figures a researcher would put in a paper: cable tensions over time, setpoint vs actual."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from tensim._files import atomic_path
from tensim.control.velocity_table import VelocityTable
from tensim.sim import TimeSeries


def _cable_panels(cables: Sequence[str], columns: int, ylabel: str, height: float,
                  draw: Callable[[Axes, str], None]) -> Figure:
    """A grid with one panel per cable, drawn by ``draw(ax, cable)``, labelled and tidied."""
    rows = math.ceil(len(cables) / columns)
    fig, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, height * rows), sharex=True,
                             squeeze=False)
    for ax, name in zip(axes.flat, cables, strict=False):
        draw(ax, name)
        ax.set_title(name, fontsize=9)
        ax.set_ylabel(ylabel, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(cables):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]", fontsize=8)
    axes.flat[0].legend(fontsize=7, loc="best")
    return fig


def plot_cable_tensions(series: TimeSeries, path: Path, *, cables: Sequence[str] | None = None,
                        title: str = "", columns: int = 3,
                        shade: tuple[float, float] | None = None) -> Path:
    """One panel per cable: measured (load-cell) tension, and the commanded tension T_set.

    Args:
        series: a recorded run.
        path: PNG file to write (atomically).
        cables: which cables, in panel order (all by default).
        title: figure title.
        columns: panels per row.
        shade: (start, stop) time span to shade, e.g. when an external force acts [s].
    """

    def draw(ax: Axes, name: str) -> None:
        ax.plot(series.time, series[f"tension/{name}"], color="black", lw=1.0, label="measured")
        setpoint = f"setpoint/{name}"
        if setpoint in series.channels:
            ax.plot(series.time, series[setpoint], color="tab:blue", lw=0.8, ls="--",
                    label="commanded")
        if shade is not None:
            ax.axvspan(*shade, color="tab:orange", alpha=0.12, lw=0)

    fig = _cable_panels(list(cables or series.items("tension")), columns, "tension [N]", 2.4,
                        draw)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_lengths(series: TimeSeries, path: Path, *, cables: Sequence[str] | None = None,
                 columns: int = 3) -> Path:
    """One panel per cable: anchor-to-anchor length and motor rest length [m]."""

    def draw(ax: Axes, name: str) -> None:
        ax.plot(series.time, series[f"length/{name}"], color="black", lw=1.0, label="length")
        ax.plot(series.time, series[f"rest_length/{name}"], color="tab:red", lw=0.8,
                label="rest length")

    fig = _cable_panels(list(cables or series.items("length")), columns, "[m]", 2.2, draw)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_path(series: TimeSeries, path: Path, items: Sequence[str], title: str = "") -> Path:
    """Top view (x, y) of the bodies' paths [m]; start marked with a circle."""
    fig, ax = plt.subplots(figsize=(5, 5))
    if title:
        ax.set_title(title, fontsize=10)
    for name in items:
        x, y = series[f"pos_x/{name}"], series[f"pos_y/{name}"]
        ax.plot(x, y, lw=1.0, label=name)
        ax.plot(x[:1], y[:1], "o", color=ax.lines[-1].get_color(), ms=4)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_velocity_input(table: VelocityTable, path: Path, *,
                        cables: Sequence[str] | None = None, columns: int = 3,
                        until: float | None = None) -> Path:
    """One panel per cable: the target velocity V* it was commanded (held between samples)."""
    stop = table.values.shape[0] if until is None else min(
        table.values.shape[0], int(until / table.period + 1e-9) + 1)
    times = table.times[:stop]

    def draw(ax: Axes, name: str) -> None:
        ax.step(times, table.values[:stop, table.cables.index(name)] * 1000.0, where="post",
                color="tab:green", lw=0.9, label="V*")
        ax.axhline(0.0, color="black", lw=0.5)

    chosen = [c for c in (cables or table.cables) if c in table.cables]
    fig = _cable_panels(chosen, columns, "V* [mm/s]", 2.0, draw)
    fig.tight_layout()
    return save_figure(fig, path)


def save_figure(fig: Figure, path: Path, dpi: int = 120) -> Path:
    """Writes ``fig`` as a PNG atomically and closes it."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    plt.close(fig)
    return path
