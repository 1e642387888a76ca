"""tensim: model, simulate and control tensegrity robots on MuJoCo."""

from tensim._input import InputError
from tensim.control import ImpedanceController, ImpedanceGains
from tensim.model import CompiledModel, WorldOptions, compile_structure
from tensim.sim import (
    NodeLoad,
    Simulation,
    SimulationError,
    SimulationResult,
    TimeSeries,
    simulate,
)
from tensim.structure import (
    Cable,
    CableContact,
    DCMotor,
    Motor,
    Node,
    PointMass,
    Rod,
    Structure,
    StructureError,
    load_structure,
    save_structure,
)

__version__ = "0.1.0"

__all__ = [
    "Cable",
    "CableContact",
    "CompiledModel",
    "DCMotor",
    "ImpedanceController",
    "ImpedanceGains",
    "InputError",
    "Motor",
    "Node",
    "NodeLoad",
    "PointMass",
    "Rod",
    "Simulation",
    "SimulationError",
    "SimulationResult",
    "Structure",
    "StructureError",
    "TimeSeries",
    "WorldOptions",
    "compile_structure",
    "load_structure",
    "save_structure",
    "simulate",
]
