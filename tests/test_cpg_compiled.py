"""The compiled CPG integrator against scipy's DOP853, the reference it reimplements."""

from __future__ import annotations

import concurrent.futures as cf
import logging
import re

import numpy as np
import pytest

from tensim.control import (
    CPGNetwork,
    GaitError,
    SolverSettings,
    _cpg_native,
    cpg,
    solve,
    spine_parameters,
)
from tensim.control.cpg import _network_arrays
from tensim.models import tetraspine3

SCIPY = SolverSettings(backend="scipy")
COMPILED = SolverSettings(backend="compiled")

pytestmark = pytest.mark.skipif(not _cpg_native.available(),
                                reason="compiled CPG integrator not built")


def _uncoupled(seed: int) -> tuple[CPGNetwork, tuple[float, ...], tuple[float, ...]]:
    """Five uncoupled oscillators with random ν, R, a, θ(0), r(0) (the closed form holds)."""
    rng = np.random.default_rng(seed)
    net = CPGNetwork(tuple("abcde"), tuple(rng.uniform(0.1, 2.0, 5)),
                     tuple(rng.uniform(0.0, 0.07, 5)), tuple(rng.uniform(2.0, 30.0, 5)))
    return net, tuple(rng.uniform(-3.0, 3.0, 5)), tuple(rng.uniform(0.0, 0.07, 5))


@pytest.mark.parametrize("seed", range(3))
def test_compiled_is_as_accurate_as_scipy_on_the_closed_form(seed):
    # θ = θ(0) + 2πν t and r − R = (r(0) − R)(1 + a t/2) e^{−a t/2} (eq. 5, dr/dt(0) = 0)
    net, phase, amplitude = _uncoupled(seed)
    fast = solve(net, 10.0, 0.01, phase, amplitude, settings=COMPILED)
    slow = solve(net, 10.0, 0.01, phase, amplitude, settings=SCIPY)
    t = fast.times[:, None]
    a, target, r0 = (np.array(x) for x in (net.convergence, net.amplitude, amplitude))
    r = target + (r0 - target) * (1 + a * t / 2) * np.exp(-a * t / 2)
    theta = np.array(phase) + 2 * np.pi * np.array(net.frequency) * t
    # θ is linear in t, which the method integrates exactly: rounding only (|θ| < 130 rad)
    np.testing.assert_allclose(fast.phase, theta, rtol=0, atol=1e-12)
    # the same method errs alike, but not to the digit: rounding in the error estimate (a
    # difference of nearly equal stage sums) can flip an accept/reject decision, and numpy's
    # SIMD kernels round scipy's own sums differently on different CPUs. Measured global errors
    # over 10 s at rtol = atol = 1e-10: 8e-10 to 1.3e-7 m/s on both paths, on two machines; so
    # both within 3e-7 m/s (a wrong coefficient costs the method its order: the evaluation
    # count below then moves by far more than a few flipped steps)
    for trajectory in (fast, slow):
        assert np.abs(trajectory.amplitude - r).max() <= 3e-7
    # the same step control: a few flipped decisions at most (12 evaluations each; measured
    # 0-6 %), where another controller or a wrong error estimator takes far more or fewer steps
    assert fast.evaluations == pytest.approx(slow.evaluations, rel=0.1)


@pytest.mark.parametrize("seed", range(4))
def test_compiled_equals_scipy_on_random_learning_points(seed):
    # random points of the Tetraspine3 CPG layout (116 parameters, 132 couplings): the gaits
    # learning builds, over a 10 s trial at the 10 ms command period
    layout = spine_parameters(tetraspine3())
    unit = np.random.default_rng(seed).uniform(size=layout.size)
    net = layout.network(layout.from_unit(unit))
    fast = solve(net, 10.0, 0.01, settings=COMPILED)
    slow = solve(net, 10.0, 0.01, settings=SCIPY)
    # Strong random coupling amplifies rounding: scipy's own samples move by up to 3e-8 m/s
    # when θ(0) moves by 1e-15 rad, and lie up to 3e-7 m/s from a 1e-13-tolerance solution.
    # The two paths differ by up to 3e-8 m/s (of V up to 0.07 m/s); 1e-7 leaves margin, while
    # a wrong coefficient or dense output is off by orders of magnitude more.
    np.testing.assert_allclose(fast.velocity, slow.velocity, rtol=0, atol=1e-7)
    # r does not depend on θ: only the steps' placement moves it (measured <= 3e-9 m/s)
    np.testing.assert_allclose(fast.amplitude, slow.amplitude, rtol=0, atol=1e-8)
    assert fast.evaluations == pytest.approx(slow.evaluations, rel=0.05)  # as above


