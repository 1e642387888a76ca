"""The OpenGL painting process of :class:`tensim.viz._gl.GLServer`, run as a script:
``python -P _glchild.py FD BACKEND`` (it serves :func:`tensim.viz._glserver.serve`).

It loads numpy and MuJoCo's compiled bindings (the enumerations, the functions, the model,
data and specification structures and the renderer's context), not the ``mujoco`` package's
``__init__``, which also loads GLFW, the Python renderer classes and the rest of the package:
0.1 s of CPU time and 11 MiB that painting never uses. Nor does it run the tensim package's
``__init__`` (the whole library).
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import sys
import types
from pathlib import Path

# MuJoCo's compiled modules that painting uses, in the order the package takes their names
# (the specifications' module registers the virtual file system that loading a model takes)
BINDINGS = ("_enums", "_functions", "_specs", "_structs", "_render")


def register_bare_mujoco(bindings: tuple[str, ...] = BINDINGS) -> types.ModuleType:
    """Registers a ``mujoco`` package without running its ``__init__``, holding the public
    names of ``bindings`` (as the package's own ``from mujoco._structs import *``), so that
    ``import mujoco``, ``mujoco.MjModel`` and ``mujoco.egl`` work as usual.

    Raises:
        ImportError: MuJoCo is not installed.
    """
    spec = importlib.util.find_spec("mujoco")
    if spec is None or spec.submodule_search_locations is None:
        raise ImportError("no mujoco package")
    package = types.ModuleType("mujoco")
    package.__path__ = list(spec.submodule_search_locations)
    sys.modules["mujoco"] = package
    for name in bindings:
        module = importlib.import_module(f"mujoco.{name}")
        vars(package).update((key, value) for key, value in vars(module).items()
                             if not key.startswith("_"))
    return package


def register_bare() -> None:
    """Registers the tensim package (as :mod:`tensim.viz._drawchild` does: importing a module of
    it runs that module and its own imports only) and MuJoCo's bindings
    (:func:`register_bare_mujoco`) without their ``__init__``."""
    tensim = types.ModuleType("tensim")
    tensim.__path__ = [str(Path(__file__).resolve().parents[1])]
    sys.modules["tensim"] = tensim
    register_bare_mujoco()


if __name__ == "__main__":
    register_bare()
    from tensim.viz._glserver import serve

    serve(int(sys.argv[1]), sys.argv[2])
    sys.stdout.flush()
    os._exit(0)  # skip the interpreter's shutdown, and the GL driver's atexit handlers
