"""Figures a researcher would put in a paper: cable tensions over time, setpoint vs actual."""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import gc
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, ParamSpec, TypeVar

import matplotlib
import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from tensim._files import atomic_path
from tensim.viz._panels import MAX_PANELS as MAX_PANELS  # re-exported: the figures' limit
from tensim.viz._panels import Panel as Panel
from tensim.viz._panels import cable_panels as cable_panels
from tensim.viz._span import Span

if TYPE_CHECKING:  # not imported: the drawing process loads no simulation or controller
    from tensim.control.velocity_table import VelocityTable
    from tensim.sim import TimeSeries
    from tensim.viz._held import HeldInputs

DPI = 120  # the saved figures' resolution [pixels per inch]
# A panel's plot area is at most 3.5 in wide: a line is drawn from the smallest and largest
# sample of each of its pixel columns.
PANEL_PIXELS = round(3.5 * DPI)
SETTLE_S = 0.2  # the y axis ignores commanded tensions before this: the start-up transient [s]

P = ParamSpec("P")
R = TypeVar("R")


@contextlib.contextmanager
def gc_paused() -> Iterator[None]:
    """Python's cyclic garbage collector paused for the block.

    A panel figure makes tens of thousands of small objects (artists, paths, transforms),
    and each few hundred of them start a collection that walks every object the process
    holds (a whole simulation's worth of modules): 10-15 % of a figure's CPU time. The
    figure's own cycles are collected after the block, as before.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _gc_paused(function: Callable[P, R]) -> Callable[P, R]:
    """Runs ``function`` under :func:`gc_paused`."""

    @functools.wraps(function)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        with gc_paused():
            return function(*args, **kwargs)

    return wrapper


def thin(x: np.ndarray, y: np.ndarray, pixels: int = PANEL_PIXELS
         ) -> tuple[np.ndarray, np.ndarray]:
    """``(x, y)`` reduced to what a line ``pixels`` columns wide can show.

    ``x`` (ascending) is cut into ``pixels`` columns of equal width; each keeps its smallest
    and largest ``y`` in time order (NaN ignored), plus the first and last sample, so no peak
    or trough is lost: every column spans the same range of ``y`` as before. Lines of at most
    four samples a column are kept whole.
    """
    n = y.size
    if n <= 4 * pixels:
        return x, y
    # column k holds the samples from starts[k] on
    edges = np.linspace(x[0], x[-1], pixels + 1)[1:-1]
    starts = np.unique(np.concatenate([[0], np.searchsorted(x, edges, side="left")]))
    starts = starts[starts < n]
    keep = [np.array([0, n - 1])]
    for reduce in (np.fmin, np.fmax):  # fmin/fmax ignore NaN
        extreme = np.repeat(reduce.reduceat(y, starts), np.diff(np.append(starts, n)))
        at = np.flatnonzero(y == extreme)
        column = np.searchsorted(starts, at, side="right") - 1
        keep.append(at[np.unique(column, return_index=True)[1]])  # the first in each column
    index = np.unique(np.concatenate(keep))
    return x[index], y[index]


def thin_lines(x: np.ndarray, ys: np.ndarray, pixels: int = PANEL_PIXELS) -> list[np.ndarray]:
    """Each row of ``ys`` (m, n) thinned as :func:`thin` does against the shared ``x`` (n,),
    as (k, 2) arrays of points: the same points, found for all the lines at once (a panel
    of many cables reduces them in a few array operations, not a few dozen per line)."""
    ys = np.asarray(ys, dtype=float).reshape(-1, x.size)
    n = x.size
    if n <= 4 * pixels:
        return [np.column_stack([x, y]) for y in ys]
    edges = np.linspace(x[0], x[-1], pixels + 1)[1:-1]
    starts = np.unique(np.concatenate([[0], np.searchsorted(x, edges, side="left")]))
    starts = starts[starts < n]
    counts = np.diff(np.append(starts, n))
    keep = np.zeros(ys.shape, dtype=bool)
    keep[:, [0, -1]] = True
    position = np.arange(n)
    for reduce in (np.fmin, np.fmax):  # fmin/fmax ignore NaN
        extreme = np.repeat(reduce.reduceat(ys, starts, axis=1), counts, axis=1)
        # the first sample of each column that reaches it (n: none, a column of NaN)
        first = np.minimum.reduceat(np.where(ys == extreme, position, n), starts, axis=1)
        rows, _ = np.nonzero(first < n)
        keep[rows, first[first < n]] = True
    return [np.column_stack([x[row], y[row]]) for y, row in zip(ys, keep, strict=True)]


GROUP_PIXELS = 200  # columns per line in a shared panel (many lines: a coarser thinning)


# Panel figures by kind: the y label and the height of a row [in].
PANELS = {"tensions": ("tension [N]", 2.4), "lengths": ("length [m]", 2.2),
          "velocity_input": ("V* [m/s]", 2.0)}
LENGTHS_TITLE = "Cable length and motor rest length"
VELOCITY_TITLE = "Target cable velocity V* sent to each impedance controller"


@dataclasses.dataclass(frozen=True)
class PanelGrid:
    """The empty grid of a panel figure: one labelled panel per cable (or group of cables,
    :func:`cable_panels`), no data yet.

    It can be laid out before a run ends; a plot function of the same ``kind``, panels,
    columns and title then only fills it. Once
    drawn, a plot function of any panel kind on the same panels and columns fills it again
    (:func:`refit`).
    """

    kind: str
    panels: tuple[Panel, ...]
    columns: int
    title: str
    figure: Figure = dataclasses.field(compare=False)

    def fits(self, kind: str, panels: Sequence[Panel], columns: int, title: str) -> bool:
        return (self.kind, self.panels, self.columns, self.title) == \
            (kind, tuple(panels), columns, title)


@_gc_paused
def panel_grid(kind: str, cables: Sequence[str], columns: int = 3, title: str = "",
               tags: Mapping[str, Sequence[str]] | None = None) -> PanelGrid:
    """Lays out the empty grid of a panel figure of ``kind`` (see :data:`PANELS`) for
    ``cables`` (grouped by ``tags`` or names where there are many: :func:`cable_panels`).

    The margins are fixed in inches (no automatic layout pass, which cost a second a figure).
    """
    return _grid(kind, cable_panels(cables, tags), columns, title)


def _grid(kind: str, panels: tuple[Panel, ...], columns: int, title: str) -> PanelGrid:
    rows = max(1, math.ceil(len(panels) / columns))
    fig = new_figure(_size(kind, rows, columns, title))
    axes = fig.subplots(rows, columns, squeeze=False)
    for ax, (name, _) in zip(axes.flat, panels, strict=False):
        ax.set_title(name, fontsize=9, pad=3, y=1.0)  # a fixed y skips a costly layout pass
        ax.tick_params(labelsize=7)
        ax.xaxis.set_major_locator(InView(5))  # few ticks: each is a costly artist
        ax.yaxis.set_major_locator(InView(4))
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    # the panels share their time axis (not as matplotlib's shared axes: their transforms
    # cost 0.2 s a figure): its labels go under the lowest panel of each column only
    for k, ax in enumerate(axes.flat[:len(panels)]):
        if k + columns < len(panels):
            ax.tick_params(labelbottom=False)
        else:
            ax.set_xlabel("time [s]", fontsize=8)
    return _label(PanelGrid(kind, panels, columns, title, fig), rows)


class InView(MaxNLocator):
    """matplotlib's :class:`~matplotlib.ticker.MaxNLocator`, its ticks outside the view left out.

    matplotlib makes a tick (two marks, a grid line, two labels: five artists) for every
    location a locator gives, drawn or not, and MaxNLocator gives one beyond each end of the
    view: a panel made 13 ticks to draw 9. The ticks drawn are the same.
    """

    def __call__(self) -> Any:
        locs = super().__call__()
        if self.axis is None:
            return locs
        low, high = sorted(self.axis.get_view_interval())
        slack = 1e-10 * (high - low)  # as matplotlib's test of which ticks it draws
        return locs[(locs >= low - slack) & (locs <= high + slack)]


def _size(kind: str, rows: int, columns: int, title: str) -> tuple[float, float]:
    """A panel figure's (width, height) [in]."""
    return 4.2 * columns, PANELS[kind][1] * rows + _header(title)


