"""``tensim models``: list the presets and the shipped controller files."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("models", help="list the model presets and shipped controller files")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from tensim.control import shipped_controllers
    from tensim.models import PRESETS

    print("model presets:")
    for preset in PRESETS.values():
        print(f"  {preset.name:<20} {preset.summary}")
    print("shipped controller files (use the name with --controller):")
    for name, path in shipped_controllers().items():
        print(f"  {name:<20} {path.name}")
    return 0