def test_spine_arrays_are_the_networks_numbers():
    # the gait's fast path reads the layout's edges as arrays instead of building a
    # CPGNetwork; it must hand the integrator exactly the same numbers
    layout = spine_parameters(tetraspine3())
    rng = np.random.default_rng(7)
    for _ in range(3):
        values = layout.from_unit(rng.uniform(size=layout.size))
        for fast, slow in zip(layout._arrays(values), _network_arrays(layout.network(values)),
                              strict=True):
            np.testing.assert_array_equal(fast, slow)


def test_compiled_runs_on_many_threads_at_once():
    # the C code keeps no state between calls and ctypes releases the GIL during the call
    layout = spine_parameters(tetraspine3())
    rng = np.random.default_rng(1)
    nets = [layout.network(layout.from_unit(rng.uniform(size=layout.size))) for _ in range(6)]
    alone = [solve(n, 4.0, 0.01, settings=COMPILED).velocity for n in nets]
    with cf.ThreadPoolExecutor(3) as pool:
        together = list(pool.map(lambda n: solve(n, 4.0, 0.01, settings=COMPILED).velocity,
                                 nets))
    for a, b in zip(alone, together, strict=True):
        np.testing.assert_array_equal(a, b)  # deterministic: bit for bit


def test_without_the_library_auto_falls_back_to_scipy_and_says_so(monkeypatch, caplog):
    net = CPGNetwork(("a", "b"), 1.0, 0.05, 20.0, ((0, 1, 2.0, 0.5), (1, 0, 2.0, -0.5)))
    reference = solve(net, 2.0, 0.01, settings=SCIPY)
    monkeypatch.setattr(_cpg_native, "_LIB", None)
    monkeypatch.setattr(cpg, "_warned_scipy", False)
    with caplog.at_level(logging.WARNING, logger="tensim.control.cpg"):
        fallback = solve(net, 2.0, 0.01)
    assert "not built" in caplog.text and "scipy" in caplog.text
    np.testing.assert_array_equal(fallback.velocity, reference.velocity)  # the same path
    with pytest.raises(RuntimeError, match="C compiler"):
        solve(net, 2.0, 0.01, settings=COMPILED)


def test_other_methods_and_unknown_backends():
    with pytest.raises(ValueError, match="backend"):
        SolverSettings(backend="fortran")
    with pytest.raises(ValueError, match="DOP853"):
        SolverSettings(method="RK45", backend="compiled")
    net = CPGNetwork(("a",), 1.0, 0.05)
    # RK45 has no compiled form: "auto" integrates it with scipy
    rk45 = solve(net, 1.0, 0.01, settings=SolverSettings(method="RK45"))
    same = solve(net, 1.0, 0.01, settings=SolverSettings(method="RK45", backend="scipy"))
    np.testing.assert_array_equal(rk45.velocity, same.velocity)


def test_compiled_amplitude_guard_stops_at_the_step_past_the_bound():
    net = CPGNetwork(("a",), 1.0, 0.05, 20.0)
    # r = R (1 − (1 + a t/2) e^{−a t/2}) with R = 0.05 m/s, a = 20/s passes 0.02 m/s where
    # (1 + x) e^{−x} = 0.6, x = a t/2 = 1.3764: t = 0.13764 s
    with pytest.raises(GaitError, match="amplitude") as stop:
        solve(net, 2.0, 0.01, settings=SolverSettings(backend="compiled", max_amplitude=0.02))
    t = float(re.search(r"by t = ([0-9.]+) s", str(stop.value)).group(1))
    assert 0.13764 <= t <= 0.3  # the end of the step that crossed it (steps here < 0.1 s)
