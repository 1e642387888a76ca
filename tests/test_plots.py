"""Figure helpers: thinned lines keep every extreme; passive cables get no commanded line."""

from __future__ import annotations

import numpy as np

from tensim.sim import TimeSeries
from tensim.viz.plots import (
    PANEL_PIXELS,
    InView,
    _commanded,
    _held,
    cable_panels,
    new_figure,
    plot_cable_tensions,
    plot_lengths,
    thin,
    thin_lines,
)


def test_thinning_keeps_each_columns_extremes_and_the_ends():
    """Cut the time axis into the line's pixel columns: in every column the thinned line
    reaches exactly the data's smallest and largest value (no peak lost), from real samples
    in time order, with at most two samples a column plus the ends."""
    rng = np.random.default_rng(4)
    x = np.linspace(0.0, 60.0, 60001)
    y = np.cumsum(rng.standard_normal(x.size))
    y[rng.integers(0, x.size, 40)] += rng.choice([-1, 1], 40) * 500.0  # one-sample spikes
    y[1000:1200] = np.nan  # a gap in the recording
    for pixels in (PANEL_PIXELS, 97):
        tx, ty = thin(x, y, pixels)
        assert ty.size <= 2 * pixels + 2
        assert tx[0] == x[0] and tx[-1] == x[-1] and np.all(np.diff(tx) > 0)
        kept = np.searchsorted(x, tx)
        assert np.array_equal(x[kept], tx) and np.array_equal(y[kept], ty, equal_nan=True)
        edges = np.linspace(x[0], x[-1], pixels + 1)
        column, thinned = np.digitize(x, edges[1:-1]), np.digitize(tx, edges[1:-1])
        for c in range(pixels):
            data, line = y[column == c], ty[thinned == c]
            if np.isfinite(data).any():
                assert np.nanmax(line) == np.nanmax(data) and np.nanmin(line) == np.nanmin(data)


def test_a_held_input_thinned_keeps_each_columns_extremes():
    """The V* figure draws each command held until the next (a step line) from the step's
    corners, thinned: every pixel column still reaches the commands' extremes there."""
    rng = np.random.default_rng(5)
    t = np.arange(6001) * 0.01
    v = np.sin(t) + (rng.random(t.size) < 0.01) * rng.choice([-3.0, 3.0], t.size)  # spikes
    x, y = _held(t, v)
    assert x.size == 2 * t.size - 1 and np.all(np.diff(x) >= 0)
    tx, ty = thin(x, y)
    assert ty.size < y.size / 5 and (tx[0], ty[0], tx[-1], ty[-1]) == (0.0, v[0], 60.0, v[-1])
    edges = np.linspace(x[0], x[-1], PANEL_PIXELS + 1)[1:-1]
    column, thinned = np.digitize(x, edges), np.digitize(tx, edges)
    for c in range(PANEL_PIXELS):
        assert ty[thinned == c].max() == y[column == c].max()
        assert ty[thinned == c].min() == y[column == c].min()


def test_lines_thinned_together_are_each_thinned_alone():
    """A shared panel thins its cables in one pass (thin_lines): each line's points are exactly
    thin's, so each keeps its columns' extremes; with gaps, a line of NaN only, spikes, a time
    axis of uneven steps, and lines short enough to be kept whole."""
    rng = np.random.default_rng(6)
    for x in (np.linspace(0.0, 10.0, 1001), np.sort(rng.uniform(0.0, 5.0, 3000)),
              np.arange(50.0)):
        ys = np.cumsum(rng.standard_normal((40, x.size)), axis=1)
        ys[3, 100:140] = np.nan
        ys[4] = np.nan
        ys[5, ::7] = np.nan
        ys[6, rng.integers(0, x.size, 5)] += 300.0
        for pixels in (200, 97, PANEL_PIXELS):
            together = thin_lines(x, ys, pixels)
            assert len(together) == len(ys)
            for y, points in zip(ys, together, strict=True):
                assert np.array_equal(points, np.column_stack(thin(x, y, pixels)),
                                      equal_nan=True)


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


def test_up_to_the_panel_limit_each_cable_has_its_own_panel():
    twelve = [f"c{k}" for k in range(12)]  # Tetraspine3's figures: a panel per cable, as ever
    assert cable_panels(twelve) == tuple((c, (c,)) for c in twelve)


