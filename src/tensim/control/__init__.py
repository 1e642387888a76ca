"""Controllers: the per-cable impedance law and (later) gait generators that drive its V*."""

from tensim.control.impedance import ImpedanceController, ImpedanceGains

__all__ = ["ImpedanceController", "ImpedanceGains"]
