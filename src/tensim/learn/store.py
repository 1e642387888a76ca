"""The run folder: configuration, every evaluation as it finishes, optimizer checkpoints.

Layout of a learning run folder (data only: JSON, YAML, text; nothing that runs on load)::

    config.json           resolved configuration, seed, budget, package versions; with
                          structure.yaml and base_controller.yaml it rebuilds the problem, so
                          a resume needs nothing outside the folder
    structure.yaml        the robot (trial problems)
    base_controller.yaml  the impedance laws the gaits are put on (trial problems)
    evaluations.jsonl     one line per finished evaluation (index, unit point, parameter
                          values, score, status, reason, wall time, metrics), appended and
                          flushed to the operating system as each trial finishes (a killed
                          run loses none), forced to disk at least every second and after
                          every batch
    checkpoint.json       how many evaluations the optimizer has been told, and the session
                          log (atomic); the optimizer's state is rebuilt from the seed and
                          the told evaluations (see :mod:`tensim.learn.run`)
    best_controller.yaml  the best gait so far on the base controller (trial problems)
    learning_curve.png    score of every evaluation and the best so far
    summary.json          best_score, evaluations, wall_s, evaluations_per_s, ... (last)
    .lock                 held (``flock``) by the one process writing the run; names its pid

A crash can leave at most a torn last line in ``evaluations.jsonl``; it is dropped when the
run is opened again. Every other file is replaced atomically; the temporary files of a killed
writer are deleted by the next one.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import math
import os
import shutil
import time
from pathlib import Path
from typing import Any

from tensim._files import write_json
from tensim._input import InputError, describe, load_json, read_text
from tensim.control import load_controller, save_controller
from tensim.learn.objective import Objective
from tensim.learn.optimizers import OptimizerSettings
from tensim.learn.problem import LOST, Evaluation, Problem, SphereProblem, TrialProblem
from tensim.model import WorldOptions
from tensim.structure import load_structure, save_structure
from tensim.terrain import parse_terrain

SYNC_EVERY_S = 1.0  # longest time an appended evaluation waits for its disk flush [s]

try:
    import fcntl
except ImportError:  # not POSIX: no lock
    fcntl = None  # type: ignore[assignment]

CONFIG = "config.json"
STRUCTURE = "structure.yaml"
BASE_CONTROLLER = "base_controller.yaml"
EVALUATIONS = "evaluations.jsonl"
CHECKPOINT = "checkpoint.json"
BEST_CONTROLLER = "best_controller.yaml"
CURVE = "learning_curve.png"
SUMMARY = "summary.json"
LOCK = ".lock"
MAX_DIMENSION = 1_000  # most parameters of a sphere problem read back from a folder
FINGERPRINT = "defines_sha256"  # config.json: hashes of what defines the run's problem
_DEFINING = ("problem", "optimizer", "seed")  # the configuration's part of it


def _read_files(config: dict[str, Any]) -> tuple[str, ...]:
    """The files outside the run folder that the configuration's problem reads."""
    problem = config.get("problem")
    terrain = problem.get("terrain") if isinstance(problem, dict) else None
    if not isinstance(terrain, str):
        return ()
    try:
        return parse_terrain(terrain).files()
    except InputError:
        return ()  # a damaged terrain string is refused where the problem is rebuilt


class RunFolderError(InputError):
    """A run folder is missing, incomplete or inconsistent; the message names the file."""


