"""The reality gap: hardware logs, load-cell calibration, sim-versus-hardware comparison and
system identification (paper sections III-V).

``read_log``/``load_log`` read and validate the CSV schema of :mod:`tensim.hardware.logs`;
``fit_loadcell`` fits eq. (7); ``SensorModel`` makes simulated tensions look logged;
``replay`` simulates a log's inputs and loads; ``compare_tensions`` aligns and scores;
``identify`` fits named physical and measurement parameters and validates the fit.
"""

from tensim.hardware.compare import (
    Alignment,
    CableErrors,
    Comparison,
    align,
    compare_tensions,
    estimate_offset,
)
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
from tensim.hardware.loads import EXPERIMENTS, load_window, replay_loads
from tensim.hardware.logs import QUANTITIES, HardwareLog, LogError, read_log, write_log
from tensim.hardware.parameters import DEFINITIONS, SysidSpace, apply_physical
from tensim.hardware.replay import replay, replay_config
from tensim.hardware.sensor import SensorModel
from tensim.hardware.synthetic import node_positions, simulated_log
from tensim.hardware.sysid import SysidError, SysidResult, SysidSettings, errors_at, identify

__all__ = [
    "DEFINITIONS",
    "EXPERIMENTS",
    "PAPER_LOADCELL",
    "QUANTITIES",
    "Alignment",
    "CableErrors",
    "CalibrationFit",
    "Comparison",
    "HardwareLog",
    "LoadCell",
    "LogError",
    "SensorModel",
    "SysidError",
    "SysidResult",
    "SysidSettings",
    "SysidSpace",
    "align",
    "apply_physical",
    "compare_tensions",
    "convert_log",
    "errors_at",
    "estimate_offset",
    "fit_loadcell",
    "identify",
    "load_calibration",
    "load_log",
    "load_window",
    "node_positions",
    "read_log",
    "read_pairs",
    "replay",
    "replay_config",
    "replay_loads",
    "save_calibration",
    "simulated_log",
    "write_log",
]
