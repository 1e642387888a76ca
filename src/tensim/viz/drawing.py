"""A run's figures, drawn in a second process that gets ready while the run simulates.

Drawing a run folder's figures (matplotlib's import, then a dozen-panel grid per figure) took
about as long as simulating the 60 s disturbance test. A command that knows its figures before
it simulates names them in :class:`FigurePlan` records and opens a :class:`FigureDrawer`: with
a second core free, a child process then loads matplotlib and lays out the empty grid of
panels that the run's panel figures share while the simulation runs, and after it each figure
fills that grid in turn (:func:`tensim.viz.plots.refit`), while this process
writes the folder's other files. Without a second core the same functions draw in this
process; the figures are the same either way. A busy machine and a short run draw in the child
too (:func:`background_pays`): this process holds the run and Parquet's library (for
``trajectory.parquet``), and matplotlib with its canvases in the same process would raise the
command's peak memory by a fifth or more (the disturbance test's from 150 to 177 MiB), for
about the CPU time the child's start costs.

The child is a fresh interpreter (``python -P tensim/viz/_drawchild.py``: no copy of this
process's MuJoCo, threads or OpenGL state, and none of its ``__main__``) that loads numpy,
matplotlib and the drawing modules only, not the tensim package and its MuJoCo; it reads the
plans and the data (the channels each figure draws) through a socket pair and writes the PNG
files itself (atomically, as every figure). It ends with its socket: when the command
finishes, fails or is killed.
"""

from __future__ import annotations

import dataclasses
import inspect
import logging
import multiprocessing
import os
import queue
import signal
import subprocess
import sys
import threading
import traceback
from collections.abc import Mapping, Sequence
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import numpy as np

from tensim.viz._child import helper_env
from tensim.viz._span import Span as Span  # re-exported: the plans name their spans

log = logging.getLogger(__name__)

# What each kind of figure draws: kind -> the tensim.viz.plots function, called as
# function(data, path, **options).
KINDS = {"tensions": "plot_cable_tensions", "lengths": "plot_lengths",
         "velocity_input": "plot_velocity_input", "path": "plot_path"}


class FigureError(RuntimeError):
    """A figure could not be drawn (the message holds the drawing process's traceback)."""


@dataclasses.dataclass(frozen=True)
class FigurePlan:
    """A figure a run will write, as known before it simulates.

    Attributes:
        file: its file name in the run folder, e.g. ``"tensions.png"``.
        kind: what it draws (:data:`KINDS`).
        options: the plot function's keyword options known in advance (``cables``,
            ``columns``, ``title``, ``spans``, ...); panel figures whose ``cables`` are
            given here are laid out before the data come.
    """

    file: str
    kind: str
    options: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown figure kind {self.kind!r}; known: {sorted(KINDS)}")


def background_pays() -> bool:
    """Whether a drawing process pays: where a second core is usable.

    Neither the run's length nor the machine's load is asked. The child's start (Python and
    numpy) costs about what it saves: its imports are cheaper than matplotlib's in this process
    (:mod:`tensim.viz._drawchild`), and the figures draw faster outside a process that holds a
    whole run; measured in turns on a loaded 2-core machine, runs of 1,000 to 60,000 steps cost
    the same CPU time either way. And matplotlib stays out of the process that holds the run,
    the pre-run check's scipy and Parquet's library (the command's peak memory: the 10 s
    Tetraspine3 ``simulate`` 150 MiB against 190 MiB; see the module's notes).
    """
    return len(os.sched_getaffinity(0)) >= 2