def _header(title: str) -> float:
    """The height above the panels for the title and the panel titles [in]."""
    return 0.85 if "\n" in title else 0.65 if title else 0.35


def _label(grid: PanelGrid, rows: int) -> PanelGrid:
    """Sets what a grid's kind and title decide: its size, margins, y labels and title.

    The margins are fixed in inches (no automatic layout pass, which cost a second a figure).
    """
    fig, title = grid.figure, grid.title
    ylabel, height = PANELS[grid.kind]
    width, fig_height = _size(grid.kind, rows, grid.columns, title)
    header = _header(title)
    fig.set_size_inches(width, fig_height)
    fig.subplots_adjust(left=0.62 / width, right=1 - 0.15 / width, bottom=0.5 / fig_height,
                        top=1 - header / fig_height,
                        wspace=0.75 / 4.2, hspace=0.55 / height)
    for ax in fig.axes[:len(grid.panels)]:
        ax.set_ylabel(ylabel, fontsize=8)
    # 0.2 in from the top of a tall figure (2 % of its height: into the panels); an empty
    # title draws nothing (and empties a refitted grid's)
    fig.suptitle(title, fontsize=11, y=0.98 if fig_height <= 12 else 1 - 0.2 / fig_height)
    return grid


def refit(grid: PanelGrid, kind: str, title: str = "") -> PanelGrid:
    """``grid``'s figure, after it was drawn and saved, emptied of its data and labelled for a
    figure of ``kind`` and ``title`` on the same panels (tensions.png, lengths.png and
    velocity_input.png of a run share their panels): its axes, panel titles and ticks are
    made once, not once per figure. It draws the same pixels as a grid laid out afresh.
    """
    for ax in grid.figure.axes[:len(grid.panels)]:
        for artist in [*ax.lines, *ax.patches, *ax.collections]:
            artist.remove()
        legend = ax.get_legend()
        if legend is not None:
            legend.remove()
        ax.relim()  # no data: the limits come from the next lines, as in a new grid
        ax.set_autoscale_on(True)
        ax.set_prop_cycle(None)  # each figure's lines start at the first colour
    rows = max(1, math.ceil(len(grid.panels) / grid.columns))
    return _label(PanelGrid(kind, grid.panels, grid.columns, title, grid.figure), rows)


