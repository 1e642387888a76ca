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


def test_the_tension_colour_scale_follows_the_run():
    from tensim.model import compile_structure
    from tensim.models import preset
    from tensim.viz.cables import TensionColors, nice_ceiling

    assert [nice_ceiling(v) for v in (0.3, 1.0, 1.2, 2.2, 3.0, 32.5, 499.0)] == \
        [0.5, 1.0, 2.0, 2.5, 5.0, 50.0, 500.0]
    assert TensionColors.for_run(np.array([[3.0, 12.0], [32.4991, np.nan]])).max_tension == 50.0
    # prism3's verticals start at sqrt(3) x 40 N/m x 0.3174 m = 21.99 N (force density x length):
    # twice that, 44 N, rounds up to 50 N, far below the 500 N motor limit that left every
    # cable the same blue
    compiled = compile_structure(preset("prism3").build())
    assert TensionColors.for_model(compiled).max_tension == 50.0
