"""Shared pieces of the command line: progress bars, model lookup, printed summaries."""

from __future__ import annotations

import argparse
import logging
import math
import os
import statistics
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the CLI imports the library only when a command runs
    from tensim.model import WorldOptions
    from tensim.structure import Structure


class Progress:
    """A one-line progress bar on stderr: work done, rate and time left; and the run log.

    On a terminal the line is redrawn in place (at most ten times a second); elsewhere one line
    is written every tenth of the work. ``quiet`` turns the bar off. Either way a plain line
    goes to the run log (``tensim.runs.RUN_LOG``, written into the run folder as tensim.log)
    every tenth of the work and at the end.
    """

    def __init__(self, label: str, quiet: bool = False, unit: str = "s sim",
                 rate_label: str = "x real time"):
        from tensim.runs import PROGRESS_LOGGER

        self._clock = time.perf_counter
        self.label, self.quiet, self.start = label, quiet, self._clock()
        self.unit, self.rate_label = unit, rate_label
        self.tty = sys.stderr.isatty()
        self._last_line = -1.0  # work done at the last non-terminal line
        self._last_logged = 0.0  # work done at the last run-log line
        self._last_draw = -math.inf  # clock time of the last terminal redraw
        self._log = logging.getLogger(PROGRESS_LOGGER)
        self.extra = ""

    def __call__(self, done: float, total: float) -> None:
        now = self._clock()
        finished = done >= total
        line = self.line(done, total, now - self.start)
        if finished or done - self._last_logged >= total / 10:
            self._last_logged = done
            self._log.info(line)
        if self.quiet:
            return
        if self.tty:
            if not finished and now - self._last_draw < 0.1:
                return
            self._last_draw = now
            print(f"\r{line}", end="\n" if finished else "", file=sys.stderr, flush=True)
        elif finished or done - self._last_line >= total / 10:
            self._last_line = done
            print(line, file=sys.stderr, flush=True)

    def note(self, text: str) -> None:
        """Shows ``text`` after the bar (e.g. which of several runs is under way)."""
        self.extra = text

    def line(self, done: float, total: float, elapsed: float) -> str:
        """The bar's text after ``elapsed`` seconds [s] with ``done`` of ``total`` done."""
        rate = done / elapsed if elapsed > 0 else 0.0
        width = 30
        filled = min(width, int(width * done / total)) if total > 0 else width
        if done >= total:
            timing = f"done in {_duration(elapsed)}"
        else:
            timing = f"{_duration((total - done) / rate)} left" if rate > 0 else "? left"
        extra = f", {self.extra}" if self.extra else ""
        return (f"{self.label} [{'#' * filled}{'.' * (width - filled)}] {done:5.1f}/{total:.1f} "
                f"{self.unit}, {_rate(rate)}{self.rate_label}, {timing}{extra}")


def _rate(rate: float) -> str:
    """A rate with three significant digits, without exponents."""
    return f"{rate:5.0f}" if rate >= 100 else f"{rate:5.3g}"


def _duration(seconds: float) -> str:
    """``seconds`` as '4.2 s', '3 min 12 s' or '2 h 05 min'."""
    if seconds < 60:
        return f"{seconds:.1f} s"
    minutes, secs = divmod(round(seconds), 60)
    if minutes < 60:
        return f"{minutes} min {secs:02d} s"
    return f"{minutes // 60} h {minutes % 60:02d} min"


def load_model(name: str) -> Structure:
    """A preset's structure, or a structure YAML file (:func:`tensim.models.load_model`)."""
    from tensim.models import load_model as load

    return load(name)


def motor_sources(name: str) -> dict[str, str]:
    """Where each cable of a preset or structure file got its motor (see
    :data:`tensim.inspect.MOTOR_SOURCES`)."""
    from tensim._input import load_yaml_file
    from tensim.models import PRESETS
    from tensim.structure import motor_sources as file_sources

    if name in PRESETS:
        return {c.name: "preset" for c in PRESETS[name].build().cables}
    return file_sources(load_yaml_file(Path(name)))


def motor_summary(structure: Structure) -> dict[str, str]:
    """Each cable's motor in a line, for run summaries: ``"kinematic 0.07 m/s, 50 N"``,
    ``"dc, 50 N"`` or ``"none (passive)"``."""
    out = {}
    for cable in structure.cables:
        m = cable.motor
        out[cable.name] = ("none (passive)" if m.passive else
                           f"{'dc' if m.dc else f'kinematic {m.max_speed:g} m/s'}, "
                           f"{m.max_tension:g} N")
    return out


