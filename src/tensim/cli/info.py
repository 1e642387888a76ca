"""``tensim info``: a model's nodes, rods, rigid bodies, cables, motors, tags and gains."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from tensim.cli._common import add_controller_option, load_model, motor_sources, output_option


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("info", help="list a model's nodes, rods, bodies, cables and motors")
    p.add_argument("model", help="preset name or structure .yaml file")
    add_controller_option(p)
    output_option(p, "--json", "file", default=None, metavar="FILE",
                   help="also write the listing as JSON to FILE")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from tensim._files import write_text
    from tensim.inspect import format_info, structure_info
    from tensim.models import resolve_controller

    structure = load_model(args.model)
    config = resolve_controller(args.model, structure, args.controller)
    label = None if config is None else (args.controller
                                         or f"the {args.model} preset's impedance laws")
    info = structure_info(structure, None if config is None else config.impedance.gains,
                          motor_sources(args.model), label)
    print(format_info(info))
    if args.json:
        write_text(Path(args.json), json.dumps(info, indent=1) + "\n")
        print(f"\nwrote {args.json}")
    return 0
