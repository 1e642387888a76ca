"""External node loads written by hand: ``NODE:FX,FY,FZ@T0-T1`` on the command line, or a file.

A push is a force vector [N] at a node over a time window [s]: it ramps up over ``ramp``
seconds from the window's start, holds, and ramps down to zero by its end (a ramp keeps the
push from being an impulse, which a stiff robot would ring with). A loads file is YAML (or
JSON)::

    loads:
      - {node: t0, force: [5, 0, 0], start: 1.0, stop: 3.0}          # a push, ramp 0.1 s
      - {node: t1, force: [0, 0, -2], start: 0.5, stop: 4, ramp: 0.5}
      - {node: t2, times: [0, 1, 2], forces: [[0, 0, 0], [1, 0, 0], [0, 0, 0]]}  # knots

:func:`save_loads` writes every load in the knot form, which a run folder keeps as ``loads.yaml``
and ``tensim simulate --loads`` reads back.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from tensim._files import write_text
from tensim._input import InputError, describe, load_yaml_file
from tensim.sim import NodeLoad
from tensim.structure import Structure

DEFAULT_RAMP = 0.1  # s
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_PUSH = re.compile(rf"(?P<node>[^:]+):(?P<force>{_NUMBER},{_NUMBER},{_NUMBER})"
                   rf"@(?P<start>{_NUMBER})-(?P<stop>{_NUMBER})(?:/(?P<ramp>{_NUMBER}))?")


class LoadError(InputError):
    """A load on the command line or in a file is malformed or does not fit the robot."""


def push(node: str, force: Sequence[float], start: float, stop: float,
         ramp: float = DEFAULT_RAMP) -> NodeLoad:
    """``force`` [N] at ``node`` from ``start`` to ``stop`` [s], ramped over ``ramp`` [s].

    Raises:
        LoadError: a window that is empty, starts before 0 or is shorter than two ramps.
    """
    vector = np.asarray(force, dtype=float).reshape(-1)
    if vector.size != 3 or not np.isfinite(vector).all():
        raise LoadError(f"load at {node!r}: force must be three finite numbers [N], got {force}")
    if not (math.isfinite(start) and math.isfinite(stop) and 0 <= start < stop):
        raise LoadError(f"load at {node!r}: window {start:g}-{stop:g} s must have 0 <= start "
                        "< stop")
    # a ramp that fills the window exactly, as the user wrote it (0.1-0.3/0.1), is read as
    # filling it, not refused by the round-off of stop - start
    fills = math.isclose(2 * ramp, stop - start, rel_tol=1e-9)
    if not (math.isfinite(ramp) and ramp > 0 and (2 * ramp <= stop - start or fills)):
        raise LoadError(f"load at {node!r}: ramp {ramp:g} s must be > 0 and fit twice in the "
                        f"window {start:g}-{stop:g} s")
    if not fills:
        times, scale = [start, start + ramp, stop - ramp, stop], [0.0, 1.0, 1.0, 0.0]
    else:  # all ramp: up and straight back down
        times, scale = [start, (start + stop) / 2, stop], [0.0, 1.0, 0.0]
    return NodeLoad(node, np.array(times), np.array(scale)[:, None] * vector[None, :])


def parse_push(text: str) -> NodeLoad:
    """``NODE:FX,FY,FZ@T0-T1`` (newtons, seconds), or ``...@T0-T1/RAMP``, as a load.

    Raises:
        LoadError: naming the expected form.
    """
    match = _PUSH.fullmatch(text.strip())
    if match is None:
        raise LoadError(f"--load {text!r}: expected NODE:FX,FY,FZ@T0-T1[/RAMP] (force in N, "
                        "window and ramp in s), e.g. t0:5,0,0@1-3")
    force = [float(x) for x in match["force"].split(",")]
    ramp = float(match["ramp"]) if match["ramp"] else DEFAULT_RAMP
    try:
        return push(match["node"], force, float(match["start"]), float(match["stop"]), ramp)
    except LoadError as err:
        raise LoadError(f"--load {text!r}: {err}") from None


def _entry(raw: Any, where: str) -> NodeLoad:
    if not isinstance(raw, dict) or not isinstance(raw.get("node"), str):
        raise LoadError(f"{where}: expected a mapping with 'node' and either force/start/stop "
                        f"or times/forces, got {describe(raw)}")
    keys = set(raw)
    try:
        if keys <= {"node", "force", "start", "stop", "ramp"} and "force" in keys:
            return push(raw["node"], raw["force"], float(raw["start"]), float(raw["stop"]),
                        float(raw.get("ramp", DEFAULT_RAMP)))
        if keys == {"node", "times", "forces"}:
            return NodeLoad(raw["node"], np.asarray(raw["times"], dtype=float),
                            np.asarray(raw["forces"], dtype=float))
    except (KeyError, TypeError, ValueError) as err:
        raise LoadError(f"{where}: {err}") from None
    raise LoadError(f"{where}: expected fields node, force, start, stop[, ramp] or node, "
                    f"times, forces; got {sorted(keys)}")


def load_loads(path: str | os.PathLike[str]) -> list[NodeLoad]:
    """Reads a loads file (see the module docstring).

    Raises:
        LoadError: naming the file and the entry.
    """
    path = Path(path)
    data = load_yaml_file(path)
    entries = data.get("loads") if isinstance(data, dict) else None
    if not isinstance(entries, list):
        raise LoadError(f"{path}: expected a mapping with a 'loads' list")
    return [_entry(raw, f"{path}: loads[{k}]") for k, raw in enumerate(entries)]


def loads_to_dict(loads: Sequence[NodeLoad]) -> dict[str, Any]:
    """The loads in the file's knot form."""
    return {"loads": [{"node": load.node, "times": [float(t) for t in load.times],
                       "forces": [[float(f) for f in row] for row in load.forces]}
                      for load in loads]}


def save_loads(loads: Sequence[NodeLoad], path: str | os.PathLike[str]) -> Path:
    """Writes the loads as YAML in the knot form, atomically."""
    path = Path(path)
    write_text(path, "# external node loads [N] at knot times [s], linear between knots\n"
               + yaml.safe_dump(loads_to_dict(loads), sort_keys=False,
                                default_flow_style=None))
    return path


def check_loads(loads: Sequence[NodeLoad], structure: Structure, duration: float) -> list[str]:
    """Checks loads against a robot and a run before it simulates.

    Returns:
        Notes on loads that the run leaves out (a load whose forces start after the run ends).

    Raises:
        LoadError: a load at a node the robot lacks, naming its nodes.
    """
    nodes = [n.name for n in structure.nodes]
    notes = []
    for load in loads:
        if load.node not in nodes:
            raise LoadError(f"load at unknown node {load.node!r}: {structure.name!r} has the "
                            f"nodes {', '.join(nodes)}")
        active = np.flatnonzero(np.abs(load.forces).max(axis=1) > 0)
        if not active.size:
            continue  # no force at all
        first = 0.0 if active[0] == 0 else float(load.times[active[0] - 1])
        if first >= duration:
            notes.append(f"the load at {load.node!r} starts at {first:g} s, after the run's "
                         f"{duration:g} s: it never acts")
        elif load.times[-1] > duration:
            notes.append(f"the load at {load.node!r} lasts until {load.times[-1]:g} s, past "
                         f"the run's {duration:g} s: the run ends during it")
    return notes