def gains_summary(structure: Structure, config: Any) -> dict[str, Any]:
    """Each cable's impedance gains in a run (T0 [N], K [N/m], B [N s/m], L* [m]), or None
    for a cable without a law, for run summaries."""
    gains = {} if config is None else config.impedance.gains
    return {c.name: None if c.name not in gains else {
                "offset_tension_N": gains[c.name].offset_tension,
                "stiffness_gain_N_per_m": gains[c.name].stiffness_gain,
                "damping_gain_N_s_per_m": gains[c.name].damping_gain,
                "target_length_m": gains[c.name].target_length}
            for c in structure.cables}


def print_summary(summary: dict[str, Any], out: Path, moved: bool = False,
                  figures: bool = True) -> None:
    """Prints where a run went (with its ``figures`` or without), its speed, (with ``moved``)
    how far its centre of mass moved, and its tensions."""
    tensions = summary.get("max_tension_N", {})
    drawn = "figures" if figures else "no figures"
    print(f"wrote {out}/ (summary.json, trajectory.parquet, {drawn})")
    print(f"simulated {summary['duration_s']} s in {summary['wall_s']} s "
          f"({summary['real_time_factor']}x real time)")
    if moved and "com_displacement_m" in summary:
        dx, dy, dz = summary["com_displacement_m"]
        print(f"centre of mass moved {math.hypot(dx, dy):.4f} m over the ground "
              f"(x {dx:+.4f} m, y {dy:+.4f} m; z {dz:+.4f} m)")
    if not (isinstance(tensions, dict) and tensions):
        return
    speeds, powers = summary.get("max_line_speed_m_s"), summary.get("max_power_W")
    if len(tensions) <= LISTED_CABLES:
        if isinstance(speeds, dict) and isinstance(powers, dict):
            # the peaks the law tracked at every step, as `design size` reads them
            print(f"max system tension {summary['max_system_tension_N']} N; per cable, peak "
                  "tension [N], motor line speed [m/s] and power [W]:")
            for name, value in tensions.items():
                print(f"  {name:<16} {value:8.3f} {speeds.get(name, 0.0):8.4f} "
                      f"{powers.get(name, 0.0):9.3f}")
            return
        print(f"max system tension {summary['max_system_tension_N']} N; per cable [N]:")
        for name, value in tensions.items():
            print(f"  {name:<16} {value:8.3f}")
        return
    # hundreds of cables: the most loaded few, the rest in summary.json
    values = [float(v) for v in tensions.values()]
    print(f"max system tension {summary['max_system_tension_N']} N; {len(tensions)} cables, "
          f"max tension median {statistics.median(values):.3f} N, least {min(values):.3f} N; the "
          f"{TOP_CABLES} most loaded [N] (every cable's in summary.json):")
    for name, value in sorted(tensions.items(), key=lambda kv: -kv[1])[:TOP_CABLES]:
        print(f"  {name:<16} {value:8.3f}")


LISTED_CABLES = 30  # robots with more cables get a summary of their tensions, not a list
TOP_CABLES = 5


def add_figures_option(parser: argparse.ArgumentParser, which: str = "") -> None:
    """Adds ``--no-figures``: a run folder without PNG figures (data, summary and report
    only), for robots too big or runs too many for their figures to pay."""
    parser.add_argument("--no-figures", action="store_true",
                        help=f"{which}write no figures and no rendered frame (the trajectory, "
                             "summary and report are written as ever)")


