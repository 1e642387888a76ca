"""The reality gap: hardware logs, load-cell calibration, sim-versus-hardware comparison and
system identification (paper sections III-V).

``read_log``/``load_log`` read and validate the CSV schema of :mod:`tensim.hardware.logs`;
``fit_loadcell`` fits eq. (7); ``SensorModel`` makes simulated tensions look logged;
``replay`` simulates a log's inputs; ``compare_tensions`` aligns and scores; ``identify`` fits
named physical and measurement parameters.
"""

from tensim.hardware.compare import CableErrors, Comparison, compare_tensions, estimate_offset
from tensim.hardware.loadcell import (
    PAPER_LOADCELL,
    CalibrationFit,
    LoadCell,
    convert_log,
    fit_loadcell,
    load_calibration,
    load_log,
    read_pairs,
    save_calibration,
)
from tensim.hardware.logs import QUANTITIES, HardwareLog, LogError, read_log, write_log
from tensim.hardware.parameters import DEFINITIONS, SysidSpace, apply_physical
from tensim.hardware.replay import replay, replay_config
from tensim.hardware.sensor import SensorModel
from tensim.hardware.synthetic import node_positions, simulated_log
from tensim.hardware.sysid import SysidResult, SysidSettings, identify

__all__ = [
    "DEFINITIONS",
    "PAPER_LOADCELL",
    "QUANTITIES",
    "CableErrors",
    "CalibrationFit",
    "Comparison",
    "HardwareLog",
    "LoadCell",
    "LogError",
    "SensorModel",
    "SysidResult",
    "SysidSettings",
    "SysidSpace",
    "apply_physical",
    "compare_tensions",
    "convert_log",
    "estimate_offset",
    "fit_loadcell",
    "identify",
    "load_calibration",
    "load_log",
    "node_positions",
    "read_log",
    "read_pairs",
    "replay",
    "replay_config",
    "save_calibration",
    "simulated_log",
    "write_log",
]
