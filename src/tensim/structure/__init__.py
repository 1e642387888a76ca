"""Structure descriptions: nodes, rods, cables, point masses and tags, as plain validated data.

Nothing here imports MuJoCo; :mod:`tensim.model` compiles a structure into a MuJoCo model.
"""

from tensim.structure._errors import StructureError
from tensim.structure._mass import MassProperties, mass_properties
from tensim.structure._records import (
    PASSIVE,
    Cable,
    CableContact,
    DCMotor,
    Motor,
    Node,
    PointMass,
    Rod,
    RodSection,
)
from tensim.structure._structure import RigidGroup, Structure, body_length
from tensim.structure._yaml import (
    load_structure,
    motor_sources,
    save_structure,
    structure_from_dict,
    structure_to_dict,
)

__all__ = [
    "PASSIVE",
    "Cable",
    "CableContact",
    "DCMotor",
    "MassProperties",
    "Motor",
    "Node",
    "PointMass",
    "RigidGroup",
    "Rod",
    "RodSection",
    "Structure",
    "StructureError",
    "body_length",
    "load_structure",
    "mass_properties",
    "motor_sources",
    "save_structure",
    "structure_from_dict",
    "structure_to_dict",
]
