"""Model exchange: import the original toolkit's YAML structures, export MuJoCo MJCF."""

from tensim.io.mjcf import mjcf_spec, save_mjcf, to_mjcf
from tensim.io.ntrt import UNITS, NtrtImport, import_ntrt

__all__ = ["UNITS", "NtrtImport", "import_ntrt", "mjcf_spec", "save_mjcf", "to_mjcf"]
