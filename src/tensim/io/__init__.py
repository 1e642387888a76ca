"""Model exchange: import the original toolkit's YAML structures and MuJoCo MJCF files,
export MuJoCo MJCF."""

from tensim.io.mjcf import mjcf_spec, save_mjcf, to_mjcf
from tensim.io.mjcf_compare import Agreement, compare_with_mujoco
from tensim.io.mjcf_import import (
    ActuatorMapping,
    CommandMap,
    MjcfImport,
    MjcfImportWarning,
    import_mjcf,
    save_import,
    stable_step,
)
from tensim.io.ntrt import UNITS, NtrtImport, import_ntrt

__all__ = ["UNITS", "ActuatorMapping", "Agreement", "CommandMap", "MjcfImport",
           "MjcfImportWarning", "NtrtImport", "compare_with_mujoco", "import_mjcf", "import_ntrt",
           "mjcf_spec", "save_import", "save_mjcf", "stable_step", "to_mjcf"]
