"""The design figures against a plain reference drawing."""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg

from tensim.design import report
from tensim.design.stiffness import stiffness
from tensim.models import preset


def _pixels(fig) -> np.ndarray:
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba()).copy()


def _per_line(ax, structure, pose, colour, width) -> None:
    """The reference: one plotted line per rod and per cable, as plain as it gets."""
    def at(name):
        return pose[name] if pose is not None else structure.position(name)

    for rod in structure.rods:
        ax.plot(*np.array([at(n) for n in rod.nodes]).T, color=colour, lw=2.5 * width)
    for cable in structure.cables:
        ax.plot(*np.array([at(n) for n in cable.path]).T, color=colour, lw=0.6 * width)


def test_the_modes_figure_draws_each_kind_of_member_as_one_collection_pixel_for_pixel(
        monkeypatch) -> None:
    """A line collection per kind of member (rods, cables) and pose paints what a line per
    member paints: the same pixels, on a prism and on Tetraspine3 (wider than tall: the
    limits come from every point)."""
    for name in ("prism3", "tetraspine3"):
        structure = preset(name).build()
        result = stiffness(structure, count=False)
        fast = _pixels(report.modes_figure(structure, result, count=2))
        with monkeypatch.context() as patch:
            patch.setattr(report, "_draw", _per_line)
            slow = _pixels(report.modes_figure(structure, result, count=2))
        assert np.array_equal(fast, slow)
