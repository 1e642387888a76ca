"""Figures drawn by a second process: the same pictures as drawn here, errors that surface,
a lost process replaced, and a main process that never loads matplotlib for them."""

from __future__ import annotations

import dataclasses
import logging
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tensim.control.velocity_table import VelocityTable
from tensim.sim import TimeSeries
from tensim.viz.drawing import (
    FigureDrawer,
    FigureError,
    FigurePlan,
    Span,
    background_pays,
)

CABLES = ("a", "b", "c", "d")


def _series() -> TimeSeries:
    rng = np.random.default_rng(7)
    t = np.arange(3001) * 0.01
    channels: dict[str, np.ndarray] = {}
    for k, name in enumerate(CABLES):
        channels[f"tension/{name}"] = 10.0 + k + np.cumsum(rng.standard_normal(t.size)) * 0.1
        channels[f"setpoint/{name}"] = 10.0 + k + np.sin(t)
        channels[f"length/{name}"] = 0.2 + 0.01 * np.sin(t + k)
        channels[f"rest_length/{name}"] = 0.19 + 0.01 * np.cos(t + k)
    for body in ("segment_0", "com"):
        channels[f"pos_x/{body}"] = 0.01 * t
        channels[f"pos_y/{body}"] = 0.02 * np.sin(t)
    return TimeSeries(t, channels)


def _plans() -> list[FigurePlan]:
    return [FigurePlan("tensions.png", "tensions", {
                "cables": CABLES, "columns": 2, "title": "tensions\nsecond line",
                "spans": (Span(10.0, 20.0, "push"), Span(12.0, 14.0, "hold", 0.25))}),
            FigurePlan("lengths.png", "lengths", {"cables": CABLES}),
            FigurePlan("velocity_input.png", "velocity_input", {"cables": CABLES}),
            FigurePlan("path.png", "path")]


def _draw_all(drawer: FigureDrawer, folder: Path) -> None:
    series = _series()
    table = VelocityTable(CABLES, 0.01,
                          np.tile(np.sin(np.arange(100) * 0.1)[:, None], (1, len(CABLES))))
    drawer.draw("tensions.png", series, folder)
    drawer.draw("lengths.png", series, folder)
    drawer.draw("velocity_input.png", table, folder, until=0.5)
    drawer.draw("path.png", series, folder, title="moved")
    drawer.wait()


def _pixels(path: Path) -> np.ndarray:
    with Image.open(path) as image:
        return np.asarray(image.convert("RGBA"))


def test_a_drawing_process_draws_the_same_figures_as_this_one(tmp_path):
    here, there = tmp_path / "here", tmp_path / "there"
    here.mkdir()
    there.mkdir()
    _draw_all(FigureDrawer(_plans()), here)
    with FigureDrawer(_plans(), background=True) as drawer:
        assert drawer.background
        _draw_all(drawer, there)
        assert not drawer.pending
    for name in ("tensions.png", "lengths.png", "velocity_input.png", "path.png"):
        a, b = _pixels(here / name), _pixels(there / name)
        assert a.shape == b.shape and a.shape[0] > 200
        # laid out before the data came, the grid ends as one laid out at once
        assert np.array_equal(a, b), name
        assert len(np.unique(a.reshape(-1, 4), axis=0)) > 20  # a real picture, not a blank


def test_figures_that_share_one_grid_draw_what_each_draws_on_its_own(tmp_path):
    """A drawer fills one panel grid with each figure in turn (tensions with shaded spans
    and set y limits, then autoscaled lengths, then V* with its zero line): each is the
    figure its plot function draws on a grid of its own, pixel for pixel."""
    from tensim.viz import plots

    shared, alone = tmp_path / "shared", tmp_path / "alone"
    shared.mkdir()
    alone.mkdir()
    plans = [dataclasses.replace(plan, options={**plan.options, "columns": 3})
             if plan.file == "tensions.png" else plan for plan in _plans()]
    drawer = FigureDrawer(plans)
    _draw_all(drawer, shared)
    table = VelocityTable(CABLES, 0.01,
                          np.tile(np.sin(np.arange(100) * 0.1)[:, None], (1, len(CABLES))))
    options = {plan.file: dict(plan.options) for plan in plans}
    plots.plot_cable_tensions(_series(), alone / "tensions.png", **options["tensions.png"])
    plots.plot_lengths(_series(), alone / "lengths.png", **options["lengths.png"])
    plots.plot_velocity_input(table, alone / "velocity_input.png", until=0.5,
                              **options["velocity_input.png"])
    for name in ("tensions.png", "lengths.png", "velocity_input.png"):
        assert np.array_equal(_pixels(shared / name), _pixels(alone / name)), name


def test_a_figure_that_fails_in_the_drawing_process_fails_the_command(tmp_path):
    plans = [FigurePlan("tensions.png", "tensions", {"cables": ("a", "no_such_cable")})]
    with FigureDrawer(plans, background=True) as drawer:
        drawer.draw("tensions.png", _series(), tmp_path)
        with pytest.raises(FigureError, match=r"(?s)tensions.png: .*no channel 'tension/no_such"):
            drawer.wait()
    assert not (tmp_path / "tensions.png").exists()


def test_a_lost_drawing_process_is_replaced_by_drawing_here(tmp_path, caplog):
    with FigureDrawer(_plans(), background=True) as drawer:
        drawer._process.kill()  # as an out-of-memory kill would
        drawer._process.wait()
        with caplog.at_level(logging.WARNING, logger="tensim.viz.drawing"):
            _draw_all(drawer, tmp_path)
    assert "drawing here instead" in caplog.text
    assert all((tmp_path / p.file).is_file() for p in _plans())


