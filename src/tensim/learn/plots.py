"""The learning curve: every evaluation's score and the best so far, by evaluation index."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from tensim.learn.problem import OK, Evaluation
from tensim.viz.plots import new_figure, save_figure

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def best_so_far(evaluations: Sequence[Evaluation]) -> np.ndarray:
    """(n,) the best score among successful evaluations up to each index (NaN before any)."""
    scores = np.array([e.score if e.status == OK else -np.inf for e in evaluations])
    best = np.maximum.accumulate(scores) if scores.size else scores
    return np.where(np.isfinite(best), best, np.nan)


def plot_learning_curve(evaluations: Sequence[Evaluation], path: Path, *, title: str = "",
                        unit: str = "m") -> Path:
    """Scores of successful trials (dots), failed ones (crosses at the bottom edge) and the
    best so far (line), against the evaluation index; written atomically as PNG.

    Args:
        evaluations: in index order.
        path: the PNG file.
        title: figure title.
        unit: unit of the score, for the axis label.
    """
    index = np.array([e.index for e in evaluations])
    ok = np.array([e.status == OK for e in evaluations], dtype=bool)
    scores = np.array([e.score for e in evaluations])
    fig = new_figure((7.5, 4.2))
    ax = fig.subplots()
    ax.plot(index[ok], scores[ok], ".", color="tab:blue", ms=4, alpha=0.6, label="evaluation")
    ax.step(index, best_so_far(evaluations), where="post", color="black", lw=1.5,
            label="best so far")
    if (~ok).any():
        low = scores[ok].min() if ok.any() else scores.min()
        high = scores[ok].max() if ok.any() else scores.max()
        bottom = low - 0.05 * max(high - low, 1e-9)
        ax.plot(index[~ok], np.full((~ok).sum(), bottom), "x", color="tab:red", ms=4,
                label=f"failed ({(~ok).sum()}; score {scores[~ok][0]:g})")
    return _finish(fig, ax, path, "evaluation", f"score [{unit}]", title)


def plot_best_so_far(runs: dict[str, Sequence[Evaluation]], path: Path, *, title: str = "",
                     unit: str = "m", styles: dict[str, dict[str, Any]] | None = None) -> Path:
    """Best score so far against the evaluation index for several runs (one line each), to
    compare optimizers; written atomically as PNG.

    Args:
        runs: label -> evaluations in index order.
        path: the PNG file.
        title: figure title.
        unit: unit of the score, for the axis label.
        styles: label -> matplotlib line options (e.g. one colour per optimizer).
    """
    fig = new_figure((7.5, 4.2))
    ax = fig.subplots()
    for label, evaluations in runs.items():
        index = np.array([e.index for e in evaluations])
        ax.step(index + 1, best_so_far(evaluations), where="post", label=label,
                **{"lw": 1.5, **(styles or {}).get(label, {})})
    return _finish(fig, ax, path, "evaluations", f"best score so far [{unit}]", title)


def _finish(fig: Figure, ax: Axes, path: Path, xlabel: str, ylabel: str, title: str) -> Path:
    """Labels, grid, legend and title shared by the learning plots; writes the PNG."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    if title:
        ax.set_title(title, fontsize=9)
    # fixed margins [fraction of 7.5 x 4.2 in] instead of a layout pass (a tenth of a second)
    lines = title.count("\n") + 1 if title else 0
    fig.subplots_adjust(left=0.11, right=0.97, bottom=0.12, top=0.96 - 0.045 * lines)
    return save_figure(fig, Path(path))