def add_world_options(parser: argparse.ArgumentParser, dt: float = 1e-3) -> None:
    """Adds the options that describe the simulated world (physics step, ...)."""
    parser.add_argument("--dt", type=positive, default=dt, help="physics step [s]")
    add_terrain_option(parser, "flat, or the experiment's own")
    parser.add_argument("--no-self-collision", action="store_true",
                        help="the robot's bodies collide only with the ground, not with each "
                             "other: faster, but wrong wherever its parts touch (see "
                             "docs/speed.md)")
    parser.add_argument("--cable-law", choices=("explicit", "implicit", "implicitfast"),
                        default="explicit",
                        help="explicit (default: the paper's law under MuJoCo's Euler step), "
                             "implicit (MuJoCo's discrete integrator takes each taut cable's "
                             "stiffness and damping: stiff, damped cables at 1-10 ms) or "
                             "implicitfast (cheaper, damping only; see docs/speed.md)")
    parser.add_argument("--split-margin", type=split_margin, default=0.0, metavar="MARGIN",
                        help="with --cable-law implicit: keep on the explicit law the cables "
                             "whose explicit step bound, together, is at least MARGIN steps "
                             "(e.g. 4; 0, the default: hand every cable to the integrator; see "
                             "docs/speed.md)")
    parser.add_argument("--contact", default=None, metavar="KEY=VALUE,...",
                        help="robot-ground friction model: cone=pyramidal|elliptic, "
                             "noslip=ITERATIONS, condim=3|4|6, torsional=COEFF [m], "
                             "rolling=COEFF [m] (see docs/speed.md)")
    parser.add_argument("--inertia-floor", type=_fraction, default=None, metavar="RATIO",
                        help="raise a rigid body's smallest principal inertia to RATIO of its "
                             "largest (default 0.01: MuJoCo spins thin rods up); 0 turns the "
                             "floor off")


def add_terrain_option(parser: argparse.ArgumentParser | argparse._ArgumentGroup,
                       default: str = "flat") -> None:
    """Adds ``--terrain NAME[:key=value,...]`` (parsed by :func:`world_from_args`)."""
    parser.add_argument("--terrain", default=None, metavar="NAME[:key=value,...]",
                        help="ground: flat, slope, hills, rough, stairs, blocks, wall or "
                             "heightfield, e.g. 'rough:roughness=0.02,seed=3' or "
                             f"'wall:height=0.1,friction=0.5' (default {default}; see "
                             "docs/terrain.md)")


def world_from_args(args: argparse.Namespace) -> WorldOptions:
    """The WorldOptions that :func:`add_world_options`' options describe.

    Raises:
        TerrainError: ``--terrain`` is not a valid terrain string.
    """
    from tensim.model import WorldOptions
    from tensim.terrain import Flat, parse_terrain

    text = getattr(args, "terrain", None)
    if getattr(args, "split_margin", None) and getattr(args, "cable_law", None) != "implicit":
        raise ValueError("--split-margin splits the implicit law's cables: give it with "
                         "--cable-law implicit")
    return WorldOptions(timestep=args.dt,
                        terrain=parse_terrain(text) if text is not None else Flat(),
                        self_collision=not getattr(args, "no_self_collision", False),
                        cable_law=getattr(args, "cable_law", None) or "explicit",
                        split_margin=getattr(args, "split_margin", None) or 0.0,
                        **contact_options(getattr(args, "contact", None)),
                        **({} if getattr(args, "inertia_floor", None) is None else
                           {"min_inertia_ratio": args.inertia_floor}))


