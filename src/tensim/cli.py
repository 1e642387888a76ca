"""The ``tensim`` command line: thin calls into the library."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from tensim import __version__

log = logging.getLogger("tensim")


class _Progress:
    """A one-line progress bar on stderr: simulated time, rate, time left."""

    def __init__(self, label: str, quiet: bool):
        import time

        self._clock = time.perf_counter
        self.label, self.quiet, self.start = label, quiet, self._clock()
        self.tty = sys.stderr.isatty()
        self._last_line = -1.0

    def __call__(self, done: float, total: float) -> None:
        if self.quiet:
            return
        elapsed = self._clock() - self.start
        rate = done / elapsed if elapsed > 0 else 0.0
        left = (total - done) / rate if rate > 0 else 0.0
        width = 30
        filled = int(width * done / total) if total > 0 else width
        if not self.tty:  # a log file: a line every tenth of the run
            if done < total and done - self._last_line < total / 10:
                return
            self._last_line = done
        print(f"\r{self.label} [{'#' * filled}{'.' * (width - filled)}] {done:5.1f}/{total:.1f} s "
              f"sim, {rate:5.1f}x real time, {left:4.1f} s left", end="", file=sys.stderr,
              flush=True)
        if done >= total or not self.tty:
            print(file=sys.stderr)


def _cmd_models(args: argparse.Namespace) -> int:
    from tensim.models import PRESETS

    for preset in PRESETS.values():
        print(f"{preset.name:<12} {preset.summary}")
    return 0


def _structure_and_controller(name: str) -> tuple[object, object]:
    from tensim.models import PRESETS, preset
    from tensim.structure import load_structure

    if name in PRESETS:
        chosen = preset(name)
        return chosen.build(), chosen.controller()
    path = Path(name)
    if path.suffix in (".yaml", ".yml") and path.exists():
        return load_structure(path), None
    raise SystemExit(f"tensim: unknown model {name!r}: not a preset ({', '.join(PRESETS)}) "
                     "nor an existing .yaml structure file")


def _cmd_simulate(args: argparse.Namespace) -> int:
    from tensim.model import WorldOptions, compile_structure
    from tensim.runs import write_run
    from tensim.sim import simulate
    from tensim.viz import plot_cable_tensions, plot_path

    structure, controller = _structure_and_controller(args.model)
    compiled = compile_structure(structure, WorldOptions(timestep=args.dt))  # type: ignore[arg-type]
    result = simulate(compiled, args.duration, controller=controller,  # type: ignore[arg-type]
                      record_dt=args.record_dt, progress=_Progress(args.model, args.quiet))
    summary = {"model": args.model, **result.summary()}
    out = Path(args.out)
    if compiled.n_cables:
        plot_cable_tensions(result.trajectory, out / "tensions.png",
                            title=f"{args.model}: cable tensions")
    plot_path(result.trajectory, out / "path.png", compiled.index.bodies)
    write_run(out, result, {**summary, "figures": ["tensions.png", "path.png"]})
    _report(summary, out)
    return 0


def _cmd_experiment(args: argparse.Namespace) -> int:
    from tensim.experiments import run_disturbance, write_disturbance

    out = Path(args.out)
    if args.name == "timestep":
        return _timestep(out, args.quiet)
    if args.name != "disturbance":
        raise SystemExit(f"tensim: unknown experiment {args.name!r}; experiments: "
                         "disturbance, timestep")
    result, summary = run_disturbance(dt=args.dt, progress=_Progress("disturbance", args.quiet))
    write_disturbance(out, result, summary)
    _report(summary, out)
    return 0


def _timestep(out: Path, quiet: bool) -> int:
    from tensim.experiments.timestep import run_timestep_study, write_timestep_study

    summary = run_timestep_study(None if quiet else lambda m: print(m, file=sys.stderr))
    write_timestep_study(out, summary)
    print(f"wrote {out}/ (summary.json, timestep.png)")
    for hz, value in summary["max_change_percent"].items():
        print(f"  {hz:>5} Hz: worst cable's max-tension change {value:.2f} % vs 1000 Hz")
    for tc, value in summary["contact_max_change_percent"].items():
        print(f"  contact time constant {tc} s: worst change {value:.2f} %")
    return 0


def _report(summary: dict[str, object], out: Path) -> None:
    tensions = summary.get("max_tension_N", {})
    assert isinstance(tensions, dict)
    print(f"wrote {out}/ (summary.json, trajectory.parquet, figures)")
    print(f"simulated {summary['duration_s']} s in {summary['wall_s']} s "
          f"({summary['real_time_factor']}x real time)")
    if tensions:
        print(f"max system tension {summary['max_system_tension_N']} N; per cable [N]:")
        for name, value in tensions.items():
            print(f"  {name:<16} {value:8.3f}")


def _cmd_bench(args: argparse.Namespace) -> int:
    from tensim._files import write_json
    from tensim.bench import run_benchmarks

    report = run_benchmarks(args.duration, args.repeats)
    print(f"{'case':<20} {'tensim x real time':>19} {'MuJoCo alone':>13} {'ratio':>7} "
          f"{'us/step':>8} {'engine us/step':>15}")
    for case in report["cases"]:  # type: ignore[attr-defined]
        print(f"{case['name']:<20} {case['real_time_factor']:>19.1f} "
              f"{case['engine_alone_real_time_factor']:>13.1f} {case['ratio_to_engine']:>7.2f} "
              f"{case['us_per_step']:>8.1f} {case['engine_us_per_step']:>15.1f}")
    if args.json:
        write_json(Path(args.json), report)
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand."""
    parser = argparse.ArgumentParser(prog="tensim", description=__doc__)
    parser.add_argument("--version", action="version", version=f"tensim {__version__}")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("models", help="list the model presets")
    p.set_defaults(run=_cmd_models)

    p = sub.add_parser("simulate", help="simulate a preset or structure file")
    p.add_argument("model", help="preset name or structure .yaml file")
    p.add_argument("--duration", type=float, default=10.0, help="simulated time [s]")
    p.add_argument("--dt", type=float, default=1e-3, help="physics step [s]")
    p.add_argument("--record-dt", type=float, default=0.01, help="recording period [s]")
    p.add_argument("--out", default="runs/simulate", help="output folder")
    p.set_defaults(run=_cmd_simulate)

    p = sub.add_parser("experiment", help="run one of the paper's experiments")
    p.add_argument("name", help="experiment: disturbance, timestep")
    p.add_argument("--dt", type=float, default=1e-3, help="physics step [s]")
    p.add_argument("--out", default=None, help="output folder (default runs/NAME)")
    p.set_defaults(run=_cmd_experiment)

    p = sub.add_parser("bench", help="speed benchmark against MuJoCo alone")
    p.add_argument("--json", default=None, help="also write the figures to this JSON file")
    p.add_argument("--duration", type=float, default=10.0, help="simulated time per case [s]")
    p.add_argument("--repeats", type=int, default=3, help="best of this many runs")
    p.set_defaults(run=_cmd_bench)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``tensim`` console script."""
    from tensim.model import ModelError
    from tensim.sim import SimulationError
    from tensim.structure import StructureError

    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    args = build_parser().parse_args(argv)
    if getattr(args, "out", "x") is None:
        args.out = f"runs/{args.name}"
    run: Callable[[argparse.Namespace], int] = args.run
    try:
        return run(args)
    except (StructureError, ModelError, SimulationError, KeyError, ValueError) as err:
        message = err.args[0] if isinstance(err, KeyError) and err.args else err
        print(f"tensim: error: {message}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

