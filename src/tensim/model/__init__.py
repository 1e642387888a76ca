"""Compilation of structure descriptions into MuJoCo models, with names and id lookups."""

from tensim.model._compile import (
    CompiledModel,
    ModelError,
    ModelIndex,
    WorldOptions,
    compile_structure,
)

__all__ = ["CompiledModel", "ModelError", "ModelIndex", "WorldOptions", "compile_structure"]