def test_closing_with_figures_pending_stops_the_process(tmp_path):
    drawer = FigureDrawer(_plans(), background=True)
    process = drawer._process
    drawer.draw("tensions.png", _series(), tmp_path)
    drawer.close()  # as when the command fails: the staging folder is about to go
    assert process.poll() is not None  # ended (killed) before close returned


def test_a_second_core_starts_a_drawing_process_whatever_the_load(monkeypatch):
    monkeypatch.setattr("os.sched_getaffinity", lambda pid: {0, 1})
    monkeypatch.setattr("os.getloadavg", lambda: (0.9, 0.5, 0.5))  # this run alone
    assert background_pays()
    # a busy machine too: matplotlib stays out of the process that holds the run
    monkeypatch.setattr("os.getloadavg", lambda: (9.6, 9.5, 9.5))
    assert background_pays()
    monkeypatch.setattr("os.sched_getaffinity", lambda pid: {0})
    monkeypatch.setattr("os.getloadavg", lambda: (0.0, 0.0, 0.0))
    assert not background_pays()


def test_plans_load_no_matplotlib_and_refuse_unknown_kinds():
    probe = ("import sys; from tensim.experiments.disturbance import disturbance_figures; "
             "from tensim.experiments.gait import gait_figures; disturbance_figures(); "
             "gait_figures('cpg', ['a']); print('matplotlib.pyplot' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "False"
    with pytest.raises(ValueError, match="unknown figure kind 'bars'"):
        FigurePlan("x.png", "bars")


def test_the_drawing_process_loads_no_mujoco_and_gets_only_the_channels_it_draws(tmp_path):
    """The child loads the drawing modules without the tensim package (MuJoCo, the time
    series' Parquet library), draws what it is sent there, and is sent only the channels
    (or the V* table's data) each figure draws."""
    import pickle

    from tensim.viz import _drawchild
    from tensim.viz.drawing import portable

    table = VelocityTable(CABLES, 0.01, np.ones((10, len(CABLES))))
    sent = {kind: portable(kind, data) for kind, data in
            (("tensions", _series()), ("lengths", _series()), ("path", _series()),
             ("velocity_input", table))}
    assert sorted(sent["path"].channels) == ["pos_x/com", "pos_x/segment_0", "pos_y/com",
                                             "pos_y/segment_0"]
    assert set(sent["tensions"].channels) == {f"{q}/{c}" for q in ("tension", "setpoint")
                                              for c in CABLES}
    assert np.array_equal(sent["velocity_input"].times, table.times)
    (tmp_path / "jobs.pickle").write_bytes(pickle.dumps(sent))
    probe = textwrap.dedent(f"""
        import pickle, sys
        from pathlib import Path
        sys.path.insert(0, {str(Path(_drawchild.__file__).parent)!r})
        import _drawchild
        _drawchild.register_bare(Path(_drawchild.__file__).resolve().parents[1])
        _drawchild.load_drawing()  # as the child: no property lists in docstrings
        import gc, matplotlib.lines
        from tensim.viz import drawing, plots
        assert gc.isenabled() and "antialiased" not in (matplotlib.lines.Line2D.set.__doc__
                                                        or "")
        jobs = pickle.loads(Path({str(tmp_path / "jobs.pickle")!r}).read_bytes())
        plots.plot_velocity_input(jobs["velocity_input"], Path({str(tmp_path / "v.png")!r}))
        plots.plot_lengths(jobs["lengths"], Path({str(tmp_path / "l.png")!r}))
        print(sorted(m for m in ("mujoco", "pyarrow", "tensim.control", "tensim.model")
                     if m in sys.modules))
        """)
    out = subprocess.run([sys.executable, "-P", "-c", probe], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"
    assert (tmp_path / "v.png").is_file() and (tmp_path / "l.png").is_file()


def test_a_figure_is_sent_only_what_it_draws_and_draws_the_same_picture(tmp_path):
    """Of a chosen few cables a per-cable figure is sent only theirs; of many (panels shared by
    groups of cables, which draw no commanded tension) no commanded tensions. Drawn from what
    is sent, each figure is the picture drawn from the whole run, pixel for pixel."""
    from tensim.viz import plots
    from tensim.viz.drawing import portable

    many = [f"group_{k % 3}/cable_{k}" for k in range(plots.MAX_PANELS + 10)]
    rng = np.random.default_rng(3)
    t = np.arange(1001) * 0.01
    channels = {f"{q}/{c}": rng.standard_normal(t.size).cumsum() for c in many
                for q in ("tension", "setpoint", "length", "rest_length", "applied")}
    series = TimeSeries(t, channels)
    cases = [("tensions", {"cables": many[:3]}, ("tension", "setpoint"), many[:3]),
             ("tensions", {"cables": many}, ("tension",), many),
             ("tensions", {}, ("tension",), many),
             ("lengths", {"cables": many}, ("length", "rest_length"), many)]
    for k, (kind, options, quantities, cables) in enumerate(cases):
        sent = portable(kind, series, options)
        assert set(sent.channels) == {f"{q}/{c}" for q in quantities for c in cables}
        draw = getattr(plots, {"tensions": "plot_cable_tensions",
                               "lengths": "plot_lengths"}[kind])
        images = [np.asarray(Image.open(draw(data, tmp_path / f"{k}_{n}.png", **options)))
                  for n, data in enumerate((series, sent))]
        assert np.array_equal(*images)
