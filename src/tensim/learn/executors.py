"""Where trials run: as batches on threads in this process (the default), one by one in this
process, in a local process pool, or on a Ray cluster.

An executor is bound to one problem and turns tasks ``(index, unit point)`` into
:class:`~tensim.learn.problem.Evaluation` s, yielded as they finish (in any order; the driver
restores ask order). A trial that raises is already a failed evaluation
(:func:`~tensim.learn.problem.evaluate_task`); an executor only has to survive workers that
die. The process pool then restarts and tries the interrupted trials again one at a time, so
the trial that kills its worker is found and given up on after ``max_attempts`` tries while the
others finish normally; on Ray the same, and a cluster that keeps failing otherwise (a node
died, a result was lost) stops the run with :class:`ClusterError` rather than record trials
that never ran. Pool workers exit when the process that started them dies, however it dies, so
none is left behind.
"""

from __future__ import annotations

import collections
import concurrent.futures as cf
import logging
import multiprocessing
import os
import select
import socket
import threading
import time
from collections.abc import Iterator, Sequence
from typing import Any, Protocol

import numpy as np

from tensim._files import pid_alive
from tensim.control.cpg import compiled_available as compiled_cpg_available
from tensim.learn.problem import (
    Evaluation,
    Problem,
    evaluate_task,
    evaluation_of,
    lost_evaluation,
)

log = logging.getLogger(__name__)
Task = tuple[int, np.ndarray]

# the problem of a pool worker process, set once by the pool's initializer
_WORKER_PROBLEM: list[Problem] = []


class Executor(Protocol):
    """Runs trials of one problem."""

    workers: int
    backend: str

    def run(self, tasks: Sequence[Task]) -> Iterator[Evaluation]:
        """Evaluates every task, yielding each evaluation as it finishes."""

    def close(self) -> None:
        """Releases the workers."""