def split_margin(text: str) -> float:
    """0 or a finite number >= 1 (argparse type of ``--split-margin``)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and (value == 0 or value >= 1)):
        raise argparse.ArgumentTypeError(f"expected 0 or a number >= 1, got {text[:50]!r}")
    return value


def _fraction(text: str) -> float:
    """A number in [0, 1) (argparse type)."""
    value = float(text)
    if not 0 <= value < 1:
        raise argparse.ArgumentTypeError(f"expected a number in [0, 1), got {text}")
    return value


_CONTACT = {"cone": ("cone", str), "noslip": ("noslip_iterations", int),
            "condim": ("condim", int), "torsional": ("torsional_friction", float),
            "rolling": ("rolling_friction", float)}


def contact_options(text: str | None) -> dict[str, Any]:
    """``--contact``'s ``cone=elliptic,condim=4,...`` as WorldOptions fields.

    Raises:
        ValueError: an unknown key or a value of the wrong kind (WorldOptions checks ranges).
    """
    out: dict[str, Any] = {}
    for entry in (e.strip() for e in (text or "").split(",") if e.strip()):
        key, _, value = (part.strip() for part in entry.partition("="))
        if key not in _CONTACT:
            raise ValueError(f"--contact: unknown key {key!r}; expected {', '.join(_CONTACT)}")
        field, kind = _CONTACT[key]
        shown = value if len(value) <= 24 else f"{value[:12]}...({len(value)} characters)"
        try:
            if len(value) > 24:  # a number, not a page of digits
                raise ValueError
            out[field] = kind(value)
        except ValueError:
            raise ValueError(f"--contact: {key} expects {kind.__name__}, got {shown!r}") from None
    condim = out.get("condim", 3)
    for key, field, least in (("torsional", "torsional_friction", 4),
                              ("rolling", "rolling_friction", 6)):
        if field in out and isinstance(condim, int) and condim < least:
            raise ValueError(f"--contact: {key}= acts at condim {least}"
                             f"{' or 6' if least == 4 else ''} only, and condim is {condim}: "
                             f"it would change nothing; add condim={least}")
    return out


def parse_point(text: str, what: str) -> tuple[float, float]:
    """``"X,Y"`` as a point (x, y) [m].

    Raises:
        ValueError: not two finite numbers, naming the option ``what``.
    """
    parts = text.split(",")
    try:
        x, y = (float(p) for p in parts)
    except ValueError:
        raise ValueError(f"{what} {text!r}: expected two numbers X,Y in metres, e.g. "
                         "1.5,0") from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"{what} {text!r}: expected finite coordinates")
    return x, y


def add_controller_option(parser: argparse.ArgumentParser, default: str | None = None) -> None:
    """Adds ``--controller FILE|NAME`` (a controller file, or a shipped one by name)."""
    shipped = "; shipped: see `tensim models`"
    parser.add_argument("--controller", default=default,
                        help="controller file (.yaml/.json) or a shipped controller's name"
                        + (f" (default {default})" if default else " (default: the model's "
                           "own impedance controller)") + shipped)


# -- numbers on the command line: argparse types that name what they expect ----------------------


def _float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def finite(text: str) -> float:
    """A finite number."""
    return _float(text)


def positive(text: str) -> float:
    """A finite number > 0."""
    value = _float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}")
    return value


def nonnegative(text: str) -> float:
    """A finite number >= 0."""
    value = _float(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}")
    return value


def _int(text: str, minimum: int) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < minimum:
        raise argparse.ArgumentTypeError(f"expected a whole number >= {minimum}, got {text!r}")
    return value


def count(text: str) -> int:
    """A whole number >= 1."""
    return _int(text, 1)


def natural(text: str) -> int:
    """A whole number >= 0."""
    return _int(text, 0)


def output_option(parser: Any, flag: str, kind: str, **kwargs: Any) -> None:
    """Adds ``flag``, the path of a ``kind`` ("file" or "folder") the command writes.

    :func:`check_outputs` checks every such option before the command runs.
    """
    action = parser.add_argument(flag, **kwargs)
    parser.set_defaults(outputs=(*(parser.get_default("outputs") or ()),
                                 (action.dest, flag, kind)))


def _input_paths(args: argparse.Namespace, skip: set[str]) -> list[str]:
    """Every argument value that names an existing file or folder (the command's inputs)."""
    found = []
    for key, value in vars(args).items():
        if key in skip or key == "outputs":
            continue
        for item in value if isinstance(value, (list, tuple)) else [value]:
            if isinstance(item, str) and item and os.path.exists(item):
                found.append(item)
    return found


def check_outputs(args: argparse.Namespace) -> None:
    """Refuses output paths a command may not write, before it runs: a device, FIFO, socket,
    a folder for a file (or a file for a folder), and the command's own input (a file it reads,
    or a folder that holds one: replacing the folder would delete it).

    Raises:
        InputError: naming the option, its path and the reason.
    """
    from tensim._files import check_writable
    from tensim._input import InputError

    outputs: list[tuple[str, str, str, str]] = [
        (dest, flag, kind, value) for dest, flag, kind in getattr(args, "outputs", ())
        if isinstance(value := getattr(args, dest, None), str) and value]
    for _, flag, kind, value in outputs:
        check_writable(Path(value), kind, flag)
    inputs = _input_paths(args, {dest for dest, _, _, _ in outputs})
    for _, flag, kind, value in outputs:
        if not os.path.exists(value):
            continue
        out = os.path.realpath(value)
        for item in inputs:
            real = os.path.realpath(item)
            if real == out or (kind == "folder" and real.startswith(out + os.sep)):
                what = "is" if real == out else "holds"
                raise InputError(f"{flag} {value}: {what} the input {item} of this command; "
                                 f"writing {flag} would replace what the command reads; choose "
                                 f"another {flag}")


def output_option_of(args: argparse.Namespace, filename: str) -> str | None:
    """The output option whose path is ``filename`` or holds it, as ``"--out PATH"``."""
    target = os.path.realpath(filename)
    for dest, flag, _ in getattr(args, "outputs", ()):
        value = getattr(args, dest, None)
        if isinstance(value, str) and value:
            real = os.path.realpath(value)
            if target == real or target.startswith(real + os.sep):
                return f"{flag} {value}"
    return None
