"""``tensim models``: list the presets and the shipped controller files."""

from __future__ import annotations

import argparse
import textwrap

from tensim._input import load_yaml_file


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
    shipped = shipped_controllers()
    width = max(map(len, shipped), default=0)
    for name, path in shipped.items():
        data = load_yaml_file(path)
        about = str(data.get("description", "")).split(" (", 1)[0].split(", learned", 1)[0]
        print(f"  {name:<{width}}  {data.get('model', '?')}: {textwrap.shorten(about, 72)}")
    return 0