class FigureDrawer:
    """Draws a run's planned figures, in a child process (``background``) or in this one.

    Use it as a context manager around the simulation and the writing of the folder:
    :meth:`draw` hands a figure its data (returning at once when a child draws it),
    :attr:`pending` names the figures still being drawn, :meth:`wait` returns once all are
    written and raises :class:`FigureError` if one failed. A child that dies is replaced by
    drawing its figures here, with a warning. With ``enabled`` False it draws nothing (a run
    without figures: ``--no-figures``), and the report then adds none either.
    """

    def __init__(self, plans: Sequence[FigurePlan], background: bool = False,
                 enabled: bool = True):
        self.enabled = enabled
        background = background and enabled
        self.plans = {plan.file: plan for plan in plans}
        if len(self.plans) != len(plans):
            raise ValueError("two figure plans share a file name")
        self._pending: dict[str, tuple[Any, Path, dict[str, Any]]] = {}
        self.handed: set[str] = set()  # the files handed to draw() so far
        self._grid: Any = None  # the last panel grid drawn here, filled again by the next
        self._conn: Connection | None = None
        self._process: subprocess.Popen[bytes] | None = None
        if background:
            self._start()

    def _start(self) -> None:
        ours, theirs = multiprocessing.Pipe()
        # the child runs this very tensim's modules (the script finds them beside it); -P:
        # the script's folder (tensim/viz) is not put on the path
        script = Path(__file__).with_name("_drawchild.py")
        try:
            process = subprocess.Popen(
                [sys.executable, "-P", str(script), str(theirs.fileno())],
                pass_fds=(theirs.fileno(),), stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL, env=helper_env())
            ours.send(list(self.plans.values()))
        except OSError as err:
            log.info("figures drawn in this process: no drawing process (%s)", err)
            ours.close()
            return
        finally:
            theirs.close()
        self._conn, self._process = ours, process

    @property
    def background(self) -> bool:
        """Whether a child process draws the figures."""
        return self._conn is not None

    @property
    def pending(self) -> frozenset[str]:
        """The files handed to the child and not yet reported written."""
        return frozenset(self._pending)

    def draw(self, file: str, data: Any, folder: Path, **late: Any) -> Path:
        """Draws the planned figure ``file`` from ``data`` into ``folder``.

        ``late``: options known only now (e.g. a title with the run's result); they join the
        plan's options, and are not part of the grid laid out in advance.
        """
        plan = self.plans[file]
        path = Path(folder) / file
        self.handed.add(file)
        if not self.enabled:
            return path
        if self._conn is not None:
            try:
                self._conn.send((file, portable(plan.kind, data, {**plan.options, **late}),
                                 path, late))
                self._pending[file] = (data, path, late)
                return path
            except (OSError, ValueError) as err:
                self._lost(err)
        self._grid = _draw(plan, data, path, late, self._grid) or self._grid
        return path

    def wait(self) -> None:
        """Returns once every handed-over figure is written.

        Raises:
            FigureError: a figure failed to draw.
        """
        failures = []
        while self._pending and self._conn is not None:
            try:
                file, error = self._conn.recv()
            except (EOFError, OSError) as err:
                self._lost(err)
                break
            self._pending.pop(file, None)
            if error is not None:
                failures.append(f"{file}: {error}")
        for file, (data, path, late) in list(self._pending.items()):
            # the child was lost
            self._grid = _draw(self.plans[file], data, path, late, self._grid) or self._grid
            del self._pending[file]
        if failures:
            raise FigureError("a figure could not be drawn:\n" + "\n".join(failures))

    def _lost(self, err: BaseException) -> None:
        log.warning("the figure-drawing process ended early (%s); drawing here instead", err)
        self._close_child(kill=True)

    def close(self) -> None:
        """Ends the child (figures not yet drawn are dropped: call :meth:`wait` first; a child
        still drawing is killed, so that it writes nothing into a folder being removed)."""
        drawing = bool(self._pending)
        self._pending.clear()
        self._close_child(kill=drawing)

    def _close_child(self, kill: bool = False) -> None:
        conn, process = self._conn, self._process
        self._conn = self._process = None
        if conn is not None:
            try:
                conn.send(None)
            except (OSError, ValueError):
                pass
            conn.close()
        if process is not None:
            if kill:
                process.kill()
            try:
                process.wait(timeout=5.0)  # it exits at once on the sentinel
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()

    def __enter__(self) -> FigureDrawer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# The channels (by quantity) each kind of figure draws from a time series.
QUANTITIES = {"tensions": ("tension", "setpoint"), "lengths": ("length", "rest_length"),
              "path": ("pos_x", "pos_y")}
# The per-cable kinds: the quantity that names their cables by default, and the quantities a
# panel of several cables draws (a shared panel draws no commanded tension)
_PER_CABLE: dict[str, tuple[str, tuple[str, ...]]] = {"tensions": ("tension", ("tension",)),
              "lengths": ("length", ("length", "rest_length"))}


