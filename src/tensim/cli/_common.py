"""Shared pieces of the command line: progress bars, model lookup, printed summaries."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from tensim.model import WorldOptions
from tensim.structure import Structure


class Progress:
    """A one-line progress bar on stderr: work done, rate and time left.

    On a terminal the line is redrawn in place; in a log file one line is written every tenth
    of the work. ``quiet`` turns it off.
    """

    def __init__(self, label: str, quiet: bool = False, unit: str = "s sim",
                 rate_label: str = "x real time"):
        self._clock = time.perf_counter
        self.label, self.quiet, self.start = label, quiet, self._clock()
        self.unit, self.rate_label = unit, rate_label
        self.tty = sys.stderr.isatty()
        self._last_line = -1.0
        self.extra = ""

    def __call__(self, done: float, total: float) -> None:
        if self.quiet:
            return
        elapsed = self._clock() - self.start
        rate = done / elapsed if elapsed > 0 else 0.0
        left = (total - done) / rate if rate > 0 else 0.0
        width = 30
        filled = min(width, int(width * done / total)) if total > 0 else width
        if not self.tty:  # a log file: a line every tenth of the work
            if done < total and done - self._last_line < total / 10:
                return
            self._last_line = done
        extra = f", {self.extra}" if self.extra else ""
        print(f"\r{self.label} [{'#' * filled}{'.' * (width - filled)}] {done:5.1f}/{total:.1f} "
              f"{self.unit}, {rate:5.1f}{self.rate_label}, {left:4.1f} s left{extra}", end="",
              file=sys.stderr, flush=True)
        if done >= total or not self.tty:
            print(file=sys.stderr)


def load_model(name: str) -> Structure:
    """A preset's structure, or a structure YAML file.

    Raises:
        SystemExit: neither a preset nor an existing .yaml file.
    """
    from tensim.models import PRESETS, preset
    from tensim.structure import load_structure

    if name in PRESETS:
        return preset(name).build()
    path = Path(name)
    if path.suffix in (".yaml", ".yml") and path.exists():
        return load_structure(path)
    raise SystemExit(f"tensim: unknown model {name!r}: not a preset ({', '.join(PRESETS)}) "
                     "nor an existing .yaml structure file")


def print_summary(summary: dict[str, Any], out: Path) -> None:
    """Prints where a run went, its speed and its tensions."""
    tensions = summary.get("max_tension_N", {})
    print(f"wrote {out}/ (summary.json, trajectory.parquet, figures)")
    print(f"simulated {summary['duration_s']} s in {summary['wall_s']} s "
          f"({summary['real_time_factor']}x real time)")
    if isinstance(tensions, dict) and tensions:
        print(f"max system tension {summary['max_system_tension_N']} N; per cable [N]:")
        for name, value in tensions.items():
            print(f"  {name:<16} {value:8.3f}")


def add_world_options(parser: argparse.ArgumentParser, dt: float = 1e-3) -> None:
    """Adds the options that describe the simulated world (physics step, ...)."""
    parser.add_argument("--dt", type=float, default=dt, help="physics step [s]")


def world_from_args(args: argparse.Namespace) -> WorldOptions:
    """The WorldOptions that :func:`add_world_options`' options describe."""
    return WorldOptions(timestep=args.dt)


def add_controller_option(parser: argparse.ArgumentParser, default: str | None = None) -> None:
    """Adds ``--controller FILE|NAME`` (a controller file, or a shipped one by name)."""
    shipped = "; shipped: see `tensim models`"
    parser.add_argument("--controller", default=default,
                        help="controller file (.yaml/.json) or a shipped controller's name"
                        + (f" (default {default})" if default else " (default: the model's "
                           "own impedance controller)") + shipped)