def test_many_cables_share_panels_by_name_path_or_tag_and_each_is_drawn_once():
    # an imported robot's names: four parts of five limbs of 10 cables, plus 6 at the top level
    names = [f"p{p}/{limb}/string_{k}" for p in range(4)
             for limb in ("spine", "fl", "fr", "bl", "br") for k in range(10)] + \
        [f"low_{k}" for k in range(6)]
    panels = cable_panels(names)
    # p/limb gives 21 groups (within the 30-panel limit), finer than p alone (5)
    assert len(panels) == 21 and panels[0] == ("p0/spine (10 cables)", tuple(names[:10]))
    assert panels[-1] == ("(top level) (6 cables)", tuple(names[-6:]))
    assert sorted(c for _, group in panels for c in group) == sorted(names)
    # flat names (the 12-segment Tetraspine's 66 cables) group by their first tag
    kinds = ("outer_top", "outer_left", "outer_right", "inner_top", "inner_left", "inner_right")
    flat = [f"{kind}_{j}" for j in range(1, 12) for kind in kinds]
    tags = {name: (name.rsplit("_", 1)[0], "joint") for name in flat}
    by_tag = cable_panels(flat, tags)
    assert [title for title, _ in by_tag] == [f"{kind} (11 cables)" for kind in kinds]
    # no names or tags to group by: the cables in order, in at most 30 runs of equal size
    runs = cable_panels(flat)
    assert len(runs) == 22 and runs[0] == ("outer_top_1 ... outer_right_1 (3 cables)",
                                           tuple(flat[:3]))


def test_a_figure_of_hundreds_of_cables_stays_a_few_rows_high(tmp_path):
    from PIL import Image

    t = np.arange(200) * 0.01
    names = [f"part{k // 40}/string_{k}" for k in range(400)]
    series = TimeSeries(t, {**{f"tension/{n}": np.sin(t + k) for k, n in enumerate(names)},
                            **{f"length/{n}": np.ones_like(t) for n in names},
                            **{f"rest_length/{n}": np.ones_like(t) for n in names}})
    for plot in (plot_cable_tensions, plot_lengths):
        with Image.open(plot(series, tmp_path / "f.png")) as image:
            # 10 panels of 40 cables on 4 rows of at most 2.4 in at 120 dpi, plus the margins
            # (one panel per cable: 134 rows, over 38,000 pixels)
            assert image.height <= 4 * 2.4 * 120 + 150


def test_panel_axes_make_only_the_ticks_they_draw():
    """A panel's locator gives MaxNLocator's ticks inside the view, so the figure draws the
    same ticks and matplotlib makes no tick artists for locations past the ends."""
    from matplotlib.ticker import MaxNLocator

    fig = new_figure((4.2, 2.4))
    ax = fig.subplots()
    ax.plot([0.0, 60.0], [3.07, 20.8])
    full = MaxNLocator(4)
    full.set_axis(ax.yaxis)
    ax.yaxis.set_major_locator(InView(4))
    fig.canvas.draw()
    low, high = ax.get_ylim()
    drawn = [t for t in full() if low <= t <= high]
    assert list(ax.yaxis.get_majorticklocs()) == drawn
    assert len(full()) > len(drawn)  # MaxNLocator alone gives ticks beyond the view
    assert len(ax.yaxis.majorTicks) == len(drawn)  # and no tick artists were made for them


def test_each_column_labels_time_under_its_lowest_panel():
    """7 panels on 3 columns: the last row holds one panel, so the other two columns end a
    row higher, and their time axes are labelled there (else they carried no time labels)."""
    from tensim.viz.plots import _grid

    panels = tuple((f"p{k}", ()) for k in range(7))
    grid = _grid("tensions", panels, 3, "test")  # type: ignore[arg-type]
    axes = [ax for ax in grid.figure.axes if ax.get_visible()]
    assert len(axes) == 7
    labelled = [k for k, ax in enumerate(axes) if ax.get_xlabel() == "time [s]"]
    assert labelled == [4, 5, 6]
    shown = [k for k, ax in enumerate(axes)
             if ax.xaxis.get_tick_params(which="major").get("labelbottom", True)]
    assert shown == [4, 5, 6]
