"""Finds and loads tensim's optional compiled parts (built at install time where a C compiler
was found): the cable law (``tensim.sim._cable``) and the CPG integrator
(``tensim.control._cpg``)."""

from __future__ import annotations

import ctypes
import importlib.util
import logging

log = logging.getLogger(__name__)


def load_library(module: str, what: str, fallback: str) -> ctypes.CDLL | None:
    """The compiled extension ``module`` as a C library, or None where it was not built or
    cannot be loaded (then a warning says so, naming ``what`` it is and the ``fallback``)."""
    spec = importlib.util.find_spec(module)
    if spec is None or spec.origin is None:
        return None
    try:
        return ctypes.CDLL(spec.origin)
    except OSError as err:  # built for another platform, or damaged
        log.warning("%s %s cannot be loaded (%s); %s (reinstall tensim to rebuild it)",
                    what, spec.origin, err, fallback)
        return None
