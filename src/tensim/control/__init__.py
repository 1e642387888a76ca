"""Controllers: the per-cable impedance law, and the gait generators (CPG, sine) that drive V*."""

from tensim.control.cpg import (
    Bounds,
    Coupling,
    CPGController,
    CPGNetwork,
    CPGParameters,
    CPGTrajectory,
    GaitError,
    Parameter,
    SolverSettings,
    integrate,
    shared_body_pairs,
    solve,
    spine_network,
    spine_parameters,
)
from tensim.control.impedance import ImpedanceController, ImpedanceGains
from tensim.control.sine import SineController, SineGait, tagged_sine, tetraspine_sine

__all__ = [
    "Bounds",
    "CPGController",
    "CPGNetwork",
    "CPGParameters",
    "CPGTrajectory",
    "Coupling",
    "GaitError",
    "ImpedanceController",
    "ImpedanceGains",
    "Parameter",
    "SineController",
    "SineGait",
    "SolverSettings",
    "integrate",
    "shared_body_pairs",
    "solve",
    "spine_network",
    "spine_parameters",
    "tagged_sine",
    "tetraspine_sine",
]
