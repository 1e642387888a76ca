"""Writes ``src/tensim/sim/_cable_layout.h``, the cable law's parameter layout for the C law,
from its one specification (``tensim.model._law_layout``).

Run it after changing the layout, then rebuild the compiled law (``pip install -e .``);
``tests/test_law_layout.py`` checks that the committed header equals what it writes.

Usage: python tools/law_header.py
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "tensim"
HEADER = SRC / "sim" / "_cable_layout.h"


def c_header() -> str:
    """The header's text, from the layout module alone (no compiled part needed to run it)."""
    spec = importlib.util.spec_from_file_location("_law_layout", SRC / "model" / "_law_layout.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return str(module.c_header())


if __name__ == "__main__":
    HEADER.write_text(c_header())
    print(f"wrote {HEADER.name}")
