"""Figure helpers: thinned lines keep every extreme; passive cables get no commanded line."""

from __future__ import annotations

import numpy as np

from tensim.sim import TimeSeries
from tensim.viz.plots import MAX_POINTS, _commanded, thin


def test_thinning_keeps_each_groups_extremes_and_the_ends():
    rng = np.random.default_rng(4)
    x = np.linspace(0.0, 60.0, 6001)
    y = np.cumsum(rng.standard_normal(x.size))
    tx, ty = thin(x, y)
    assert ty.size <= MAX_POINTS + 10  # two per group, plus the ends and a partial group
    assert ty.max() == y.max() and ty.min() == y.min()
    assert tx[0] == x[0] and tx[-1] == x[-1] and np.all(np.diff(tx) > 0)
    # every kept sample is a real one, and each span between kept samples stays inside the
    # kept line's range over it, so the drawn envelope is the data's
    assert np.isin(tx, x).all() and np.allclose(ty, np.interp(tx, x, y))


def test_short_lines_are_drawn_whole():
    x = np.arange(10.0)
    assert thin(x, x ** 2)[1].size == 10


def test_a_cable_without_an_impedance_law_has_no_commanded_tension():
    t = np.arange(5) * 0.01
    series = TimeSeries(t, {"tension/a": np.ones(5), "setpoint/a": np.full(5, np.nan),
                            "tension/b": np.ones(5), "setpoint/b": np.full(5, 3.0)})
    assert _commanded(series, "a") is None
    assert np.all(_commanded(series, "b") == 3.0)
