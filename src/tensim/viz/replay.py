"""Recorded runs replayed onto a compiled model: poses from the trajectory, no re-simulation.

A run folder's ``trajectory.parquet`` holds each rigid body's position and orientation
(``pos_x/<body>`` ... ``quat_z/<body>``, MuJoCo body names) and each cable's tension and rest
length; ``structure.yaml`` is the robot as it ran (older folders: the model ``summary.json``
names) and ``summary.json`` holds its world (time step, terrain, contact and engine options).
A recorded pose is written into the free joints' ``qpos`` and MuJoCo's position stage
(``mj_fwdPosition``: kinematics, centre of mass, tendon paths) places everything for drawing.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from tensim._files import STRUCTURE_FILE
from tensim._input import InputError, load_json, read_text
from tensim.model import CompiledModel, WorldOptions, compile_structure
from tensim.sim import TimeSeries
from tensim.structure import Structure, load_structure

_POSE = ("pos_x", "pos_y", "pos_z", "quat_w", "quat_x", "quat_y", "quat_z")


class RunFolderError(InputError):
    """A run folder cannot be replayed; the message names the file and what is missing."""


@dataclasses.dataclass(frozen=True)
class RecordedRun:
    """A run folder's recording, ready to replay.

    Attributes:
        folder: the run folder.
        summary: the content of its summary.json.
        series: the recorded trajectory.
        compiled: the model it ran on, compiled afresh.
    """

    folder: Path
    summary: dict[str, Any]
    series: TimeSeries
    compiled: CompiledModel

    @property
    def duration(self) -> float:
        """Recorded time span [s]."""
        return float(self.series.time[-1] - self.series.time[0])


def read_summary(folder: Path) -> dict[str, Any]:
    """The run folder's summary.json.

    Raises:
        RunFolderError: it is missing or not a JSON object.
    """
    path = folder / "summary.json"
    if not path.is_file():
        raise RunFolderError(f"{path}: no such file; is {folder} a tensim run folder?")
    try:
        summary = load_json(read_text(path), str(path))
    except InputError as err:
        raise RunFolderError(str(err)) from None
    if not isinstance(summary, dict):
        raise RunFolderError(f"{path}: expected a JSON object")
    return summary


def model_structure(name: str, folder: Path) -> Structure:
    """The structure a summary's ``model`` names: a preset, or a structure file.

    A relative file path is looked up from the working directory, then from the run folder.

    Raises:
        RunFolderError: neither a preset nor an existing structure file.
    """
    from tensim.models import PRESETS, preset
    from tensim.structure import load_structure

    if name in PRESETS:
        return preset(name).build()
    for path in (Path(name), folder / name):
        if path.suffix in (".yaml", ".yml") and path.is_file():
            return load_structure(path)
    raise RunFolderError(f"{folder / 'summary.json'}: field 'model' is {name!r}, which is neither "
                         f"a preset ({', '.join(PRESETS)}) nor a structure file found from here "
                         f"or from {folder}")


def load_run(folder: Path) -> RecordedRun:
    """Reads a run folder and compiles its model.

    Raises:
        RunFolderError: summary.json or trajectory.parquet is missing or lacks what a replay
            needs.
    """
    folder = Path(folder)
    summary = read_summary(folder)
    path = folder / "trajectory.parquet"
    if not path.is_file():
        raise RunFolderError(f"{path}: no such file; this run folder holds no recorded poses")
    try:
        series = TimeSeries.from_parquet(path)
    except KeyError:
        raise RunFolderError(f"{path}: no column 'time'") from None
    except Exception as err:  # pyarrow's many errors of a damaged file
        raise RunFolderError(f"{path}: cannot be read as a trajectory "
                             f"({type(err).__name__}: {str(err)[:200]})") from None
    return recorded_run(folder, summary, series)


def recorded_run(folder: Path, summary: dict[str, Any], series: TimeSeries,
                 compiled: CompiledModel | None = None) -> RecordedRun:
    """A run from its summary and trajectory (as read from, or about to be written to, folder).

    Args:
        folder: the run folder.
        summary: its summary.
        series: its trajectory.
        compiled: the robot the run simulated, where the caller still holds it (the command
            that just ran it); None compiles it again from the folder's structure file (or the
            preset the summary names) in the summary's world.

    Raises:
        RunFolderError: the summary names no model, or the trajectory lacks a body's pose.
    """
    name = summary.get("model")
    if not isinstance(name, str):
        raise RunFolderError(f"{folder / 'summary.json'}: field 'model' (the preset or structure "
                             "file the run used) is missing")
    if compiled is None:
        recorded = folder / STRUCTURE_FILE
        structure = load_structure(recorded) if recorded.is_file() \
            else model_structure(name, folder)
        compiled = compile_structure(structure, _world(summary, folder))
    missing = [f"{q}/{body}" for body in compiled.index.bodies for q in _POSE
               if f"{q}/{body}" not in series.channels]
    if missing:
        raise RunFolderError(f"{folder / 'trajectory.parquet'}: no channel {missing[0]!r} (and "
                             f"{len(missing) - 1} more missing); the poses of model {name!r} "
                             "cannot be replayed")
    _check_poses(folder / "trajectory.parquet", series, compiled)
    return RecordedRun(folder, summary, series, compiled)


def _check_poses(path: Path, series: TimeSeries, compiled: CompiledModel) -> None:
    """Refuses a recording a replay would draw wrong: a time that is not finite or does not
    increase, a pose (or bead position) that is not finite, naming the column and row.

    Raises:
        RunFolderError: naming the file, the column, the row and the value.
    """
    try:
        time = np.asarray(series.time, dtype=float)
    except (TypeError, ValueError):
        raise RunFolderError(f"{path}: column 'time' does not hold numbers") from None
    if time.size == 0:
        raise RunFolderError(f"{path}: no samples")
    bad = np.flatnonzero(~np.isfinite(time))
    if bad.size:
        raise RunFolderError(f"{path}: column 'time', row {bad[0]}: {time[bad[0]]} is not a "
                             "finite time")
    back = np.flatnonzero(np.diff(time) <= 0)
    if back.size:
        k = int(back[0])
        raise RunFolderError(f"{path}: column 'time' does not increase at row {k + 1} "
                             f"({time[k]:g} s, then {time[k + 1]:g} s); a recording runs "
                             "forward in time")
    columns = [f"{q}/{body}" for body in compiled.index.bodies for q in _POSE]
    columns += [f"bead_{a}/{bead}" for bead in compiled.index.beads for a in "xyz"
                if f"bead_{a}/{bead}" in series.channels]
    for column in columns:
        try:
            values = np.asarray(series[column], dtype=float)
        except (TypeError, ValueError):
            raise RunFolderError(f"{path}: column {column!r} does not hold numbers") from None
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise RunFolderError(f"{path}: column {column!r}, row {bad[0]} (t = "
                                 f"{time[bad[0]]:g} s): {values[bad[0]]} is not a finite "
                                 f"pose; {bad.size} such rows")


def _world(summary: dict[str, Any], folder: Path) -> WorldOptions:
    """The run's world from the summary's fields (:func:`tensim.runs.world_record`); fields a
    summary lacks (folders written before they were recorded) keep their defaults.

    Raises:
        RunFolderError: a field cannot be read back.
    """
    from tensim.terrain import TerrainError, parse_terrain

    defaults = WorldOptions()
    try:
        world = WorldOptions(
            timestep=float(summary.get("dt_s", defaults.timestep)),
            contact_timeconst=float(summary.get("contact_timeconst_s",
                                                defaults.contact_timeconst)),
            midphase=bool(summary.get("midphase", defaults.midphase)),
            self_collision=bool(summary.get("self_collision", defaults.self_collision)),
            cone=str(summary.get("cone", defaults.cone)),
            noslip_iterations=int(summary.get("noslip_iterations", defaults.noslip_iterations)),
            condim=int(summary.get("condim", defaults.condim)),
            torsional_friction=float(summary.get("torsional_friction_m",
                                                 defaults.torsional_friction)),
            rolling_friction=float(summary.get("rolling_friction_m",
                                               defaults.rolling_friction)),
            cable_law=str(summary.get("cable_law", defaults.cable_law)),
            split_margin=float(summary.get("split_margin", defaults.split_margin)),
            min_inertia_ratio=float(summary.get("min_inertia_ratio",
                                                defaults.min_inertia_ratio)))
    except (TypeError, ValueError, OverflowError) as err:
        raise RunFolderError(f"{folder / 'summary.json'}: {str(err)[:200]}") from None
    text = summary.get("terrain")
    if not isinstance(text, str) or not text:
        return world
    try:
        return dataclasses.replace(world, terrain=parse_terrain(text))
    except TerrainError as err:
        raise RunFolderError(f"{folder / 'summary.json'}: field 'terrain': {err}") from err


class PoseReplay:
    """Puts recorded samples into an ``MjData`` for drawing.

    Args:
        run: the recorded run.
    """

    def __init__(self, run: RecordedRun):
        compiled, series = run.compiled, run.series
        model = compiled.model
        self.compiled = compiled
        self.model, self.data = model, mujoco.MjData(model)
        self.time = series.time
        self._qpos = np.tile(model.qpos0, (series.time.size, 1))
        for name, body in zip(compiled.index.bodies, compiled.index.body, strict=True):
            joint = model.body_jntadr[body]
            if joint < 0:  # welded to the world: nothing to place
                continue
            start = model.jnt_qposadr[joint]
            pose = np.stack([series[f"{q}/{name}"] for q in _POSE], axis=1)
            self._qpos[:, start:start + 7] = pose
        for name, body in zip(compiled.index.beads, compiled.index.bead, strict=True):
            if f"bead_x/{name}" in series.channels:  # slide joints x, y, z from the body's place
                start = model.jnt_qposadr[model.body_jntadr[body]]
                self._qpos[:, start:start + 3] = np.stack(
                    [series[f"bead_{a}/{name}"] for a in "xyz"], axis=1) - model.body_pos[body]
        cables, n = compiled.index.cables, series.time.size

        def recorded(quantity: str) -> bool:
            return all(f"{quantity}/{c}" in series.channels for c in cables)

        # without recorded tensions every cable is drawn taut; without rest lengths, the build's
        self.tension = series.matrix("tension", cables) if cables and recorded("tension") \
            else np.ones((n, len(cables)))
        self.rest_length = series.matrix("rest_length", cables) \
            if cables and recorded("rest_length") else np.tile(compiled.rest_length, (n, 1))

    def sample_at(self, t: float) -> int:
        """Index of the last sample at or before time ``t`` [s] (the first one before it)."""
        return int(np.clip(np.searchsorted(self.time, t + 1e-9, side="right") - 1, 0,
                           self.time.size - 1))

    def place(self, k: int) -> mujoco.MjData:
        """Puts sample ``k``'s pose into the data and runs the position stage."""
        self.data.qpos[:] = self._qpos[k]
        self.data.time = float(self.time[k])
        mujoco.mj_fwdPosition(self.model, self.data)
        return self.data
