"""``tensim controller init``: an impedance controller file that holds a robot's build pose."""

from __future__ import annotations

import argparse
from pathlib import Path

from tensim.cli._common import load_model, nonnegative, output_option, positive


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("controller", help="make controller files")
    actions = p.add_subparsers(dest="action", required=True)
    init = actions.add_parser(
        "init", help="write impedance laws for every motorised cable that hold the build pose "
        "(T0 = build pretension, L* = build length, K = cable stiffness, B = 0.2 s x K)")
    init.add_argument("model", help="preset name or structure .yaml file")
    output_option(init, "--out", "file", required=True,
                  help="controller file to write (.yaml or .json)")
    init.add_argument("--stiffness-gain", type=nonnegative, default=None,
                      help="K for every cable [N/m] (default: each cable's stiffness)")
    init.add_argument("--damping-time", type=positive, default=None,
                      help="B / K [s] (default 0.2)")
    init.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from tensim._files import check_writable
    from tensim.control import ControllerConfig, default_impedance, save_controller
    from tensim.control.impedance import DEFAULT_DAMPING_TIME
    from tensim.models import PRESETS

    out = Path(args.out)
    check_writable(out, "file")
    structure = load_model(args.model)
    damping = args.damping_time or DEFAULT_DAMPING_TIME
    impedance = default_impedance(structure, args.stiffness_gain, damping)
    passive = [c.name for c in structure.cables if c.motor.passive]
    description = (f"holds the build pose of {structure.name}: T0 = build pretension, L* = "
                   f"build length, K = "
                   + ("cable stiffness" if args.stiffness_gain is None
                      else f"{args.stiffness_gain:g} N/m")
                   + f", B = {damping:g} s x K (tensim controller init)")
    config = ControllerConfig(impedance, model=args.model if args.model in PRESETS else None,
                              description=description)
    save_controller(config, out)
    print(f"wrote {out}: impedance laws for {len(impedance.gains)} motorised cables"
          + (f"; {len(passive)} passive cables (no motor): {', '.join(passive)}"
             if passive else ""))
    return 0
