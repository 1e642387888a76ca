"""Controller files by preset: the lookup the data layers leave to the top.

:func:`tensim.control.load_controller` reads a file for a robot it is given; here a file
that names a preset in ``model`` gets that preset when no robot is given, is refused on a
robot whose cables are not that preset's, and a command's controller resolves to a file, a
shipped name, or the preset's own impedance laws.
"""

from __future__ import annotations

import functools
import os

from tensim.control import ControllerConfig, ControllerFileError, controller_path
from tensim.control import load_controller as load_for_robot
from tensim.control.files import controller_from_file, read_controller_data
from tensim.models._registry import PRESETS
from tensim.structure import Structure


@functools.cache
def _preset_cables(model: str) -> frozenset[str]:
    return frozenset(c.name for c in PRESETS[model].build().cables)


def load_controller(source: str | os.PathLike[str], structure: Structure | None = None
                    ) -> ControllerConfig:
    """Reads a controller file, or a shipped controller by name.

    Args:
        source: a .yaml/.yml/.json path, or the name of a shipped controller.
        structure: the robot; None builds the preset the file names in ``model``.

    Raises:
        FileNotFoundError: neither a file nor a shipped controller.
        ControllerFileError: as :func:`tensim.control.load_controller`, and a file that names
            no preset while no robot is given, or names a preset whose cables are not
            ``structure``'s.
    """
    path = controller_path(source)
    data = read_controller_data(path)
    model = data.get("model") if isinstance(data, dict) else None
    if structure is None:
        if model not in PRESETS:
            raise ControllerFileError(f"names no preset ({model!r}); pass the structure it "
                                      "drives", field="model", source=str(path))
        structure = PRESETS[model].build()
    elif isinstance(model, str) and model in PRESETS \
            and _preset_cables(model) != frozenset(c.name for c in structure.cables):
        raise ControllerFileError(f"the file is made for {model!r}, whose cables are not those "
                                  f"of the robot {structure.name!r}; pass a controller for that "
                                  "robot", field="model", source=str(path))
    return controller_from_file(path, data, structure)


def resolve_controller(model: str, structure: Structure, source: str | None
                       ) -> ControllerConfig | None:
    """The controller for a command: the file or shipped name given, else the preset's own.

    Returns None for a structure without a default controller.
    """
    if source is not None:
        return load_controller(source, structure)
    if model in PRESETS:
        impedance = PRESETS[model].controller()
        if impedance is not None:
            return ControllerConfig(impedance, model=model)
    return None


__all__ = ["load_controller", "load_for_robot", "resolve_controller"]
