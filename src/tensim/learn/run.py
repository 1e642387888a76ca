"""The learning driver: ask a batch, evaluate it in parallel, tell it in ask order, checkpoint.

One loop serves a fresh run and a resumed one. Evaluations are logged as they finish; after
every tell the checkpoint records how many evaluations the optimizer has been told. The
optimizer's state is never stored: optimizers are deterministic given their seed and the costs
they are told, so a resume builds a fresh optimizer from the configuration and tells it the
logged costs batch by batch, asking each batch again and checking it against the log (bit for
bit). That rebuilds the state exactly, then the run asks the next batch and reuses every
evaluation of it already in the log, so no finished trial is run twice and the run ends with
exactly the evaluations an uninterrupted run would have made. A trial of that batch logged as
``lost`` (its worker died in every try) is run again. A batch cut short by the
evaluation budget is evaluated but not told; extending the budget later completes and tells it.
A run holds its folder's lock (:meth:`RunStore.acquire`) while it writes.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import logging
import platform
import time
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import OptimizeResult

from tensim import __version__
from tensim._files import write_json
from tensim.learn.executors import Executor, make_executor
from tensim.learn.optimizers import Optimizer, OptimizerSettings
from tensim.learn.problem import LOST, OK, Evaluation, Problem, TrialProblem
from tensim.learn.store import (
    BEST_CONTROLLER,
    CURVE,
    EVALUATIONS,
    SUMMARY,
    RunFolderError,
    RunStore,
)

log = logging.getLogger(__name__)
# progress(done, total, best score or None, failed trials) after every evaluation of a session
ProgressFn = Callable[[int, int, float | None, int], None]
ExecutorFactory = Callable[[Problem], Executor]
_NAMED_VALUES = 8  # a best controller's description lists its parameters up to this many


@dataclasses.dataclass(frozen=True)
class LearningSettings:
    """How to search, as saved with a run.

    Attributes:
        optimizer: which optimizer and its knobs.
        evaluations: evaluation budget.
        seed: seed of the optimizer (the only randomness of a run).
    """

    optimizer: OptimizerSettings = dataclasses.field(default_factory=OptimizerSettings)
    evaluations: int = 100
    seed: int = 0

    def __post_init__(self) -> None:
        if self.evaluations < 1:
            raise ValueError(f"evaluations must be >= 1, got {self.evaluations}")
        if not 0 <= self.seed < 2**32:
            raise ValueError(f"seed must be in [0, 2^32), got {self.seed}")


def _versions() -> dict[str, str]:
    import importlib.metadata

    import mujoco

    # cma's version from its metadata: importing cma costs a second (see import_cma)
    return {"tensim": __version__, "mujoco": mujoco.__version__, "numpy": np.__version__,
            "cma": importlib.metadata.version("cma"), "python": platform.python_version()}


def create_run(out: str | Path, problem: Problem, settings: LearningSettings) -> RunStore:
    """Creates a run folder: resolved configuration, robot files, initial checkpoint.

    A creation that fails (a problem that cannot be read back, a full disk) removes what it
    wrote, so the folder is as it was (absent, or empty).

    Raises:
        RunFolderError: ``out`` already holds a run.
    """
    store = RunStore(out)
    existed = store.folder.is_dir()
    checked = False
    try:
        with store.locked():
            store.check_new()
            checked = True
            _create(store, problem, settings)
    except BaseException:
        if checked or not existed:
            store.discard(keep_folder=existed)
        raise
    return store


def _create(store: RunStore, problem: Problem, settings: LearningSettings) -> None:
    config = {"format": "tensim-learning-run", "version": 1,
              "problem": problem.to_dict(),
              "optimizer": dataclasses.asdict(settings.optimizer),
              "evaluations": settings.evaluations, "seed": settings.seed,
              "versions": _versions(),
              "created_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")}
    store.create(config, problem)
    # a resume rebuilds the problem from the folder's files: check that it is the same problem
    loaded = store.load_problem()
    same = loaded == problem if isinstance(problem, TrialProblem) else True
    if not same or not np.array_equal(loaded.start(), problem.start()):
        raise RunFolderError(f"{store.folder}: the problem read back from the folder differs "
                             "from the one given; it could not be resumed")
    store.save_checkpoint({"told": 0, "sessions": []})


def learn(problem: Problem, settings: LearningSettings, out: str | Path, *, workers: int = 1,
          executor: ExecutorFactory | None = None, progress: ProgressFn | None = None
          ) -> OptimizeResult:
    """Learns from scratch into the new run folder ``out``; see :func:`resume`.

    A run that fails before it starts evaluating (an executor that cannot start, a cluster
    that cannot be reached) leaves no run folder.
    """
    existed = Path(out).is_dir()
    create_run(out, problem, settings)
    with discard_unstarted(out, existed):
        return _run(RunStore(out), None, problem, workers=workers, executor=executor,
                    progress=progress)


@contextlib.contextmanager
def discard_unstarted(out: str | Path, existed: bool) -> Iterator[None]:
    """Removes the new run folder ``out`` (or empties it, if it ``existed``) when the block
    fails with an error before the run started evaluating (its executor could not start: no
    evaluation log was opened). A run that started keeps its folder, to resume, even if it
    recorded nothing (a cluster node that died under the first generation); so does an
    interruption."""
    try:
        yield
    except Exception:
        store = RunStore(out)
        if not store.path(EVALUATIONS).exists():
            store.discard(keep_folder=existed)
        raise


def resume(out: str | Path, evaluations: int | None = None, *, workers: int = 1,
           executor: ExecutorFactory | None = None, progress: ProgressFn | None = None
           ) -> OptimizeResult:
    """Runs the run in ``out`` until its evaluation budget is spent or the optimizer stops.

    Args:
        out: the run folder.
        evaluations: a new evaluation budget (None: the saved one).
        workers: worker processes of the default executor (a local process pool).
        executor: builds the executor for the run's problem (overrides ``workers``).
        progress: called after every evaluation of this session.

    Returns:
        scipy's ``OptimizeResult``: ``x`` best parameter values, ``fun`` = −best score,
        ``nfev`` evaluations, plus ``best_score``, ``best_index`` and ``summary`` (the mapping
        written to ``summary.json``).

    Raises:
        RunFolderError: a missing or inconsistent run folder.
    """
    return _run(RunStore(out), evaluations, None, workers=workers, executor=executor,
                progress=progress)


def _run(store: RunStore, evaluations: int | None, problem: Problem | None, *, workers: int,
         executor: ExecutorFactory | None, progress: ProgressFn | None) -> OptimizeResult:
    """Holds the folder's lock while it runs the run (``problem``: None reads the folder's)."""
    if not store.exists():
        store.read_config()  # raises: not a run folder (before the lock creates the folder)
    with store.locked():
        config = store.read_config()
        store.check_fingerprint(config)
        if evaluations is not None and evaluations != config["evaluations"]:
            if evaluations < 1:
                raise ValueError(f"evaluations must be >= 1, got {evaluations}")
            config["evaluations"] = evaluations
            store.write_config(config)
        problem = store.load_problem() if problem is None else problem
        state = store.load_checkpoint()
        session = _Session(store, problem, config, state, progress)
        factory = executor or (lambda p: make_executor(p, workers))
        runner = factory(problem)
        session.record["workers"], session.record["backend"] = runner.workers, runner.backend
        store.open_log()
        try:
            session.loop(runner)
        finally:
            runner.close()
            store.close_log()
            session.finish()
        return session.result()


def _rank(evaluation: Evaluation) -> tuple[bool, float, int]:
    """Sort key of the best evaluation: successful first, then score, then the earliest."""
    return evaluation.status == OK, evaluation.score, -evaluation.index


class _Session:
    """One sitting of a run: the loop, the best so far and the outputs."""

    def __init__(self, store: RunStore, problem: Problem, config: dict[str, Any],
                 state: dict[str, Any], progress: ProgressFn | None):
        self.store, self.problem, self.config, self.state = store, problem, config, state
        self.progress = progress
        self.logged = store.evaluations()
        self.optimizer: Optimizer = self._rebuild(int(state["told"]))
        self.budget = int(config["evaluations"])
        self.started = time.perf_counter()
        self.record: dict[str, Any] = {
            "started_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "evaluations_run": 0, "wall_s": 0.0}
        state["sessions"] = [*state["sessions"], self.record]
        self.best: Evaluation | None = None
        for evaluation in self.logged.values():
            self._update_best(evaluation, write=False)
        self.stop_reason = ""
        self.total = max(0, self.budget - len(self.logged))

    def _rebuild(self, told: int) -> Optimizer:
        """A fresh optimizer told the first ``told`` logged costs, batch by batch as the run
        told them: the state the run's optimizer had after its last tell, exactly."""
        settings = OptimizerSettings(**self.config["optimizer"])
        try:
            optimizer = settings.build(self.problem.dimension, int(self.config["seed"]),
                                       self.problem.start())
        except ValueError as err:  # settings that do not fit the problem
            raise RunFolderError(f"{self.store.path('config.json')}: {err}") from None
        done = 0
        while done < told:
            if optimizer.done:
                break
            points = optimizer.ask()
            self._check_logged(done, points)
            missing = [done + k for k in range(len(points)) if done + k not in self.logged]
            if missing or done + len(points) > told:
                break
            optimizer.tell(points, np.asarray(
                [-self.logged[done + k].score for k in range(len(points))]))
            done += len(points)
        if done != told:
            raise RunFolderError(
                f"{self.store.folder}: the checkpoint says {told} evaluations were told, but "
                f"the log and the optimizer agree on only {done}; the files are from different "
                "runs or damaged")
        return optimizer

    def loop(self, executor: Executor) -> None:
        """Asks, evaluates and tells until the budget is spent or the optimizer stops."""
        while self.state["told"] < self.budget:
            if self.optimizer.done:
                self.stop_reason = self.optimizer.stop_reason
                return
            points = self.optimizer.ask()
            first = self.state["told"]
            ahead = sorted(i for i in self.logged if i >= first + len(points))
            if ahead:  # the log runs past the batch the optimizer asks now
                raise RunFolderError(
                    f"{self.store.path(EVALUATIONS)}: evaluation {ahead[0]} is out of sequence: "
                    f"{first} are told and the optimizer asks {first} to "
                    f"{first + len(points) - 1} next; the log is damaged or edited")
            wanted = points[:self.budget - first]
            tasks = [(first + k, u) for k, u in enumerate(wanted)
                     if first + k not in self.logged or self.logged[first + k].status == LOST]
            self._check_logged(first, wanted)
            for evaluation in executor.run(tasks):
                self._take(evaluation)
            self.store.sync()
            if len(wanted) < len(points):  # evaluated now, told if the budget is extended
                break
            costs = [-self.logged[first + k].score for k in range(len(points))]
            self.optimizer.tell(points, np.asarray(costs))
            self.state["told"] = first + len(points)
            self._checkpoint()
        self.stop_reason = "evaluation budget spent"

    def _check_logged(self, first: int, points: np.ndarray) -> None:
        for k, unit in enumerate(points):
            known = self.logged.get(first + k)
            if known is not None and not np.array_equal(known.unit, unit):
                raise RunFolderError(
                    f"{self.store.folder}: evaluation {first + k} in the log does not match "
                    "the point the optimizer asks for; the log and checkpoint are from "
                    "different runs")

    def _take(self, evaluation: Evaluation) -> None:
        self.store.append(evaluation)
        self.logged[evaluation.index] = evaluation
        self.record["evaluations_run"] += 1
        if evaluation.status != OK:
            log.info("evaluation %d %s: %s", evaluation.index, evaluation.status,
                     evaluation.reason)
        self._update_best(evaluation, write=True)
        if self.progress is not None:
            failed = sum(e.status != OK for e in self.logged.values())
            best = None if self.best is None else self.best.score
            self.progress(self.record["evaluations_run"], self.total, best, failed)

    def _update_best(self, evaluation: Evaluation, write: bool) -> None:
        if self.best is not None and _rank(evaluation) <= _rank(self.best):
            return
        self.best = evaluation
        if write and isinstance(self.problem, TrialProblem) and evaluation.status == OK:
            self._write_best()

    def _write_best(self) -> None:
        from tensim.control import save_controller

        best, problem = self.best, self.problem
        assert best is not None and isinstance(problem, TrialProblem)
        text = (f"learned by tensim learn ({self.config['optimizer']['name']}, seed "
                f"{self.config['seed']}): evaluation {best.index}, score {best.score:.6g} "
                f"({problem.objective.describe()}) over {problem.duration_s:g} s")
        if problem.dimension <= _NAMED_VALUES:  # a few numbers: say them
            text += "; " + ", ".join(f"{n} = {v:.6g}" for n, v in
                                     zip(problem.layout.names, best.values, strict=True))
        save_controller(problem.controller(np.asarray(best.unit), text),
                        self.store.path(BEST_CONTROLLER))

    def _checkpoint(self) -> None:
        self.record["wall_s"] = time.perf_counter() - self.started
        self.store.save_checkpoint(self.state)

    def finish(self) -> None:
        """Checkpoints the session log, draws the learning curve, writes ``summary.json``."""
        from tensim.learn.plots import plot_learning_curve

        self._checkpoint()
        evaluations = [self.logged[i] for i in sorted(self.logged)]
        if evaluations:
            plot_learning_curve(evaluations, self.store.path(CURVE), title=self._title())
        write_json(self.store.path(SUMMARY), self.summary())

    def _title(self) -> str:
        problem = self.config["problem"]
        what = (f"{problem.get('model')} {problem.get('family')}: "
                f"{problem.get('objective_text')}" if problem["kind"] == "trial"
                else f"{problem['kind']} ({problem['dimension']} parameters)")
        return f"{what}\n{self.config['optimizer']['name']}, seed {self.config['seed']}"

    def summary(self) -> dict[str, Any]:
        """The run's headline figures and its configuration."""
        wall = sum(s["wall_s"] for s in self.state["sessions"])
        n = len(self.logged)
        best = self.best
        failed = Counter(e.status for e in self.logged.values() if e.status != OK)
        out: dict[str, Any] = {
            "best_score": None if best is None else best.score,
            "best_index": None if best is None else best.index,
            "best_status": None if best is None else best.status,
            "evaluations": n, "wall_s": wall,
            "evaluations_per_s": round(n / wall, 4) if wall > 0 else None,
            "budget": self.budget, "finished": n >= self.budget or bool(self.stop_reason),
            "stop_reason": self.stop_reason, "failed": dict(failed),
            "best_metrics": None if best is None else best.metrics,
            "sessions": self.state["sessions"], "config": self.config,
        }
        if best is not None and best.status == OK and isinstance(self.problem, TrialProblem):
            out["best_controller"] = BEST_CONTROLLER
        return out

    def result(self) -> OptimizeResult:
        """The run as scipy's ``OptimizeResult``."""
        best = self.best
        summary = self.summary()
        return OptimizeResult(
            x=None if best is None else np.asarray(best.values),
            fun=None if best is None else -best.score, nfev=len(self.logged),
            success=best is not None and best.status == OK, message=self.stop_reason,
            best_score=summary["best_score"], best_index=summary["best_index"],
            summary=summary)
