"""Design analyses on structures: self-stress, stiffness, inverse statics, motor sizing, checks.

Everything here works on plain :class:`tensim.structure.Structure` descriptions at their build
pose (no MuJoCo), in SI units; figures and reports live in :mod:`tensim.design.report`, which
nothing in the library imports.
"""

from tensim.design._errors import DesignError
from tensim.design.equilibrium import (
    Equilibrium,
    SelfStress,
    equilibrium,
    prestressed,
    residuals,
    self_stress,
)

__all__ = [
    "DesignError",
    "Equilibrium",
    "SelfStress",
    "equilibrium",
    "prestressed",
    "residuals",
    "self_stress",
]