def _panels(grid: PanelGrid | None, kind: str, cables: Sequence[str], columns: int, title: str,
            draw: Callable[[Axes, str], None], draw_group: Callable[[Axes, Sequence[str]], None],
            tags: Mapping[str, Sequence[str]] | None) -> Figure:
    """Fills ``grid`` (refitted where it holds another figure, :func:`refit`; a new grid where
    it was laid out for other panels or columns) with
    ``draw(ax, cable)`` per single-cable panel and ``draw_group(ax, cables)`` per shared one,
    and the legend."""
    panels = cable_panels(cables, tags)
    if grid is None or (grid.panels, grid.columns) != (panels, columns):
        grid = _grid(kind, panels, columns, title)
    elif not grid.fits(kind, panels, columns, title) or _holds_data(grid):
        grid = refit(grid, kind, title)
    axes = grid.figure.axes
    for ax, (_, names) in zip(axes, panels, strict=False):
        if len(panels) == len(cables):
            draw(ax, names[0])
        else:
            draw_group(ax, names)
    if axes and axes[0].get_legend_handles_labels()[0]:
        axes[0].legend(fontsize=7, loc="best")
    return grid.figure


def _holds_data(grid: PanelGrid) -> bool:
    """Whether a plot function has drawn into ``grid`` (lines, line groups, shaded spans)."""
    return any(ax.lines or ax.collections or ax.patches for ax in grid.figure.axes)


def _lines(ax: Axes, t: np.ndarray, lines: Sequence[np.ndarray], ls: str = "solid") -> None:
    """Many cables' lines in one panel, thin, in matplotlib's colour cycle (the k-th line in
    the k-th colour): one collection, not an artist per cable."""
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    segments = thin_lines(t, np.array(lines), GROUP_PIXELS)
    ax.add_collection(LineCollection(segments, colors=[colors[k % len(colors)]
                                                       for k in range(len(lines))],
                                     linewidths=0.6, alpha=0.7, linestyles=ls))
    ax.autoscale_view()


def _commanded(series: TimeSeries, name: str) -> np.ndarray | None:
    """The cable's commanded tension T_set, or None where it had no impedance law (NaN)."""
    channel = f"setpoint/{name}"
    if channel not in series.channels:
        return None
    values = series[channel]
    return values if np.isfinite(values).any() else None


