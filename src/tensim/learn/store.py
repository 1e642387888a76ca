"""The run folder: configuration, every evaluation as it finishes, optimizer checkpoints.

Layout of a learning run folder::

    config.json           resolved configuration, seed, budget, package versions
    problem.pkl           the problem itself (robot, base controller, objective), which a
                          resume reads, so it needs nothing outside the folder
    structure.yaml        the robot, readable (trial problems)
    base_controller.yaml  the impedance laws the gaits are put on, readable
    evaluations.jsonl     one line per finished evaluation (index, unit point, parameter
                          values, score, status, reason, wall time, metrics), appended and
                          flushed to disk as each trial finishes
    checkpoint.pkl        optimizer state after its last tell, and the session log (atomic)
    best_controller.yaml  the best gait so far on the base controller (trial problems)
    learning_curve.png    score of every evaluation and the best so far
    summary.json          best_score, evaluations, wall_s, evaluations_per_s, ... (last)

A crash can leave at most a torn last line in ``evaluations.jsonl``; it is dropped when the
run is opened again. Every other file is replaced atomically.
"""

from __future__ import annotations

import json
import os
import pickle
from pathlib import Path
from typing import Any

from tensim._files import atomic_path, write_json
from tensim._input import InputError
from tensim.control import save_controller
from tensim.learn.problem import Evaluation, Problem, TrialProblem
from tensim.structure import save_structure

CONFIG = "config.json"
PROBLEM = "problem.pkl"
STRUCTURE = "structure.yaml"
BASE_CONTROLLER = "base_controller.yaml"
EVALUATIONS = "evaluations.jsonl"
CHECKPOINT = "checkpoint.pkl"
BEST_CONTROLLER = "best_controller.yaml"
CURVE = "learning_curve.png"
SUMMARY = "summary.json"


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

    def path(self, name: str) -> Path:
        """A file of the run folder."""
        return self.folder / name

    def exists(self) -> bool:
        """Whether the folder holds a run (its configuration)."""
        return self.path(CONFIG).is_file()

    # -- configuration and problem ---------------------------------------------------------

    def create(self, config: dict[str, Any], problem: Problem) -> None:
        """Writes the configuration and, for a trial problem, its robot and base controller.

        Raises:
            RunFolderError: the folder already holds a run.
        """
        if self.exists() or self.path(EVALUATIONS).exists():
            raise RunFolderError(f"{self.folder}: already holds a learning run; continue it "
                                 "with --resume, or choose another --out")
        self.folder.mkdir(parents=True, exist_ok=True)
        if isinstance(problem, TrialProblem):
            save_structure(problem.structure, self.path(STRUCTURE))
            save_controller(problem.base, self.path(BASE_CONTROLLER))
        self._pickle(PROBLEM, problem)
        self.write_config(config)

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
        try:
            return json.loads(path.read_text())
        except json.JSONDecodeError as err:
            raise RunFolderError(f"{path}: not valid JSON: {err}") from None

    def load_problem(self) -> Problem:
        """The run's problem, as saved in the folder.

        Raises:
            RunFolderError: it is missing.
        """
        return self._unpickle(PROBLEM)

    # -- evaluations -----------------------------------------------------------------------

    def evaluations(self) -> dict[int, Evaluation]:
        """Every recorded evaluation by index (a torn last line is ignored).

        Raises:
            RunFolderError: a damaged line before the last one.
        """
        path = self.path(EVALUATIONS)
        if not path.exists():
            return {}
        lines = path.read_text().split("\n")
        found: dict[int, Evaluation] = {}
        for number, line in enumerate(lines[:-1], start=1):  # the last piece is unterminated
            try:
                evaluation = Evaluation.from_json(json.loads(line))
            except (json.JSONDecodeError, KeyError, TypeError, ValueError) as err:
                raise RunFolderError(f"{path}: line {number} is damaged ({err})") from None
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

    def append(self, evaluation: Evaluation) -> None:
        """Appends one evaluation and forces it to disk."""
        self._log.write(json.dumps(evaluation.to_json()) + "\n")
        self._log.flush()
        os.fsync(self._log.fileno())

    def close_log(self) -> None:
        """Closes the evaluation log."""
        if self._log is not None:
            self._log.close()
            self._log = None

    # -- checkpoints -----------------------------------------------------------------------

    def save_checkpoint(self, state: dict[str, Any]) -> None:
        """Pickles the driver state (optimizer included) atomically."""
        self._pickle(CHECKPOINT, state)

    def load_checkpoint(self) -> dict[str, Any]:
        """The last checkpoint.

        Raises:
            RunFolderError: none was written.
        """
        return self._unpickle(CHECKPOINT)

    def _pickle(self, name: str, obj: object) -> None:
        with atomic_path(self.path(name)) as tmp, tmp.open("wb") as f:
            pickle.dump(obj, f, protocol=pickle.HIGHEST_PROTOCOL)

    def _unpickle(self, name: str) -> Any:
        path = self.path(name)
        if not path.is_file():
            raise RunFolderError(f"{path}: missing; the run cannot be resumed")
        with path.open("rb") as f:
            return pickle.load(f)
