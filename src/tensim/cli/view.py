"""``tensim view``: the robot moving in real time in MuJoCo's viewer, cables coloured by tension."""

from __future__ import annotations

import argparse
import sys

from tensim.cli._common import (
    add_controller_option,
    add_world_options,
    load_model,
    positive,
    world_from_args,
)


def register(sub: argparse._SubParsersAction) -> None:
    from tensim.viz.pacing import KEY_HELP

    p = sub.add_parser(
        "view", help="watch a simulation in real time in a window",
        description="Simulates MODEL under its controller at the fixed physics step, drawn at "
        "60 Hz in step with the wall clock, in MuJoCo's viewer. Cables are coloured by tension "
        "(blue just taut, red at twice the starting tension); slack ones are grey, dashed and "
        f"sagging. Keys: {KEY_HELP}. Needs a screen: elsewhere use `tensim render`.")
    p.add_argument("model", help="preset name or structure .yaml file")
    p.add_argument("--max-tension", type=positive, default=None, metavar="N",
                   help="tension drawn red [N] (default: twice the highest tension at the "
                        "start, rounded up to 1, 2 or 5 x 10^k N)")
    add_world_options(p)
    add_controller_option(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from tensim.model import compile_structure
    from tensim.models import resolve_controller
    from tensim.viz.cables import TensionColors
    from tensim.viz.pacing import KEY_HELP
    from tensim.viz.viewer import DisplayUnavailable, check_display, view

    try:
        check_display()
    except DisplayUnavailable as err:
        print(f"tensim: error: {err}", file=sys.stderr)
        return 1
    structure = load_model(args.model)
    config = resolve_controller(args.model, structure, args.controller)
    compiled = compile_structure(structure, world_from_args(args))
    controller = config.build(compiled.model.opt.timestep) if config else None
    print(f"viewing {args.model}; {KEY_HELP}; close the window to quit")
    colors = TensionColors(args.max_tension) if args.max_tension is not None else None
    view(compiled, controller=controller, colors=colors)
    return 0
