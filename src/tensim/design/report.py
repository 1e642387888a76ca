"""Figures and tables of the design analyses: the edge that the command line calls.

Nothing in the library imports this module. Figures are drawn on
:class:`matplotlib.figure.Figure` objects (no pyplot, no backend choice) and written
atomically. matplotlib loads when a figure is made, not for the tables (a design command
without ``--out`` never draws).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tensim._files import atomic_path
from tensim.design._bodies import bodies
from tensim.design.motors import CableDuty, DriveMotor
from tensim.design.stiffness import Stiffness
from tensim.structure import Structure

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def save(fig: Figure, path: Path, dpi: int = 110) -> Path:
    """Writes ``fig`` as a PNG atomically."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    return path


def _moved(structure: Structure, twist: np.ndarray, amplitude: float) -> dict[str, np.ndarray]:
    """Node positions after the reduced twist ``twist`` scaled to ``amplitude`` (linearised)."""
    body_set = bodies(structure)
    full = body_set.basis @ twist
    moved = {}
    for node in structure.nodes:
        b = body_set.node_body[node.name]
        p = structure.position(node.name)
        moved[node.name] = p if b < 0 else p + amplitude * body_set.point_jacobian(b, p) @ full
    span = max(np.linalg.norm(moved[n] - structure.position(n)) for n in moved) or 1.0
    return {n: structure.position(n) + (moved[n] - structure.position(n)) / span * amplitude
            for n in moved}


def modes_figure(structure: Structure, result: Stiffness, count: int = 4) -> Figure:
    """The ``count`` softest non-rigid modes: the build pose (grey) and each mode (colour)."""
    live = [k for k in np.argsort(result.frequencies) if result.frequencies[k] > 1e-6]
    chosen = live[:count]
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3.2 * max(len(chosen), 1), 3.4))
    size = float(np.ptp([n.position for n in structure.nodes], axis=0).max())
    for i, k in enumerate(chosen):
        # the mode (red) drawn over the build pose (grey), in that order
        ax = fig.add_subplot(1, len(chosen), i + 1, projection="3d", computed_zorder=False)
        moved = _moved(structure, result.modes[:, k], 0.15 * size)
        for pose, colour, width in ((None, "0.7", 1.0), (moved, "tab:red", 1.6)):
            _draw(ax, structure, pose, colour, width)
        ax.set_title(f"mode {k + 1}: {result.frequencies[k]:.3g} Hz", fontsize=9)
        ax.set_axis_off()
    fig.suptitle(f"{structure.name}: softest modes (grey: build pose)", fontsize=10)
    return fig


def _draw(ax: object, structure: Structure, pose: dict[str, np.ndarray] | None, colour: str,
          width: float) -> None:
    """The rods and the cables at ``pose`` (None: the build pose), each kind one line
    collection (a line per member costs seconds on a robot of hundreds of cables), painted
    as lines are (projecting caps, round joins)."""
    from mpl_toolkits.mplot3d.art3d import Line3DCollection  # type: ignore[import-untyped]

    def at(name: str) -> np.ndarray:
        return pose[name] if pose is not None else structure.position(name)

    for members, lw in (([rod.nodes for rod in structure.rods], 2.5 * width),
                        ([cable.path for cable in structure.cables], 0.6 * width)):
        if not members:
            continue
        lines = [np.array([at(n) for n in names]) for names in members]
        had_data = ax.has_data()  # type: ignore[attr-defined]
        ax.add_collection3d(Line3DCollection(  # type: ignore[attr-defined]
            lines, colors=colour, linewidths=lw, capstyle="projecting", joinstyle="round"))
        points = np.concatenate(lines)
        ax.auto_scale_xyz(*points.T, had_data=had_data)  # type: ignore[attr-defined]


def sizing_figure(duties: Sequence[CableDuty], catalogue: Sequence[DriveMotor],
                  spool_radius: float, gear_ratio: float, safety: float) -> Figure:
    """Shaft operating points (speed, torque) of every cable with each motor's torque-speed
    line: a motor suffices where all points lie under its line."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot(1, 1, 1)
    for duty in duties:
        ax.plot(safety * np.abs(duty.speed) * gear_ratio / spool_radius,
                safety * np.maximum(duty.tension, 0.0) * spool_radius / gear_ratio, ".", ms=2,
                label=duty.cable if len(duties) <= 12 else None)
    for motor in catalogue:
        ax.plot([0.0, motor.no_load_speed], [motor.stall_torque, 0.0], "k--", lw=1)
        ax.annotate(motor.name, (0.5 * motor.no_load_speed, 0.5 * motor.stall_torque),
                    fontsize=8)
    ax.set_xlabel("shaft speed [rad/s]")
    ax.set_ylabel("shaft torque [N m]")
    ax.set_title(f"operating points x {safety:g} (spool {spool_radius:g} m, gear "
                 f"{gear_ratio:g})", fontsize=10)
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    if len(duties) <= 12:
        ax.legend(fontsize=6, markerscale=4, ncol=2)
    return fig


def table(rows: Sequence[Sequence[object]], header: Sequence[str]) -> str:
    """A plain-text table with right-aligned numbers."""
    cells = [[str(h) for h in header]] + [[_cell(v) for v in row] for row in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(header))]
    return "\n".join("  ".join(c.rjust(w) if i else c.ljust(w)
                               for i, (c, w) in enumerate(zip(r, widths, strict=True)))
                     for r in cells)


def _cell(value: object) -> str:
    if isinstance(value, float | np.floating):
        return f"{value + 0.0:.4g}"  # + 0.0: no "-0"
    return str(value)
