"""One BLAS thread for the design analyses' small dense linear algebra.

The analyses' SVDs and eigenproblems are of the order of a robot's degrees of freedom (tens to
a few thousand). OpenBLAS spreads such a matrix over every core and its threads spin while
they wait for work; on a machine whose cores are busy with other programs they mostly spin,
and an analysis costs several times its single-thread CPU time (the 796-cable centipede's
stiffness: 9-15 s of CPU against 3.2-3.7 s). Below :data:`SMALL_ORDER` the analyses run with
one BLAS thread (threadpoolctl limits the thread pools of the BLAS libraries loaded).
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable, Iterator
from typing import Any, ParamSpec, TypeVar

from threadpoolctl import ThreadpoolController

from tensim.structure import Structure

SMALL_ORDER = 3000  # matrices up to this order: one BLAS thread

P = ParamSpec("P")
R = TypeVar("R")


@functools.cache
def _controller() -> ThreadpoolController:
    """The BLAS libraries loaded (looked up once: numpy's and scipy's load on import)."""
    return ThreadpoolController()


@contextlib.contextmanager
def blas_threads(order: int) -> Iterator[None]:
    """Runs its block with one BLAS thread where matrices of ``order`` are small."""
    if order > SMALL_ORDER:
        yield
        return
    with _controller().limit(limits=1, user_api="blas"):
        yield


def one_blas_thread(function: Callable[P, R]) -> Callable[P, R]:
    """Runs ``function(structure, ...)`` with one BLAS thread where the structure is small:
    its matrices are at most 6 x nodes on a side (six coordinates per rigid body)."""

    @functools.wraps(function)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        structure: Any = args[0] if args else kwargs.get("structure")
        order = 6 * len(structure.nodes) if isinstance(structure, Structure) else 0
        with blas_threads(order):
            return function(*args, **kwargs)

    return wrapper
