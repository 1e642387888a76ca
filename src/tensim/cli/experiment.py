"""``tensim experiment NAME``: the paper's experiments, each writing a run folder."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tensim.cli._common import (
    Progress,
    add_controller_option,
    add_world_options,
    print_summary,
    world_from_args,
)


def _disturbance(args: argparse.Namespace, out: Path) -> dict[str, Any]:
    from tensim.experiments import run_disturbance, write_disturbance

    result, summary = run_disturbance(dt=args.dt, world=world_from_args(args),
                                      progress=Progress("disturbance", args.quiet))
    write_disturbance(out, result, summary)
    return summary


def _timestep(args: argparse.Namespace, out: Path) -> dict[str, Any]:
    from tensim.experiments.timestep import run_timestep_study, write_timestep_study

    summary = run_timestep_study(None if args.quiet else lambda m: print(m, file=sys.stderr))
    write_timestep_study(out, summary)
    for hz, value in summary["max_change_percent"].items():
        print(f"  {hz:>5} Hz: worst cable's max-tension change {value:.2f} % vs 1000 Hz")
    for tc, value in summary["contact_max_change_percent"].items():
        print(f"  contact time constant {tc} s: worst change {value:.2f} %")
    return summary


def _gait(name: str, default: str) -> Callable[[argparse.Namespace, Path], dict[str, Any]]:
    def run(args: argparse.Namespace, out: Path) -> dict[str, Any]:
        from tensim.experiments.gait import run_gait, write_gait

        result, summary, config = run_gait(
            name, args.controller or default, duration=args.duration,
            world=world_from_args(args), progress=Progress(name, args.quiet))
        write_gait(out, result, summary, config)
        print(f"moved {summary['planar_displacement_m']:.3f} m toward "
              f"{summary['direction']} ({summary['direction_deg']:.0f} deg from +x)")
        if "body_sideways_m" in summary:
            side = summary["body_sideways_m"]
            print(f"in the robot's own frame: {summary['body_forward_m']:.3f} m forward, "
                  f"{abs(side):.3f} m to its {'left' if side > 0 else 'right'}; heading "
                  f"turned {summary['heading_change_deg']:.0f} deg")
        return summary

    return run


def _drag(args: argparse.Namespace, out: Path) -> dict[str, Any]:
    from tensim.experiments.drag import run_drag, write_drag

    result, summary = run_drag(world=world_from_args(args), duration=args.duration,
                               progress=Progress("drag", args.quiet))
    write_drag(out, result, summary)
    print(f"steady drag force {summary['drag_force_N']:.3f} N "
          f"(mu m g = {summary['coulomb_force_N']:.3f} N); "
          f"effective friction {summary['effective_friction']:.4f}")
    return summary


# name -> (one-line help, runner(args, out) -> summary)
EXPERIMENTS: dict[str, tuple[str, Callable[[argparse.Namespace, Path], dict[str, Any]]]] = {
    "disturbance": ("steady push on the front segment, held by the others (paper Fig. 3)",
                    _disturbance),
    "timestep": ("disturbance test at 250/1000/4000 Hz and three contact time constants",
                 _timestep),
    "sine": ("hand-tuned style sine gait on V* (paper Fig. 4)",
             _gait("sine", "tetraspine3_sine")),
    "cpg": ("simulator-tuned CPG gait, sideways locomotion (paper Fig. 5)",
            _gait("cpg", "tetraspine3_cpg")),
    "drag": ("quasi-static drag at steady velocity: the friction force (paper IV-A)", _drag),
}


def register(sub: argparse._SubParsersAction) -> None:
    lines = "\n".join(f"  {name:<12} {text}" for name, (text, _) in EXPERIMENTS.items())
    p = sub.add_parser("experiment", help="run one of the paper's experiments",
                       description=f"experiments:\n{lines}",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("name", choices=list(EXPERIMENTS), metavar="NAME",
                   help=f"one of: {', '.join(EXPERIMENTS)}")
    add_world_options(p)
    add_controller_option(p)
    p.add_argument("--duration", type=float, default=None,
                   help="simulated time [s] (default: the experiment's own)")
    p.add_argument("--out", default=None, help="output folder (default runs/NAME)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    out = Path(args.out or f"runs/{args.name}")
    summary = EXPERIMENTS[args.name][1](args, out)
    if "duration_s" in summary:
        print_summary(summary, out)
    else:
        print(f"wrote {out}/")
    return 0
