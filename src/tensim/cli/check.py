"""``tensim check``: what in a model makes its runs fail or lie, and what to change."""

from __future__ import annotations

import argparse

from tensim.cli._common import load_model, positive


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("check", help="check a model: time step, thin rods, slack cables, "
                       "equilibrium, motors, units")
    p.add_argument("model", help="preset name or structure .yaml file")
    p.add_argument("--dt", type=positive, default=1e-3, help="physics step to check [s]")
    p.add_argument("--cable-law", choices=("explicit", "implicit", "implicitfast"),
                   default="explicit",
                   help="the cable law the runs use: the step bound is its integrator's "
                        "(explicit: Euler; implicitfast; implicit: MuJoCo's discrete step, "
                        "stable at any step)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Prints each finding; exits 1 when one of them is an error."""
    from tensim.design.check import check_structure

    findings = check_structure(load_model(args.model), args.dt, source=args.model,
                               cable_law=args.cable_law)
    for finding in findings:
        print(finding)
    if not findings:
        law = "" if args.cable_law == "explicit" else f" under the {args.cable_law} law"
        print(f"{args.model}: no findings at dt = {args.dt:g} s{law}")
    return 1 if any(f.severity == "error" for f in findings) else 0