class InlineExecutor:
    """Runs trials one after another in this process (debugging, tiny problems)."""

    backend = "inline"
    workers = 1

    def __init__(self, problem: Problem):
        self.problem = problem

    def run(self, tasks: Sequence[Task]) -> Iterator[Evaluation]:
        """Evaluates the tasks in order."""
        for index, unit in tasks:
            yield evaluate_task(self.problem, index, unit)

    def close(self) -> None:
        """Nothing to release."""

    def __enter__(self) -> InlineExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class ThreadBatchExecutor:
    """Runs trials as batches in this process, on threads (the default).

    A problem with ``evaluate_batch`` (a simulated gait) runs up to ``batch_size`` trials per
    call of the batch engine, its trials spread over ``workers`` threads; others run inline.
    With ``engine="warp"`` a call is one MuJoCo Warp batch (one world per trial; a GPU holds
    thousands, so the default batch size is a whole generation). A batch's gaits are built
    first, on ``workers`` threads, or with ``process_builds`` on as many worker processes (the
    default only where CPGs integrate in Python).
    """

    def __init__(self, problem: Problem, workers: int, batch_size: int | None = None,
                 engine: str = "cpu", process_builds: bool | None = None):
        self.problem, self.workers, self.engine = problem, max(1, workers), engine
        self.batch_size = batch_size or (32 if engine == "cpu" else 4096)
        self.backend = "threads" if engine == "cpu" else "warp"
        # a CPG gait is an ODE integration, built before its batch on ``workers`` threads of
        # this process when it runs compiled (~1.5 ms; the C call releases the GIL), and on
        # worker processes when it runs in Python (~25 ms; process_builds None without the
        # compiled integrator, or True): their start (~0.7 s) and transfers only pay off then
        self._processes = not compiled_cpg_available() if process_builds is None \
            else process_builds
        self._builders: cf.Executor | None = None
        self._parallel = self.workers > 1 and hasattr(problem, "build_gaits")

    def _build(self, units: Sequence[np.ndarray]) -> list[Any]:
        share = max(1, -(-len(units) // self.workers))
        parts = [list(units[k:k + share]) for k in range(0, len(units), share)]
        if self._processes:
            if self._builders is None:
                self._builders = cf.ProcessPoolExecutor(self.workers, _context(),
                                                        initializer=_init_worker,
                                                        initargs=(self.problem, os.getpid()))
            built = self._builders.map(_build_gaits, parts)
        else:
            if self._builders is None:
                self._builders = cf.ThreadPoolExecutor(self.workers,
                                                       thread_name_prefix="tensim-gaits")
            built = self._builders.map(self.problem.build_gaits, parts)  # type: ignore[attr-defined]
        return [g for part in built for g in part]

    def run(self, tasks: Sequence[Task]) -> Iterator[Evaluation]:
        """Evaluates the tasks, a batch at a time."""
        evaluate = getattr(self.problem, "evaluate_batch", None)
        if evaluate is None:
            for index, unit in tasks:
                yield evaluate_task(self.problem, index, unit)
            return
        for first in range(0, len(tasks), self.batch_size):
            chunk = tasks[first:first + self.batch_size]
            start = time.perf_counter()
            try:
                outcomes = evaluate([np.asarray(u, dtype=float) for _, u in chunk],
                                    self.workers, self.engine,
                                    self._build if self._parallel else None)
            except Exception as err:  # the whole batch failed: try its trials one by one
                log.warning("batch of %d trials failed (%s); running them one at a time",
                            len(chunk), err)
                for index, unit in chunk:
                    yield evaluate_task(self.problem, index, unit)
                continue
            wall = (time.perf_counter() - start) / len(chunk)
            for (index, unit), outcome in zip(chunk, outcomes, strict=True):
                yield evaluation_of(self.problem, index, unit, outcome, wall)

    def close(self) -> None:
        """Stops the gait builders (the batch's threads end with each call)."""
        if self._builders is not None:
            self._builders.shutdown(wait=True, cancel_futures=True)
            self._builders = None

    def __enter__(self) -> ThreadBatchExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _init_worker(problem: Problem, parent: int) -> None:
    _WORKER_PROBLEM[:] = [problem]
    threading.Thread(target=_exit_with, args=(parent,), daemon=True,
                     name="tensim-parent-watch").start()


def _exit_with(parent: int) -> None:
    """Ends this worker process as soon as process ``parent`` has ended (even by SIGKILL, which
    gives the pool no chance to stop its workers)."""
    try:
        fd = os.pidfd_open(parent)  # Linux: readable once the process has ended
    except (AttributeError, OSError):
        fd = None
    if fd is not None:
        select.select([fd], [], [])
    else:
        while pid_alive(parent):
            time.sleep(1.0)
    os._exit(1)


def _warm_worker(_: int) -> int:
    compiled = getattr(_WORKER_PROBLEM[0], "compiled", None)
    if compiled is not None:
        compiled()  # compile the robot now rather than in the first trial
    return os.getpid()


def _build_gaits(units: list[np.ndarray]) -> list[Any]:
    return _WORKER_PROBLEM[0].build_gaits(units)  # type: ignore[attr-defined]


def _pool_task(index: int, unit: np.ndarray) -> Evaluation:
    return evaluate_task(_WORKER_PROBLEM[0], index, unit)


def _context() -> multiprocessing.context.BaseContext:
    """Fresh worker processes that inherit no state: forked from a server process that has
    imported tensim once (``forkserver``), or started from scratch (``spawn``) where there is
    no fork."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(["tensim.learn.problem"])
    return context


class ProcessPoolExecutor:
    """A pool of worker processes on this machine, which inherit no state from this one.

    Each worker receives the problem once, at start, and compiles the robot once.

    Args:
        problem: the problem every task belongs to.
        workers: number of worker processes.
        max_attempts: tries of a trial whose worker process died before it is recorded as lost.
    """

    backend = "process-pool"

    def __init__(self, problem: Problem, workers: int, max_attempts: int = 3):
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.problem, self.workers, self.max_attempts = problem, workers, max_attempts
        self._pool = self._new_pool()

    def _new_pool(self) -> cf.ProcessPoolExecutor:
        return cf.ProcessPoolExecutor(self.workers, _context(), initializer=_init_worker,
                                      initargs=(self.problem, os.getpid()))

    def warm_up(self) -> None:
        """Starts every worker and compiles the robot in each (before timing anything)."""
        list(self._pool.map(_warm_worker, range(self.workers)))

    def run(self, tasks: Sequence[Task]) -> Iterator[Evaluation]:
        """Evaluates the tasks in parallel; trials cut short by a dying worker are tried again."""
        queue: collections.deque[tuple[int, np.ndarray, int]] = collections.deque(
            (i, u, 0) for i, u in tasks)
        suspects: collections.deque[tuple[int, np.ndarray, int]] = collections.deque()
        running: dict[cf.Future[Evaluation], tuple[int, np.ndarray, int]] = {}
        while queue or suspects or running:
            if suspects and not running:  # after a crash: one at a time finds the culprit
                index, unit, tries = suspects.popleft()
                running[self._pool.submit(_pool_task, index, unit)] = (index, unit, tries)
            while queue and not suspects and len(running) < 2 * self.workers:
                index, unit, tries = queue.popleft()
                running[self._pool.submit(_pool_task, index, unit)] = (index, unit, tries)
            finished, _ = cf.wait(running, return_when=cf.FIRST_COMPLETED)
            broken = False
            while finished:
                for future in finished:
                    task = running.pop(future)
                    try:
                        yield future.result()
                    except cf.process.BrokenProcessPool:
                        broken = True
                        yield from self._retry(task, suspects)
                # a broken pool fails every other running trial at once: collect them too
                finished = cf.wait(running)[0] if broken else set()
            if broken:
                self._pool.shutdown(wait=True, cancel_futures=True)
                self._pool = self._new_pool()

    def _retry(self, task: tuple[int, np.ndarray, int], suspects: collections.deque
               ) -> Iterator[Evaluation]:
        index, unit, tries = task
        if tries + 1 >= self.max_attempts:
            reason = f"lost: its worker process died in each of {self.max_attempts} tries"
            log.warning("evaluation %d %s", index, reason)
            yield lost_evaluation(self.problem, index, unit, reason)
        else:
            log.info("evaluation %d: worker process died, trying again", index)
            suspects.append((index, unit, tries + 1))

    def close(self) -> None:
        """Stops the workers (after their current trial)."""
        self._pool.shutdown(wait=True, cancel_futures=True)

    def __enter__(self) -> ProcessPoolExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _ray_task(problem: Problem, tasks: list[Task]) -> list[Evaluation]:
    """A Ray task: a share of the generation as one batch on the worker's own thread."""
    return list(ThreadBatchExecutor(problem, 1).run(tasks))


CONNECT_TIMEOUT_S = 10.0  # how long a Ray head may take to accept a connection


def check_reachable(address: str, option: str, timeout: float = CONNECT_TIMEOUT_S) -> None:
    """Refuses a Ray address whose head does not accept a connection within ``timeout`` [s]
    (``ray.init`` itself retries an unreachable one for minutes). ``host:port`` and
    ``ray://host:port`` are probed; ``auto``, ``local`` and the like are left to Ray.

    Raises:
        ClusterError: naming the option, the address and the cause.
    """
    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if not sep or not port.isdigit() or not host:
        return
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout).close()
    except OSError as err:
        cause = "no answer" if isinstance(err, TimeoutError) else (err.strerror or str(err))
        raise ClusterError(f"{option} {address}: the Ray head cannot be reached ({cause} "
                           f"within {timeout:g} s); check the address and that the cluster "
                           "runs (ray status on its head)") from None


class ClusterError(RuntimeError):
    """The cluster failed to run some trials, again and again, for reasons of its own (nodes
    or workers that died, results that were lost); those trials are not recorded, so resuming
    the run evaluates them."""


def connect_ray(address: str | None, workers: int) -> bool:
    """Connects this process to Ray, as ``ray.init`` finds it: the cluster at ``address``,
    else the one ``RAY_ADDRESS`` names or ``ray start`` started on this machine, else a new
    local Ray of ``workers`` CPUs. An existing cluster keeps its own CPUs (Ray refuses
    ``num_cpus`` when it connects).

    Returns:
        Whether this call connected (False: this process was connected already).
    """
    import ray

    if ray.is_initialized():
        return False
    named = address or os.environ.get("RAY_ADDRESS")
    if named:
        check_reachable(named, "--ray-address" if address else "RAY_ADDRESS")
    if address:
        ray.init(address=address, log_to_driver=False)
        return True
    try:
        ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
    except ValueError as err:  # Ray found a running cluster: connect to it as it is
        if "existing cluster" not in str(err):
            raise
        ray.init(log_to_driver=False)
    return True


class RayExecutor:
    """Trials as Ray tasks, on a running cluster (``address``) or a local Ray started here.

    Each generation is split into one share per CPU of the cluster, and each task evaluates its
    share as a batch (:class:`ThreadBatchExecutor`). The problem goes into Ray's object store
    once; Ray reuses worker processes, so each compiles the robot once.

    A trial's own failure (it raises, its simulation diverges) is an evaluation like any other.
    The cluster's failures are not: Ray retries a task whose worker or node died up to
    ``max_attempts`` − 1 times; a share whose worker died in every try is split into one task
    per trial, and a trial whose worker dies in each of its own tries is recorded as ``lost``
    (it kills its worker, as in the process pool). Any other failure of the cluster (a node
    died, a result was lost, the task could not run) has the share submitted again, up to
    ``max_attempts`` times, and then raises :class:`ClusterError`: the trials are not recorded,
    and resuming the run evaluates them, so it ends as an uninterrupted run would.

    Args:
        problem: the problem every task belongs to.
        address: address of a running Ray cluster (``ray://host:10001`` or ``host:6379``);
            None: the cluster ``RAY_ADDRESS`` names or ``ray start`` started here, else a
            local Ray of ``workers`` CPUs (:func:`connect_ray`).
        workers: CPUs of a local Ray this starts.
        max_attempts: tries of a task before its failure counts.
    """

    backend = "ray"

    def __init__(self, problem: Problem, address: str | None = None, workers: int = 1,
                 max_attempts: int = 3):
        import ray

        self.problem, self.max_attempts = problem, max_attempts
        self._started = connect_ray(address, workers)
        self.workers = int(ray.cluster_resources().get("CPU", workers))
        self._remote = ray.remote(_ray_task).options(max_retries=max_attempts - 1,
                                                     retry_exceptions=False)
        self._problem_ref = ray.put(problem)

    def run(self, tasks: Sequence[Task]) -> Iterator[Evaluation]:
        """Submits every task; yields each evaluation as its task finishes.

        Raises:
            ClusterError: the cluster failed a share ``max_attempts`` times.
        """
        import ray

        share = max(1, -(-len(tasks) // self.workers))
        pending: dict[Any, tuple[list[Task], int]] = {}
        failed: list[str] = []

        def submit(chunk: list[Task], tries: int) -> None:
            pending[self._remote.remote(self._problem_ref, chunk)] = (chunk, tries)

        for k in range(0, len(tasks), share):
            submit(list(tasks[k:k + share]), 1)
        while pending:
            try:
                done, _ = ray.wait(list(pending), num_returns=1)
            except (ConnectionError, ray.exceptions.RaySystemError) as err:
                raise ClusterError(f"lost the Ray cluster ({_describe(err)}): its head node "
                                   "stopped or cannot be reached") from None
            for ref in done:
                chunk, tries = pending.pop(ref)
                try:
                    yield from ray.get(ref)
                except ray.exceptions.WorkerCrashedError:
                    # its worker died in each of Ray's tries: find the trial that kills it
                    if len(chunk) > 1:
                        log.info("a task's worker died %d times; its %d trials run one by one",
                                 self.max_attempts, len(chunk))
                        for task in chunk:
                            submit([task], 1)
                        continue
                    index, unit = chunk[0]
                    reason = f"lost: its worker process died in each of {self.max_attempts} tries"
                    log.warning("evaluation %d %s", index, reason)
                    yield lost_evaluation(self.problem, index, unit, reason)
                except ray.exceptions.RayError as err:
                    if tries < self.max_attempts:
                        log.warning("Ray failed a task of %d trial(s) (%s); submitting it "
                                    "again", len(chunk), type(err).__name__)
                        submit(chunk, tries + 1)
                    else:  # the other shares finish first: their trials are recorded
                        failed.append(f"{len(chunk)} trial(s) failed {tries} times, last by "
                                      f"{_describe(err)}")
        if failed:
            raise ClusterError("the Ray cluster could not run every trial: " + "; ".join(failed))

    def close(self) -> None:
        """Disconnects from Ray (a local Ray this executor started stops)."""
        import ray

        if self._started and ray.is_initialized():
            ray.shutdown()

    def __enter__(self) -> RayExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _describe(err: BaseException) -> str:
    """A Ray error in one line: its type and its cause's first line (a failure inside a task,
    e.g. an argument whose owner died, comes wrapped in ``RayTaskError``)."""
    cause = getattr(err, "cause", None) or err
    lines = [line for line in str(cause).strip().split("\n") if line.strip()]
    return f"{type(err).__name__}: {lines[0] if lines else 'no message'}"


def make_executor(problem: Problem, workers: int, *, ray: bool = False,
                  ray_address: str | None = None, processes: bool = False,
                  engine: str = "cpu") -> Executor:
    """The executor for the command line's choice.

    Args:
        problem: the problem.
        workers: threads of the batch engine, or worker processes with ``processes`` or Ray
            (0: run trials one by one in this process).
        ray: run on Ray (a local one unless ``ray_address`` is given).
        ray_address: address of a running Ray cluster (implies ``ray``).
        processes: one trial per task on a local process pool instead of batches on threads.
        engine: ``"cpu"`` or ``"warp"`` (MuJoCo Warp batches, ``tensim[gpu]``).
    """
    if engine == "warp":
        if ray or ray_address or processes:
            raise ValueError("--backend warp runs in this process: drop --ray and --processes")
        return ThreadBatchExecutor(problem, max(1, workers), engine="warp")
    if ray or ray_address:
        return RayExecutor(problem, ray_address, max(1, workers))
    if workers == 0:
        return InlineExecutor(problem)
    if processes:
        return ProcessPoolExecutor(problem, workers)
    return ThreadBatchExecutor(problem, workers)