def portable(kind: str, data: Any, options: Mapping[str, Any] | None = None) -> Any:
    """What a figure of ``kind`` is sent of ``data``: of a time series, the channels it draws
    (a quarter or less of a run's: of a per-cable figure, its ``options``' cables only, and
    no commanded tensions where cables share panels, which draw none); of a V* table, its
    :class:`~tensim.viz._held.HeldInputs` (which the drawing process loads without the
    controllers).

    Args:
        kind: the figure's kind (:data:`KINDS`).
        data: what its plot function draws.
        options: the plot function's options (``cables``, ``tags``), as it will be called.
    """
    from tensim.viz._held import HeldInputs

    if kind in QUANTITIES and hasattr(data, "channels"):
        wanted = _drawn_channels(kind, data, options or {})
        return type(data)(data.time, {
            name: values for name, values in data.channels.items()
            if (name.partition("/")[0] in QUANTITIES[kind] if wanted is None
                else name in wanted)})
    if kind == "velocity_input" and hasattr(data, "period"):
        return HeldInputs(tuple(data.cables), float(data.period), np.asarray(data.values))
    return data


def _drawn_channels(kind: str, data: Any, options: Mapping[str, Any]) -> set[str] | None:
    """The channels a per-cable figure draws of ``data`` (None: not a per-cable kind, all of
    its quantities')."""
    from tensim.viz._panels import cable_panels

    if kind not in _PER_CABLE:
        return None
    naming, shared = _PER_CABLE[kind]
    cables = list(options.get("cables") or data.items(naming))
    quantities: tuple[str, ...] = QUANTITIES[kind]
    if len(cable_panels(cables, options.get("tags"))) != len(cables):
        quantities = shared
    return {f"{q}/{c}" for q in quantities for c in cables}


def _draw(plan: FigurePlan, data: Any, path: Path, late: Mapping[str, Any], grid: Any) -> Any:
    """Draws ``plan``'s figure of ``data`` into ``path``; a panel figure into ``grid``, a panel
    grid drawn before (its figures share their panels: the plot function refits it, see
    :func:`tensim.viz.plots.refit`; None: a new one). Returns the panel grid it drew into (None:
    not a panel figure, or one the plot function laid out itself)."""
    from tensim.viz import plots

    function = getattr(plots, KINDS[plan.kind])
    options = {**plan.options, **late}
    if plan.kind in plots.PANELS:
        options["grid"] = grid if grid is not None else _lay_out(plan)
    function(data, path, **options)
    return options.get("grid")


def _lay_out(plan: FigurePlan) -> Any:
    """The plan's empty panel grid (None: a kind or plan without one).

    It is not drawn: drawing the empty grid ahead (its ticks and text) moved some work before
    the run's end, but cost the drawing process more CPU time in all (0.3 s of the disturbance
    test's 1.6 s).
    """
    from tensim.viz import plots

    if plan.kind not in plots.PANELS or "cables" not in plan.options:
        return None
    function = getattr(plots, KINDS[plan.kind])
    defaults = inspect.unwrap(function).__kwdefaults__ or {}
    options = {**defaults, **plan.options}
    return plots.panel_grid(plan.kind, options["cables"], options["columns"], options["title"],
                            options.get("tags"))


def serve(conn: Connection) -> None:
    """The drawing process: lays out the planned grids, then draws what it is sent.

    A thread takes the jobs off the socket as they come, so the parent never waits for a
    figure to be drawn before it can hand over the next.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's; it ends the socket
    jobs: queue.SimpleQueue[Any] = queue.SimpleQueue()

    def receive() -> None:
        try:
            while (job := conn.recv()) is not None:
                jobs.put(job)
        except (EOFError, OSError):
            pass  # the parent has gone: nothing left to draw
        jobs.put(None)

    threading.Thread(target=receive, name="tensim-figure-jobs", daemon=True).start()
    plans = jobs.get()
    if plans is None:
        return
    # one grid: the run's panel figures share their panels, and each fills it in turn
    grid = next((g for g in map(_lay_out, plans) if g is not None), None)
    by_file = {plan.file: plan for plan in plans}
    while (job := jobs.get()) is not None:
        file, data, path, late = job
        try:
            grid = _draw(by_file[file], data, path, late, grid) or grid
            error = None
        except Exception:  # reported to the parent, which raises it
            error = traceback.format_exc()
        try:
            conn.send((file, error))
        except OSError:
            return

