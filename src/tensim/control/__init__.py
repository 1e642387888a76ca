"""Controllers: the per-cable impedance law, the gait generators (CPG, sine, spine waves) that
drive its target velocity V*, sampled V* tables, and controller files."""

from tensim.control.cpg import (
    Coupling,
    CPGController,
    CPGNetwork,
    CPGTrajectory,
    GaitError,
    SolverSettings,
    integrate,
    solve,
)
from tensim.control.files import (
    ControllerConfig,
    ControllerFileError,
    controller_path,
    load_controller,
    save_controller,
    shipped_controllers,
)
from tensim.control.impedance import ImpedanceController, ImpedanceGains, default_impedance
from tensim.control.parameters import Bounds, Parameter, ParameterLayout, ParameterVector
from tensim.control.rest import RestCommand
from tensim.control.sine import SineController, SineGait, tagged_sine, tetraspine_sine
from tensim.control.spine import (
    CPGParameters,
    SpineCPG,
    shared_body_pairs,
    spine_network,
    spine_parameters,
)
from tensim.control.velocity_table import (
    TableController,
    VelocityFileError,
    VelocityTable,
    load_velocity_table,
    save_velocity_table,
)
from tensim.control.wave import SpineWave, SpineWaveParameters, spine_wave_parameters

__all__ = [
    "Bounds",
    "CPGController",
    "CPGNetwork",
    "CPGParameters",
    "CPGTrajectory",
    "ControllerConfig",
    "ControllerFileError",
    "Coupling",
    "GaitError",
    "ImpedanceController",
    "ImpedanceGains",
    "Parameter",
    "ParameterLayout",
    "ParameterVector",
    "RestCommand",
    "SineController",
    "SineGait",
    "SolverSettings",
    "SpineCPG",
    "SpineWave",
    "SpineWaveParameters",
    "TableController",
    "VelocityFileError",
    "VelocityTable",
    "controller_path",
    "default_impedance",
    "integrate",
    "load_controller",
    "load_velocity_table",
    "save_controller",
    "save_velocity_table",
    "shared_body_pairs",
    "shipped_controllers",
    "solve",
    "spine_network",
    "spine_parameters",
    "spine_wave_parameters",
    "tagged_sine",
    "tetraspine_sine",
]
