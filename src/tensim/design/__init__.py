"""Design analyses on structures: self-stress, stiffness, inverse statics, motor sizing, checks.

Everything here works on plain :class:`tensim.structure.Structure` descriptions at their build
pose (no MuJoCo), in SI units; figures and reports live in :mod:`tensim.design.report`, which
nothing in the library imports.
"""

from tensim.design._errors import DesignError
from tensim.design.check import Finding, check_structure
from tensim.design.equilibrium import (
    Equilibrium,
    SelfStress,
    equilibrium,
    prestressed,
    residuals,
    self_stress,
)
from tensim.design.inverse import InverseStatics, RestCommand, inverse_statics
from tensim.design.motors import CableDuty, DriveMotor, cable_duty, load_catalogue
from tensim.design.stiffness import StepBound, Stiffness, stable_timestep, step_bound, stiffness

__all__ = [
    "CableDuty",
    "DesignError",
    "DriveMotor",
    "Equilibrium",
    "Finding",
    "InverseStatics",
    "RestCommand",
    "SelfStress",
    "StepBound",
    "Stiffness",
    "cable_duty",
    "check_structure",
    "equilibrium",
    "inverse_statics",
    "load_catalogue",
    "prestressed",
    "residuals",
    "self_stress",
    "stable_timestep",
    "step_bound",
    "stiffness",
]