@_gc_paused
def plot_cable_tensions(series: TimeSeries, path: Path, *, cables: Sequence[str] | None = None,
                        title: str = "", columns: int = 3,
                        spans: Sequence[Span] = (), grid: PanelGrid | None = None,
                        tags: Mapping[str, Sequence[str]] | None = None) -> Path:
    """One panel per cable: measured (load-cell) tension, and the commanded tension T_set.

    The measured line is drawn over the commanded one. The y axis spans the measured tension
    and the commanded one after :data:`SETTLE_S` (the first steps' setpoints, while the robot
    settles, can be several times larger and are clipped). Over :data:`MAX_PANELS` cables, a
    panel per group of cables (:func:`cable_panels`) with each one's measured tension.

    Args:
        series: a recorded run.
        path: PNG file to write (atomically).
        cables: which cables, in panel order (all by default).
        title: figure title.
        columns: panels per row.
        spans: time spans to shade, e.g. when an external force acts.
        grid: the empty grid to fill, laid out before the run ended (:func:`panel_grid` of
            ``"tensions"`` for the same cables, columns and title); None: laid out here.
        tags: each cable's tags, to group many cables by (None: by their names).
    """
    t = series.time
    later = t >= min(SETTLE_S, float(t[-1]))

    def draw(ax: Axes, name: str) -> None:
        measured = series[f"tension/{name}"]
        commanded = _commanded(series, name)
        low, high = float(np.nanmin(measured)), float(np.nanmax(measured))
        if commanded is not None:
            ax.plot(*thin(t, commanded), color="tab:blue", lw=1.2, alpha=0.7, ls="--",
                    label="commanded", zorder=2)
            low = min(low, float(np.nanmin(commanded[later])))
            high = max(high, float(np.nanmax(commanded[later])))
        # without an impedance law nothing is commanded: say so rather than "measured" alone
        label = "measured" if commanded is not None else "tension (no law: none commanded)"
        ax.plot(*thin(t, measured), color="black", lw=0.8, label=label, zorder=3)
        for span in spans:
            ax.axvspan(span.start, span.stop, color=span.color, alpha=span.alpha, lw=0,
                       label=span.label)
        margin = 0.05 * (high - low) or 0.5
        ax.set_ylim(low - margin, high + margin)

    def draw_group(ax: Axes, names: Sequence[str]) -> None:
        _lines(ax, t, [series[f"tension/{name}"] for name in names])
        for span in spans:
            ax.axvspan(span.start, span.stop, color=span.color, alpha=span.alpha, lw=0)

    cables = list(cables or series.items("tension"))
    return save_figure(_panels(grid, "tensions", cables, columns, title, draw, draw_group,
                               tags), path)


@_gc_paused
def plot_lengths(series: TimeSeries, path: Path, *, cables: Sequence[str] | None = None,
                 columns: int = 3, title: str = LENGTHS_TITLE, grid: PanelGrid | None = None,
                 tags: Mapping[str, Sequence[str]] | None = None) -> Path:
    """One panel per cable: anchor-to-anchor length and motor rest length [m]; over
    :data:`MAX_PANELS` cables, a panel per group with each one's length (solid) and rest
    length (dashed).

    ``grid``, ``tags``: as in :func:`plot_cable_tensions`.
    """
    t = series.time

    def draw(ax: Axes, name: str) -> None:
        ax.plot(*thin(t, series[f"rest_length/{name}"]), color="tab:red", lw=0.8,
                label="rest length")
        ax.plot(*thin(t, series[f"length/{name}"]), color="black", lw=0.8, label="length")

    def draw_group(ax: Axes, names: Sequence[str]) -> None:
        _lines(ax, t, [series[f"length/{name}"] for name in names])
        # each rest length in its cable's colour
        _lines(ax, t, [series[f"rest_length/{name}"] for name in names], ls="--")

    cables = list(cables or series.items("length"))
    return save_figure(_panels(grid, "lengths", cables, columns, title, draw, draw_group,
                               tags), path)


PATH_LEGEND = 12  # bodies named in a path figure's legend; more are drawn as one grey bundle


