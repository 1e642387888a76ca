"""Design analyses: form finding, self-stress, stiffness, inverse statics, motors, checks.

Everything here works on plain :class:`tensim.structure.Structure` descriptions at their build
pose (no MuJoCo), in SI units; figures and reports live in :mod:`tensim.design.report`, which
nothing in the library imports. scipy's optimizers are imported where they are called
(about 0.3 s of CPU that ``tensim simulate``'s pre-run check, which solves nothing, need not
pay).
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
from tensim.design.form_finding import Form, form
from tensim.design.inverse import InverseStatics, RestCommand, inverse_statics
from tensim.design.motors import CableDuty, DriveMotor, cable_duty, load_catalogue
from tensim.design.stiffness import StepBound, Stiffness, stable_timestep, step_bound, stiffness
from tensim.design.topology import Topology, load_topology, topology_from_dict

__all__ = [
    "CableDuty",
    "DesignError",
    "DriveMotor",
    "Equilibrium",
    "Finding",
    "Form",
    "InverseStatics",
    "RestCommand",
    "SelfStress",
    "StepBound",
    "Stiffness",
    "Topology",
    "cable_duty",
    "check_structure",
    "equilibrium",
    "form",
    "inverse_statics",
    "load_catalogue",
    "load_topology",
    "prestressed",
    "residuals",
    "self_stress",
    "stable_timestep",
    "step_bound",
    "stiffness",
    "topology_from_dict",
]
