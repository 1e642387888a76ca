"""Run folders: the recorded time series, a log, a report and a summary, each written atomically.

Every command that writes a run folder ends with :func:`write_run` (one simulation) or
:func:`finish_run` (studies and searches that keep only a summary and figures). Both write
``tensim.log`` (this process's tensim warnings and progress lines since the last run folder),
``report.html`` (:func:`tensim.viz.report.write_report`) and then ``summary.json``, last, so its
presence means the folder is complete.

Commands write their folder through :func:`replace_folder`: the files go into a hidden staging
folder beside ``--out``, which replaces ``--out`` whole when the command succeeds. A folder
therefore never mixes the files of two runs, and an interrupted or failed command leaves
``--out`` as it was. tensim replaces only a folder that is empty or holds an earlier tensim run;
any other folder is refused.
"""

from __future__ import annotations

import collections
import contextlib
import glob
import hashlib
import logging
import os
import platform
import shutil
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tensim import __version__
from tensim._files import (
    CONTROLLER_FILE,
    RUN_MARKER,
    STRUCTURE_FILE,
    cause,
    check_writable,
    output_target,
    pid_alive,
    write_json,
    write_text,
)
from tensim._input import InputError
from tensim.sim import SimulationResult, TimeSeries
from tensim.viz.report import figure_names, write_report

if TYPE_CHECKING:
    from tensim.control import ControllerConfig
    from tensim.model import CompiledModel, WorldOptions
    from tensim.structure import Structure
    from tensim.viz.drawing import FigureDrawer


PROGRESS_LOGGER = "tensim.progress"  # progress lines: to the run log only, never the console
_MAX_LINES = 20_000


class RunLog(logging.Handler):
    """Keeps this process's tensim log records (warnings, progress lines) for the next run folder.

    Attached to the ``tensim`` logger (records at the level it passes, WARNING unless the
    application sets another) and to the progress logger (INFO, not propagated).
    """

    def __init__(self) -> None:
        super().__init__(logging.INFO)
        self.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
        self.lines: collections.deque[str] = collections.deque(maxlen=_MAX_LINES)

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(self.format(record))
        if self._only_handler(record) and logging.lastResort is not None \
                and record.levelno >= logging.lastResort.level:
            logging.lastResort.handle(record)  # as Python would have without this handler

    def _only_handler(self, record: logging.LogRecord) -> bool:
        """Whether no other handler sees ``record`` (so Python's last resort would print it)."""
        logger: logging.Logger | None = logging.getLogger(record.name)
        while logger is not None:
            if any(h is not self for h in logger.handlers):
                return False
            logger = logger.parent if logger.propagate else None
        return record.name != PROGRESS_LOGGER

    def write(self, path: Path) -> Path:
        """Writes the header and the lines kept since the last write, atomically; clears them."""
        command = " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]) if sys.argv else ""
        header = [f"tensim {__version__}, Python {platform.python_version()}, "
                  f"{platform.system()} {platform.machine()}", f"command: {command}"]
        write_text(path, "\n".join([*header, *self.lines]) + "\n")
        self.lines.clear()
        return path


def _install() -> RunLog:
    log = RunLog()
    logging.getLogger("tensim").addHandler(log)
    progress = logging.getLogger(PROGRESS_LOGGER)
    progress.setLevel(logging.INFO)
    progress.propagate = False
    progress.addHandler(log)
    return log


RUN_LOG = _install()


def prepare_outputs() -> None:
    """Starts the child process that paints frame.png (:class:`tensim.viz._gl.GLServer`).

    Call it before simulating: the child starts and tries the offscreen OpenGL backends
    while the run simulates (a thread only waits for it, holding no Python lock the
    simulation needs), instead of after it. With a single usable core it would take that
    core from the simulation (and skew its real-time factor), so then it does nothing and the
    report starts the child later. A failure is left for the report to meet and note. (Loading
    matplotlib this way was tried and dropped: an import holds Python's lock and slowed the
    simulation, and the real-time factor it reports, by as much as it saved.)
    """
    if len(os.sched_getaffinity(0)) < 2:
        return
    from tensim.viz import _gl

    _gl.prepare_server()


def finish_run(out: Path, summary: dict[str, Any], series: TimeSeries | None = None,
               drawer: FigureDrawer | None = None, compiled: CompiledModel | None = None
               ) -> Path:
    """Writes ``tensim.log``, ``report.html`` and then ``summary.json`` into ``out``.

    Call it last, after the folder's figures and data files are written (or handed to
    ``drawer``, which the report waits for); ``series`` is the run's trajectory if it has one
    (else the report reads trajectory.parquet, if any); ``compiled`` the robot it simulated,
    for the report's frame (else compiled again from the folder).
    """
    out.mkdir(parents=True, exist_ok=True)
    summary = {**summary, "tensim_version": __version__}
    RUN_LOG.write(out / "tensim.log")
    write_report(out, summary, series=series, drawer=drawer, compiled=compiled)
    summary["figures"] = figure_names(out, summary)  # with those the report added
    write_json(out / "summary.json", summary)
    return out


def world_record(world: WorldOptions) -> dict[str, Any]:
    """The world options as summary fields, enough to rebuild the run's world: ``dt_s``,
    ``terrain`` (a ``--terrain`` string), ``contact_timeconst_s``, the engine options and the
    inertia floor."""
    from tensim.terrain import format_terrain

    return {"dt_s": world.timestep, "terrain": format_terrain(world.terrain),
            "contact_timeconst_s": world.contact_timeconst, "midphase": world.midphase,
            "self_collision": world.self_collision, "cone": world.cone,
            "noslip_iterations": world.noslip_iterations, "condim": world.condim,
            "torsional_friction_m": world.torsional_friction,
            "rolling_friction_m": world.rolling_friction, "cable_law": world.cable_law,
            "split_margin": world.split_margin,
            "min_inertia_ratio": world.min_inertia_ratio}


