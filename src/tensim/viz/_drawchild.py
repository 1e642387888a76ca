"""The figure-drawing process of :class:`tensim.viz.drawing.FigureDrawer`, run as a script:
``python -P _drawchild.py FD``.

It loads numpy, matplotlib and the few tensim modules that draw (:mod:`tensim.viz.drawing`,
:mod:`tensim.viz.plots` and their imports, the time series), not the tensim package: the
package's ``__init__`` loads MuJoCo and the whole library, which drawing never uses (0.3 s of
CPU time and 60 MiB). So the packages on the way are registered bare, their ``__init__`` not
run: importing a module of them runs that module and its own imports only.
"""

from __future__ import annotations

import os
import sys
import types
from pathlib import Path

# the packages whose __init__ the drawing process skips (tensim.viz's own is light)
BARE = ("tensim", "tensim.sim")


def register_bare(root: Path, names: tuple[str, ...] = BARE) -> None:
    """Registers the packages ``names`` of the tensim package folder ``root`` without running
    their ``__init__``."""
    for name in names:
        package = types.ModuleType(name)
        package.__path__ = [str(root.joinpath(*name.split(".")[1:]))]
        sys.modules[name] = package


if __name__ == "__main__":
    register_bare(Path(__file__).resolve().parents[1])
    from multiprocessing.connection import Connection

    from tensim.viz.drawing import serve

    serve(Connection(int(sys.argv[1])))
    os._exit(0)  # its files are written and closed: skip the interpreter's slow shutdown
