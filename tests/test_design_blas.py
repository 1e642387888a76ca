"""The design analyses' linear algebra: one BLAS thread for small matrices, one rigid-body
computation per check."""

from __future__ import annotations

import threadpoolctl

from tensim.design import _bodies, check_structure, stiffness
from tensim.design._blas import SMALL_ORDER, one_blas_thread
from tensim.models import preset


def _blas_threads() -> set[int]:
    return {i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"}


def test_small_structures_run_their_analyses_on_one_blas_thread():
    structure = preset("tetraspine3").build()
    seen = []

    @one_blas_thread
    def analysis(s):
        seen.append(_blas_threads())

    before = _blas_threads()
    analysis(structure)
    assert seen == [{1}]
    assert _blas_threads() == before  # the limit ends with the call
    assert 6 * len(structure.nodes) <= SMALL_ORDER


def test_check_structure_computes_the_rigid_bodies_once(monkeypatch):
    structure = preset("tetraspine3").build()
    calls = []
    original = _bodies.bodies
    monkeypatch.setattr(_bodies, "bodies", lambda s: calls.append(1) or original(s))
    check_structure(structure)
    assert len(calls) == 1
    calls.clear()
    stiffness(structure)  # the counts' equilibrium shares the pose too
    assert len(calls) == 1