def write_run(out: Path, result: SimulationResult, summary: dict[str, Any], *,
              structure: Structure | None = None,
              controller: ControllerConfig | None = None,
              drawer: FigureDrawer | None = None,
              compiled: CompiledModel | None = None) -> Path:
    """Writes ``trajectory.parquet``, the run's robot and controller, then finishes the folder
    (:func:`finish_run`).

    With the world fields of :func:`world_record` in the summary, the folder holds what it takes
    to replay (``tensim render``) or rerun the run on the same robot and ground.

    Args:
        out: the run folder.
        result: the finished simulation.
        summary: its summary.
        structure: the robot as it ran, written as ``structure.yaml`` (None: the preset the
            summary's ``model`` names, if it names one).
        controller: the controller it ran under, written as ``controller.yaml``.
        drawer: still drawing some of the folder's figures (see :func:`finish_run`).
        compiled: the model the run simulated (``structure`` compiled in the summary's
            world), for the report's frame (None: compiled again from the folder).
    """
    from tensim.control import save_controller
    from tensim.models import PRESETS
    from tensim.structure import save_structure

    out.mkdir(parents=True, exist_ok=True)
    files = [str(f) for f in summary.get("files", [])]
    if structure is None and summary.get("model") in PRESETS:
        structure = PRESETS[summary["model"]].build()
    if structure is not None:
        save_structure(structure, out / STRUCTURE_FILE)
        files.append(STRUCTURE_FILE)
    if controller is not None:
        save_controller(controller, out / CONTROLLER_FILE)
        files.append(CONTROLLER_FILE)
    if files:
        summary = {**summary, "files": list(dict.fromkeys(files))}
    result.trajectory.to_parquet(out / "trajectory.parquet")
    return finish_run(out, summary, result.trajectory, drawer, compiled)


MARKER = RUN_MARKER  # every folder written through replace_folder holds it
_STAGE = ".partial-"  # staging folders are named .<out name>.partial-<pid>-<random>


def _holds_run(folder: Path) -> bool:
    """Whether ``folder`` is empty or holds a tensim run (a marker or a summary)."""
    return not any(folder.iterdir()) or (folder / MARKER).is_file() \
        or (folder / "summary.json").is_file()


def check_run_folder(out: Path) -> None:
    """Refuses an ``--out`` that :func:`replace_folder` may not replace.

    Raises:
        InputError: a file, a path under a file, or a folder that holds something other than a
            tensim run.
    """
    check_writable(out, "folder", "--out")
    if out.is_dir() and not _holds_run(out):
        raise InputError(f"{out}: a folder that holds no tensim run (no summary.json); tensim "
                         "replaces a run folder whole, so it writes only into an empty folder "
                         "or an earlier run's; choose another --out")


def _stage_prefix(out: Path) -> str:
    """``.<out name>.partial-``: a long name shortened (with a hash) so the staging folder's
    name stays within the file system's 255 bytes."""
    name = out.name
    if len(name.encode()) > 120:
        name = name.encode()[:80].decode(errors="ignore") + "-" + hashlib.sha256(
            out.name.encode()).hexdigest()[:12]
    return f".{name}{_STAGE}"


def _remove_stale_stages(out: Path) -> None:
    """Deletes staging folders of ``out`` left by processes that no longer run."""
    for stage in out.parent.glob(f"{glob.escape(_stage_prefix(out))}*"):
        pid = stage.name.rpartition(_STAGE)[2].partition("-")[0]
        if pid.isdigit() and not pid_alive(int(pid)):
            shutil.rmtree(stage, ignore_errors=True)


@contextlib.contextmanager
def replace_folder(out: str | os.PathLike[str]) -> Iterator[Path]:
    """Yields an empty staging folder; when the block ends normally, it replaces ``out`` whole.

    An earlier run in ``out`` is removed only then. If the block raises (or is interrupted),
    the staging folder is deleted and ``out`` is left as it was. Stale staging folders of
    ``out`` (from killed processes) are deleted first. A symbolic link is followed (the rule of
    :mod:`tensim._files`): the folder it points to is replaced, and the link stays.

    Raises:
        InputError: ``out`` may not be replaced (see :func:`check_run_folder`), or cannot be
            written (the message names ``out`` and the cause in words).
    """
    named = Path(out)
    check_run_folder(named)
    out = output_target(named)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        _remove_stale_stages(out)
        stage = Path(tempfile.mkdtemp(prefix=f"{_stage_prefix(out)}{os.getpid()}-",
                                      dir=out.parent))
    except OSError as err:
        raise InputError(f"--out {named}: cannot be written ({cause(err)})") from None
    try:
        (stage / MARKER).write_text("a tensim run folder; tensim may replace it whole\n"
                                    f"folder: {named.name}\n")
        yield stage
        os.chmod(stage, 0o777 & ~_umask())  # mkdtemp makes 0700
        if out.exists():
            check_run_folder(out)  # it may have changed while the command ran
            old = stage.with_name(stage.name + "-old")
            os.replace(out, old)
            os.replace(stage, out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(stage, out)
    except OSError as err:  # name --out and the file, not the hidden staging folder
        where = err.filename and Path(os.fsdecode(err.filename))
        if not where or not (where == stage or stage in where.parents
                             or where.name.startswith(stage.name)):
            raise
        inside = f" while writing {where.relative_to(stage)}" if stage in where.parents else ""
        raise InputError(f"--out {named}: cannot be written{inside} ({cause(err)}); "
                         f"{named} is left as it was") from None
    finally:
        if stage.exists():
            shutil.rmtree(stage, ignore_errors=True)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
