"""The member forces of a simulated run: each cable's peak tension and each rod's peak axial
force from the cables' pulls at its ends, at every recorded instant (see
:func:`tensim.design.members.end_forces`; ground forces and inertia are left out)."""

from __future__ import annotations

import numpy as np

from tensim.design._errors import DesignError
from tensim.design.members import end_forces
from tensim.hardware import node_positions
from tensim.model import compile_structure
from tensim.sim import TimeSeries
from tensim.structure import Structure


def run_peaks(structure: Structure, series: TimeSeries
              ) -> tuple[np.ndarray, dict[str, float | None]]:
    """Peak tension per cable (n_cables,) [N], and per rod its force at the instant of its
    largest magnitude (negative in compression; None if ever undetermined) [N].

    Raises:
        DesignError: the trajectory lacks a cable's tension or the bodies' poses.
    """
    names = [c.name for c in structure.cables]
    missing = [n for n in names if f"tension/{n}" not in series.channels]
    if missing:
        raise DesignError(f"the run's trajectory has no tension/{missing[0]} channel; expected "
                          "a run of this structure")
    tensions = np.stack([series[f"tension/{n}"] for n in names], axis=1)
    compiled = compile_structure(structure)
    free = [n.name for n in structure.nodes if compiled.index.node_body.get(n.name, 0) != 0]
    try:
        where = node_positions(series, compiled, free)
    except KeyError as err:
        raise DesignError(f"the run's trajectory lacks the bodies' poses ({err})") from None
    fixed = {n.name: structure.position(n.name) for n in structure.nodes if n.name not in where}
    peaks: dict[str, float | None] = {r.name: 0.0 for r in structure.rods}
    for k in range(len(series.time)):
        at = {**fixed, **{n: p[k] for n, p in where.items()}}
        for rod, force in end_forces(structure, tensions[k], at).items():
            held = peaks[rod]
            if force is None or held is None:
                peaks[rod] = None
            elif abs(force) > abs(held):
                peaks[rod] = force
    return tensions.max(axis=0), peaks
