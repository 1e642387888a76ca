"""Model presets: ready-made structures (and their default controllers), and the controller
files that name them (:mod:`tensim.models.controllers`)."""

from tensim.models._registry import PRESETS, Preset, load_model, preset
from tensim.models.complex_spines import octahedral_complex, tetrahedral_complex
from tensim.models.controllers import load_controller, resolve_controller
from tensim.models.prism3 import prism3
from tensim.models.prisms import prism, prism4, prism5
from tensim.models.six_bar import six_bar
from tensim.models.superball import superball
from tensim.models.tetraspine import tetraspine, tetraspine3
from tensim.models.three_bar import three_bar

__all__ = [
    "PRESETS",
    "Preset",
    "load_controller",
    "load_model",
    "octahedral_complex",
    "preset",
    "prism",
    "prism3",
    "prism4",
    "prism5",
    "resolve_controller",
    "six_bar",
    "superball",
    "tetrahedral_complex",
    "tetraspine",
    "tetraspine3",
    "three_bar",
]