class RunStore:
    """Reads and writes one learning run folder.

    Args:
        folder: the run folder.
    """

    def __init__(self, folder: str | os.PathLike[str]):
        self.folder = Path(folder)
        self._log: Any = None
        self._synced = 0.0  # time.monotonic() of the last disk flush of the log
        self._lock: int | None = None

    def path(self, name: str) -> Path:
        """A file of the run folder."""
        return self.folder / name

    def exists(self) -> bool:
        """Whether the folder holds a run (its configuration)."""
        return self.path(CONFIG).is_file()

    # -- the lock --------------------------------------------------------------------------

    def acquire(self) -> None:
        """Takes the folder's exclusive lock (creating the folder), then deletes temporary
        files a killed writer left.

        Raises:
            RunFolderError: another process holds the lock, or the folder is a file.
        """
        if self.folder.exists() and not self.folder.is_dir():
            raise RunFolderError(f"{self.folder}: is a file; expected a run folder")
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.path(LOCK), os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as err:  # name the run folder, not its lock file
            raise RunFolderError(f"{self.folder}: cannot be opened as a learning run folder "
                                 f"({err.strerror or err})") from None
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.read(fd, 32).decode(errors="replace").strip() or "?"
                os.close(fd)
                raise RunFolderError(f"{self.folder}: in use by another tensim process (pid "
                                     f"{holder}); wait for it to finish, or stop it") from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self._lock = fd
        for stale in self.folder.glob(".*.tmp"):  # atomic writes a killed writer left
            stale.unlink(missing_ok=True)

    def release(self) -> None:
        """Releases the lock."""
        if self._lock is not None:
            os.close(self._lock)  # closing the descriptor releases the flock
            self._lock = None

    @contextlib.contextmanager
    def locked(self) -> Any:
        """The lock for the duration of a ``with`` block."""
        self.acquire()
        try:
            yield self
        finally:
            self.release()

    # -- configuration and problem ---------------------------------------------------------

    def create(self, config: dict[str, Any], problem: Problem) -> None:
        """Writes the configuration and, for a trial problem, its robot and base controller.

        Raises:
            RunFolderError: the folder already holds a run, or other files.
        """
        self.check_new()
        self.folder.mkdir(parents=True, exist_ok=True)
        if isinstance(problem, TrialProblem):
            save_structure(problem.structure, self.path(STRUCTURE))
            save_controller(problem.base, self.path(BASE_CONTROLLER))
        self.write_config({**config, FINGERPRINT: self.fingerprint(config)})

    def check_new(self) -> None:
        """Refuses a folder that holds a run or other files (a new run needs a new or empty
        folder).

        Raises:
            RunFolderError: naming what the folder holds.
        """
        if self.exists() or self.path(EVALUATIONS).exists():
            raise RunFolderError(f"{self.folder}: already holds a learning run; continue it "
                                 "with --resume, or choose another --out")
        others = sorted(p.name for p in self.folder.iterdir() if p.name != LOCK) \
            if self.folder.is_dir() else []
        if others:
            raise RunFolderError(f"{self.folder}: is not empty ({', '.join(others[:4])}"
                                 f"{', ...' if len(others) > 4 else ''}); a learning run needs a "
                                 "new or empty folder: choose another --out")

    def discard(self, keep_folder: bool) -> None:
        """Removes a run that never started: the folder (or, with ``keep_folder``, what is in
        it), so a refused or failed start leaves nothing that would refuse the next one."""
        if not self.folder.is_dir():
            return
        if not keep_folder:
            shutil.rmtree(self.folder, ignore_errors=True)
            return
        for item in self.folder.iterdir():
            if item.is_dir() and not item.is_symlink():
                shutil.rmtree(item, ignore_errors=True)
            else:
                item.unlink(missing_ok=True)

    def fingerprint(self, config: dict[str, Any]) -> dict[str, str]:
        """SHA-256 of each thing that defines the run's problem: the configuration's problem,
        optimizer and seed, the robot files (structure, base controller) byte for byte, and
        the contents of every other file the problem reads (a height field's file, keyed
        ``terrain file PATH``; a missing one hashes as missing). Stored in ``config.json``
        when the run is created; a resume recomputes it."""
        parts = {key: json.dumps(config.get(key), sort_keys=True, allow_nan=False)
                 .encode() for key in _DEFINING}
        for name in (STRUCTURE, BASE_CONTROLLER):
            if self.path(name).is_file():
                parts[name] = self.path(name).read_bytes()
        for file in _read_files(config):
            path = Path(file)
            parts[f"terrain file {file}"] = path.read_bytes() if path.is_file() else b"missing"
        return {key: hashlib.sha256(data).hexdigest() for key, data in parts.items()}

    def check_fingerprint(self, config: dict[str, Any]) -> None:
        """Proves that the folder still defines the problem it was created with.

        Raises:
            RunFolderError: no stored fingerprint, or a part that differs (named).
        """
        stored = config.get(FINGERPRINT)
        if not isinstance(stored, dict):
            raise RunFolderError(f"{self.path(CONFIG)}: holds no {FINGERPRINT!r} (what defines "
                                 "the run's problem, hashed when it was created), so a resume "
                                 "cannot prove it continues the same problem; start a new run")
        try:
            now = self.fingerprint(config)
        except ValueError as err:  # a configuration holding NaN or infinity
            raise RunFolderError(f"{self.path(CONFIG)}: {err}") from None
        differ = sorted(k for k in {*stored, *now} if stored.get(k) != now.get(k))
        if differ:
            where = [f"{k} (config.json)" if k in _DEFINING else k for k in differ]
            raise RunFolderError(f"{self.folder}: {', '.join(where)} changed since the run "
                                 "was created; a resume must continue the same problem: "
                                 "restore the file, or start a new run with --out")

    def write_config(self, config: dict[str, Any]) -> None:
        """Replaces ``config.json``."""
        write_json(self.path(CONFIG), config)

    def read_config(self) -> dict[str, Any]:
        """The saved configuration.

        Raises:
            RunFolderError: no run in the folder, or an unreadable configuration.
        """
        path = self.path(CONFIG)
        if not path.is_file():
            raise RunFolderError(f"{self.folder}: not a learning run folder (no {CONFIG})")
        config = self._json(CONFIG)
        if not isinstance(config, dict) or not isinstance(config.get("problem"), dict):
            raise RunFolderError(f"{path}: expected a JSON object with a 'problem' mapping")
        for key, top in (("evaluations", None), ("seed", 2**32)):
            value = config.get(key)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0 \
                    or (top is not None and value >= top):
                raise RunFolderError(f"{path}: {key!r} must be a whole number >= 0"
                                     + (f" and < {top}" if top else "")
                                     + f", got {describe(value)}")
        try:
            OptimizerSettings(**config["optimizer"])
        except (KeyError, TypeError, ValueError) as err:
            raise RunFolderError(f"{path}: 'optimizer' must be a mapping of optimizer settings "
                                 f"({err})") from None
        return config

    def load_problem(self) -> Problem:
        """The run's problem, rebuilt from ``config.json`` and the robot files.

        Raises:
            RunFolderError: a missing or inconsistent file, naming it.
        """
        data = self.read_config()["problem"]
        try:
            if data.get("kind") == "sphere":
                dimension = data["dimension"]
                if isinstance(dimension, bool) or not isinstance(dimension, int) \
                        or not 1 <= dimension <= MAX_DIMENSION:
                    raise ValueError(f"dimension must be a whole number in [1, "
                                     f"{MAX_DIMENSION}], got {describe(dimension)}")
                return SphereProblem(dimension, float(data["center"]), float(data["penalty"]))
            if data.get("kind") == "trial":
                return self._trial(data)
        except (KeyError, TypeError) as err:
            raise RunFolderError(f"{self.path(CONFIG)}: problem: missing or malformed {err}"
                                 ) from None
        except (InputError, ValueError) as err:
            raise RunFolderError(f"{self.folder}: the problem cannot be rebuilt: {err}"
                                 ) from None
        raise RunFolderError(f"{self.path(CONFIG)}: unknown problem kind {data.get('kind')!r}; "
                             "expected 'trial' or 'sphere'")

    def _trial(self, data: dict[str, Any]) -> TrialProblem:
        structure = load_structure(self.path(STRUCTURE))
        base = load_controller(self.path(BASE_CONTROLLER), structure)
        world = dict(data["world"])
        world["gravity"] = tuple(world["gravity"])
        world["terrain"] = parse_terrain(data["terrain"])
        objective = dict(data["objective"])
        if objective.get("target_xy") is not None:
            objective["target_xy"] = tuple(objective["target_xy"])
        fields = {f.name for f in dataclasses.fields(Objective)}
        randomize = tuple((str(name), float(low), float(high))
                          for name, (low, high) in data.get("randomize", {}).items())
        return TrialProblem(structure, base, data["family"], data["duration_s"],
                            Objective(**{k: v for k, v in objective.items() if k in fields}),
                            WorldOptions(**world), data["record_dt_s"], data["penalty"],
                            data["model"], randomize, int(data.get("robots", 1)),
                            str(data.get("robust", "mean")),
                            int(data.get("randomize_seed", 0)),
                            tuple((str(name), float(value))
                                  for name, value in data.get("start_from", {}).items()))

    # -- evaluations -----------------------------------------------------------------------

    def evaluations(self) -> dict[int, Evaluation]:
        """Every recorded evaluation by index (a torn last line is ignored).

        Raises:
            RunFolderError: a damaged line before the last one.
        """
        path = self.path(EVALUATIONS)
        if not path.exists():
            return {}
        try:
            lines = read_text(path).split("\n")
        except InputError as err:
            raise RunFolderError(str(err)) from None
        found: dict[int, Evaluation] = {}
        for number, line in enumerate(lines[:-1], start=1):  # the last piece is unterminated
            try:
                raw = json.loads(line)
                index = raw["index"]
                if isinstance(index, bool) or not isinstance(index, int):
                    raise ValueError(f"index must be a whole number, got {describe(index)}")
                evaluation = Evaluation.from_json(raw)
            except (json.JSONDecodeError, KeyError, TypeError, ValueError,
                    OverflowError) as err:
                raise RunFolderError(f"{path}: line {number} is damaged ({err})") from None
            if not all(math.isfinite(u) for u in evaluation.unit):
                raise RunFolderError(f"{path}: line {number} is damaged (a point that is not "
                                     "finite)")
            if not math.isfinite(evaluation.score):
                raise RunFolderError(f"{path}: line {number} is damaged (score "
                                     f"{evaluation.score}, expected a finite number)")
            earlier = found.get(evaluation.index)
            # a trial lost to the cluster is run again on resume: its new record replaces it
            if evaluation.index < 0 or (earlier is not None and earlier.status != LOST):
                what = "a negative index" if evaluation.index < 0 else \
                    f"evaluation {evaluation.index} recorded a second time"
                raise RunFolderError(f"{path}: line {number} is damaged ({what})")
            found[evaluation.index] = evaluation
        return found

    def open_log(self) -> None:
        """Opens ``evaluations.jsonl`` for appending, dropping a torn last line first."""
        path = self.path(EVALUATIONS)
        if path.exists():
            data = path.read_bytes()
            end = data.rfind(b"\n") + 1
            if end != len(data):
                with path.open("r+b") as f:
                    f.truncate(end)
        self._log = path.open("a")
        self._synced = time.monotonic()

    def append(self, evaluation: Evaluation) -> None:
        """Appends one evaluation and hands it to the operating system (a killed process
        loses nothing); forces the log to disk if :data:`SYNC_EVERY_S` has passed since it
        last was (a disk flush per evaluation cost 8 ms each, most of a 1024-world
        generation's time on a GPU)."""
        self._log.write(json.dumps(evaluation.to_json()) + "\n")
        self._log.flush()
        if time.monotonic() - self._synced >= SYNC_EVERY_S:
            self.sync()

    def sync(self) -> None:
        """Forces the evaluations appended so far to disk (after every batch, and on close)."""
        if self._log is not None:
            self._log.flush()
            os.fsync(self._log.fileno())
        self._synced = time.monotonic()

    def close_log(self) -> None:
        """Forces the evaluation log to disk and closes it."""
        if self._log is not None:
            self.sync()
            self._log.close()
            self._log = None

    # -- checkpoints -----------------------------------------------------------------------

    def save_checkpoint(self, state: dict[str, Any]) -> None:
        """Writes the driver state (evaluations told, sessions) as JSON, atomically."""
        write_json(self.path(CHECKPOINT), state)

    def load_checkpoint(self) -> dict[str, Any]:
        """The last checkpoint.

        Raises:
            RunFolderError: none was written, or it is damaged.
        """
        if not self.path(CHECKPOINT).is_file():
            raise RunFolderError(f"{self.path(CHECKPOINT)}: missing; the run cannot be resumed")
        state = self._json(CHECKPOINT)
        told = state.get("told") if isinstance(state, dict) else None
        if isinstance(told, bool) or not isinstance(told, int) or told < 0 \
                or not isinstance(state.get("sessions"), list):
            raise RunFolderError(f"{self.path(CHECKPOINT)}: expected a JSON object with 'told' "
                                 "(a count >= 0) and 'sessions' (a list)")
        return state

    def _json(self, name: str) -> Any:
        try:
            return load_json(read_text(self.path(name)), str(self.path(name)))
        except InputError as err:
            raise RunFolderError(str(err)) from None