@_gc_paused
def plot_path(series: TimeSeries, path: Path, items: Sequence[str] | None = None,
              title: str = "") -> Path:
    """Top view (x, y) of the bodies' paths [m] (``items``; None: every recorded body and the
    centre of mass); start marked with a circle."""
    items = series.items("pos_x") if items is None else items
    fig = new_figure((5, 5))
    ax = fig.subplots()
    if title:
        ax.set_title(title, fontsize=10)
    named = list(items) if len(items) <= PATH_LEGEND else [n for n in items if n == "com"]
    for name in named:
        x, y = series[f"pos_x/{name}"], series[f"pos_y/{name}"]
        ax.plot(x, y, lw=1.0, label=name)
        ax.plot(x[:1], y[:1], "o", color=ax.lines[-1].get_color(), ms=4)
    rest = [n for n in items if n not in named]
    if rest:  # many bodies: one collection in thin grey, a legend entry for all
        paths = [np.column_stack([series[f"pos_x/{n}"], series[f"pos_y/{n}"]]) for n in rest]
        ax.add_collection(LineCollection(paths, colors="0.55", linewidths=0.5,
                                         label=f"{len(rest)} bodies"))
        ax.plot([p[0, 0] for p in paths], [p[0, 1] for p in paths], "o", color="0.55", ms=2)
        ax.autoscale_view()
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.subplots_adjust(left=0.17, right=0.96, bottom=0.11, top=0.93)  # room for the labels
    return save_figure(fig, path)


@_gc_paused
def plot_velocity_input(table: VelocityTable | HeldInputs, path: Path, *,
                        cables: Sequence[str] | None = None, columns: int = 3,
                        until: float | None = None, title: str = VELOCITY_TITLE,
                        grid: PanelGrid | None = None,
                        tags: Mapping[str, Sequence[str]] | None = None) -> Path:
    """One panel per cable: the target velocity V* it was commanded (held between samples);
    over :data:`MAX_PANELS` cables, a panel per group.

    ``grid``, ``tags``: as in :func:`plot_cable_tensions`.
    """
    stop = table.values.shape[0] if until is None else min(
        table.values.shape[0], int(until / table.period + 1e-9) + 1)
    times = table.times[:stop]

    def draw(ax: Axes, name: str) -> None:
        ax.plot(*thin(*_held(times, table.values[:stop, table.cables.index(name)])),
                color="tab:green", lw=0.9, label="V*")
        ax.axhline(0.0, color="black", lw=0.5)

    def draw_group(ax: Axes, names: Sequence[str]) -> None:
        for name in names:
            ax.step(times, table.values[:stop, table.cables.index(name)],
                    where="post", lw=0.6, alpha=0.7)
        ax.axhline(0.0, color="black", lw=0.5)

    chosen = [c for c in (cables or table.cables) if c in table.cables]
    return save_figure(_panels(grid, "velocity_input", chosen, columns, title, draw,
                               draw_group, tags), path)


def _held(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The corners of ``y`` held from each ``t`` to the next (a step line, ``where="post"``)
    as a plain line, so that :func:`thin` can reduce it."""
    return np.repeat(t, 2)[1:], np.repeat(y, 2)[:-1]


def new_figure(size: tuple[float, float], dpi: int = DPI) -> Figure:
    """A figure of ``size`` (width, height) [in] at ``dpi`` on its own Agg canvas: no pyplot,
    and no plotting backend chosen for the process."""
    fig = Figure(figsize=size, dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig: Figure, path: Path, dpi: int = DPI) -> Path:
    """Writes ``fig`` as a PNG at ``dpi`` atomically.

    The figure is drawn once and its pixels encoded by Pillow: matplotlib's ``savefig`` draws
    it a second time (the same pixels; a third of a panel figure's cost).
    """
    from PIL import Image

    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    if fig.dpi != dpi:
        fig.set_dpi(dpi)
    canvas.draw()
    pixels = np.asarray(canvas.buffer_rgba())
    image = Image.fromarray(pixels)
    if pixels[..., 3].min() == 255:  # opaque: the same picture, a quarter less to compress
        image = image.convert("RGB")
    with atomic_path(path) as tmp:
        # zlib level 3: 5 % larger files than matplotlib's 6, written in 60 % of the time
        image.save(tmp, format="png", compress_level=3)
    return path
