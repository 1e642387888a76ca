"""Simulation: the fixed-step loop, cables and motors, external forces and recording."""

from tensim.sim._batch import PhysicsScale, Trial, TrialResult, run_batch
from tensim.sim._drive import MODE_IMPEDANCE, MODE_PD, MODE_REST, CableDrive, InputPlan
from tensim.sim._law import cable_law, compiled_available, installed_backend
from tensim.sim._law import install as install_law
from tensim.sim._laws import (
    cable_tension,
    impedance_rest_target,
    impedance_setpoint,
    load_cell_reading,
    load_cell_tension,
    motor_step,
)
from tensim.sim._loads import NodeLoad, ramp_hold_release
from tensim.sim._simulation import (
    COM,
    CableSetup,
    Controller,
    Simulation,
    SimulationError,
    SimulationResult,
    StabilityLimits,
    simulate,
)
from tensim.sim._timeseries import UNITS, TimeSeries

__all__ = [
    "COM",
    "MODE_IMPEDANCE",
    "MODE_PD",
    "MODE_REST",
    "UNITS",
    "CableDrive",
    "CableSetup",
    "Controller",
    "InputPlan",
    "NodeLoad",
    "PhysicsScale",
    "Simulation",
    "SimulationError",
    "SimulationResult",
    "StabilityLimits",
    "TimeSeries",
    "Trial",
    "TrialResult",
    "cable_law",
    "cable_tension",
    "compiled_available",
    "impedance_rest_target",
    "impedance_setpoint",
    "install_law",
    "installed_backend",
    "load_cell_reading",
    "load_cell_tension",
    "motor_step",
    "ramp_hold_release",
    "run_batch",
    "simulate",
]
