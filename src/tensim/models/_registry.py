"""The preset registry: names, one-line summaries, builders and default controllers."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

from tensim._input import InputError
from tensim.control import ImpedanceController
from tensim.models.complex_spines import octahedral_complex, tetrahedral_complex
from tensim.models.prism3 import prism3
from tensim.models.prisms import prism4, prism5
from tensim.models.six_bar import six_bar
from tensim.models.superball import superball
from tensim.models.tetraspine import impedance_controller, tetraspine, tetraspine3
from tensim.models.three_bar import three_bar
from tensim.structure import Structure, load_structure


@dataclasses.dataclass(frozen=True)
class Preset:
    """A named ready-made model.

    Attributes:
        name: preset name used on the command line.
        summary: one line for ``tensim models``.
        build: returns the structure.
        controller: returns its default controller, or None for a passive structure.
    """

    name: str
    summary: str
    build: Callable[[], Structure]
    controller: Callable[[], ImpedanceController | None] = lambda: None


PRESETS: dict[str, Preset] = {
    p.name: p for p in (
        Preset("tetraspine3", "3-segment hardware Tetraspine of the paper, 12 impedance-"
               "controlled cables, 2.35 kg", tetraspine3, lambda: impedance_controller(3)),
        Preset("tetraspine", "12-segment Tetraspine (same joint pattern), 66 impedance-"
               "controlled cables", tetraspine, lambda: impedance_controller(12)),
        Preset("six_bar", "six-strut icosahedron (ReCTeR scale, 1 m struts), 24 passive cables",
               six_bar),
        Preset("prism3", "triangular tensegrity prism, 3 rods, 9 pretensioned passive cables",
               prism3),
        Preset("prism4", "square tensegrity prism (135 deg twist), 4 rods, 12 self-stressed "
               "cables", prism4),
        Preset("prism5", "pentagonal tensegrity prism (126 deg twist), 5 rods, 15 self-stressed "
               "cables", prism5),
        Preset("superball", "SUPERball scale six-bar: 1.68 m, 3.5 kg struts, 24 cables of "
               "613 N/m at 245 N", superball),
        Preset("three_bar", "3-bar rolling robot: 1.376 m, 4 kg bars, 6 motorised end-triangle "
               "cables and 3 passive verticals of 10 kN/m", three_bar),
        Preset("tetrahedral_complex", "6-vertebra tetrahedral-complex spine (4 rods from a "
               "centre), 40 motorised cables", tetrahedral_complex),
        Preset("octahedral_complex", "6-vertebra octahedral-complex spine (6 rods from a "
               "centre), 40 motorised cables", octahedral_complex),
    )
}


def preset(name: str) -> Preset:
    """The preset called ``name``.

    Raises:
        KeyError: with the list of known presets.
    """
    try:
        return PRESETS[name]
    except KeyError:
        raise KeyError(f"unknown model {name!r}; presets: {', '.join(PRESETS)}") from None


def load_model(name: str) -> Structure:
    """A preset's structure, or a structure YAML file.

    Raises:
        InputError: neither a preset nor an existing .yaml file.
    """
    if name in PRESETS:
        return PRESETS[name].build()
    path = Path(name)
    if path.suffix in (".yaml", ".yml") and path.is_file():
        return load_structure(path)
    raise InputError(f"unknown model {name!r}: neither a preset ({', '.join(PRESETS)}) nor an "
                     "existing .yaml structure file")
