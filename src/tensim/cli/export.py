"""``tensim export-trajectory``: a gait's V* commands as the text table the robot's PC sends."""

from __future__ import annotations

import argparse
from pathlib import Path

from tensim.cli._common import load_model, output_option, positive


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("export-trajectory",
                       help="write a controller's V* commands as a text table for the hardware",
                       description="Samples the gait's target velocity V* at the robot's command "
                       "rate (one row per packet of all cables' commands) and writes it as a "
                       "text table; `tensim simulate MODEL --controller FILE --velocity-input "
                       "TABLE` plays it back.")
    p.add_argument("controller", help="controller file (.yaml/.json) or a shipped name")
    p.add_argument("--model", default="tetraspine3", help="preset or structure .yaml file")
    output_option(p, "--out", "file", required=True, help="output text file")
    p.add_argument("--period", type=positive, default=0.01,
                   help="time between command packets [s] (the robot's PC: 0.01)")
    p.add_argument("--duration", type=positive, default=None,
                   help="time covered [s] (default: the gait's duration)")
    p.add_argument("--hardware-scale", type=positive, default=1.0,
                   help="multiply the written V* by this (the paper's robot ran 10x the "
                        "simulator's amplitudes); reading the file divides it out")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from tensim.control import save_velocity_table
    from tensim.control.files import sampled_table
    from tensim.models import load_controller

    structure = load_model(args.model)
    config = load_controller(args.controller, structure)
    gait = config.gait
    if config.rest is not None:  # the V* table would silently drop them
        raise ValueError(f"{args.controller}: rest_lengths: a V* table carries no commanded "
                         "rest lengths; export a controller whose cables all have impedance "
                         "laws")
    if gait is None:
        raise ValueError(f"{args.controller}: has no gait, so there is no V* to export")
    if args.duration is not None:
        config = config.with_duration(args.duration)
    table = sampled_table(gait, config.duration, args.period)
    out = Path(args.out)
    save_velocity_table(table, out, hardware_scale=args.hardware_scale, comments=(
        f"model: {args.model}", f"controller: {args.controller}",
        f"cables: {len(table.cables)}, rows: {table.values.shape[0]}"))
    print(f"wrote {out}: {table.values.shape[0]} rows x {len(table.cables)} cables, one row "
          f"every {args.period} s, V* in m/s x {args.hardware_scale}")
    return 0
