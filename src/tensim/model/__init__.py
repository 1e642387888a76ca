"""Compilation of structure descriptions into MuJoCo models, with names and id lookups."""

from tensim.model._compile import (
    BUILD_KEY,
    WORLD_FRAME_SITE,
    CompiledModel,
    ModelError,
    ModelIndex,
    WorldOptions,
    compile_spec,
    compile_structure,
    without_cable_law,
)
from tensim.model._law_layout import CABLE_MARKER, LawParameters

__all__ = [
    "BUILD_KEY",
    "CABLE_MARKER",
    "WORLD_FRAME_SITE",
    "CompiledModel",
    "LawParameters",
    "ModelError",
    "ModelIndex",
    "WorldOptions",
    "compile_spec",
    "compile_structure",
    "without_cable_law",
]
