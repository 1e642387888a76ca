"""The figure-drawing process of :class:`tensim.viz.drawing.FigureDrawer`, run as a script:
``python -P _drawchild.py FD``.

It loads numpy, matplotlib and the few tensim modules that draw (:mod:`tensim.viz.drawing`,
:mod:`tensim.viz.plots` and their imports, the time series), not the tensim package: the
package's ``__init__`` loads MuJoCo and the whole library, which drawing never uses (0.3 s of
CPU time and 60 MiB). So the packages on the way are registered bare, their ``__init__`` not
run: importing a module of them runs that module and its own imports only.

Its imports are made cheaper in two ways that change nothing drawn (:func:`load_drawing`):
Python's cyclic garbage collector is paused while they run, and matplotlib does not write
the property lists into its artists' ``set`` docstrings, text that only ``help()`` shows
(matplotlib builds it for each artist class as it is defined: a third of its import's CPU
time). Both hold in this process alone, never in the command's.
"""

from __future__ import annotations

import gc
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


def _no_property_list(artist: object) -> str:
    """Stands in for ``matplotlib.artist.kwdoc`` (an artist's property list, for docstrings)."""
    return ""


def load_drawing() -> None:
    """Imports the drawing modules with the collector paused and without matplotlib's
    property lists in docstrings; the objects the imports made are then frozen out of later
    collections (:func:`gc.freeze`: they live as long as the process)."""
    gc.disable()
    try:
        import matplotlib.artist  # before any artist class is defined

        if callable(getattr(matplotlib.artist, "kwdoc", None)):
            matplotlib.artist.kwdoc = _no_property_list
        import tensim.viz.drawing
        import tensim.viz.plots  # noqa: F401
    finally:
        gc.freeze()
        gc.enable()


if __name__ == "__main__":
    register_bare(Path(__file__).resolve().parents[1])
    load_drawing()
    from multiprocessing.connection import Connection

    from tensim.viz.drawing import serve

    serve(Connection(int(sys.argv[1])))
    os._exit(0)  # its files are written and closed: skip the interpreter's slow shutdown
