"""What a log says was done to the robot: its external loads and its named experiment.

Loads are ``load_N/<node>/<axis>`` columns [N, world frame], linear between a node's samples
and held before the first and after the last (so a push that starts from rest logs a 0 N row
first). A header ``# experiment: disturbance`` with ``# experiment_params: peak=22.56,
start=30, ...`` names a built-in protocol; its loads are replayed when the log has no load
columns (columns, when present, are what happened and win).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping

import numpy as np

from tensim.hardware.logs import AXES, HardwareLog, LogError
from tensim.sim import NodeLoad, ramp_hold_release
from tensim.structure import Structure


@dataclasses.dataclass(frozen=True)
class Experiment:
    """A built-in protocol a log can name.

    Attributes:
        name: its name in the ``experiment`` header.
        defaults: parameter -> default value (units in ``units``).
        units: parameter -> unit.
        loads: the external loads for given parameters.
        description: one line.
        positive: parameters that must be > 0 (the others >= 0).
    """

    name: str
    defaults: Mapping[str, float]
    units: Mapping[str, str]
    loads: Callable[[Mapping[str, float]], tuple[NodeLoad, ...]]
    description: str
    positive: tuple[str, ...] = ()


def _disturbance(params: Mapping[str, float]) -> tuple[NodeLoad, ...]:
    """The paper's Fig. 3 push on the front tip, with the restoring forces on the others."""
    from tensim.experiments.disturbance import RESTORING_SHARE
    from tensim.models.tetraspine import node_name

    push = ramp_hold_release(node_name(0, "tip"), (1.0, 0.0, 0.0), params["peak"],
                             params["start"], params["rise"], params["hold"], params["fall"])
    return (push, *(push.scaled(-share).at(node_name(seg, "tip"))
                    for seg, share in RESTORING_SHARE.items()))


def _sine(params: Mapping[str, float]) -> tuple[NodeLoad, ...]:
    return ()


EXPERIMENTS: dict[str, Experiment] = {e.name: e for e in (
    Experiment("disturbance",
               {"peak": 22.56, "start": 30.0, "rise": 5.0, "hold": 5.0, "fall": 5.0},
               {"peak": "N", "start": "s", "rise": "s", "hold": "s", "fall": "s"},
               _disturbance, "a forward push on the front segment's tip (paper Fig. 3), the "
               "other tips pushed back with 0.45 and 0.55 of it",
               positive=("rise", "hold", "fall")),
    Experiment("sine", {}, {}, _sine, "a gait from the logged V* (no external loads)"),
)}


def experiment_params(name: str, text: str | Mapping[str, float] | None, where: str
                      ) -> dict[str, float]:
    """The experiment's parameters: its defaults with ``text`` (``"peak=20,start=2"``) applied.

    Raises:
        LogError: an unknown experiment or parameter, or a value that is not a number >= 0
            (> 0 for a phase's duration), naming ``where`` (the file and header, or the
            option).
    """
    if name not in EXPERIMENTS:
        raise LogError(f"{where}: unknown experiment {name!r}; expected one of "
                       f"{list(EXPERIMENTS)}")
    experiment = EXPERIMENTS[name]
    given = text if isinstance(text, Mapping) else dict(
        _pair(entry, where) for entry in (text or "").split(",") if entry.strip())
    out = dict(experiment.defaults)
    for key, value in given.items():
        if key not in out:
            raise LogError(f"{where}: experiment {name!r} has no parameter {key!r}; expected "
                           f"one of {list(out)}")
        if not (np.isfinite(value) and value >= 0):
            raise LogError(f"{where}: {key}: expected a number >= 0, got {value!r}")
        if key in experiment.positive and value <= 0:
            raise LogError(f"{where}: {key}: expected a duration > 0 (each phase of "
                           f"{name!r} takes time), got {value!r}")
        out[key] = float(value)
    return out


def _pair(entry: str, where: str) -> tuple[str, float]:
    key, _, value = (p.strip() for p in entry.partition("="))
    try:
        return key, float(value)
    except ValueError:
        raise LogError(f"{where}: expected NAME=NUMBER, got {entry.strip()!r}") from None


def format_params(params: Mapping[str, float]) -> str:
    """``{"peak": 20.0}`` -> ``"peak=20"`` (the header form)."""
    return ", ".join(f"{k}={v:g}" for k, v in params.items())


def log_experiment(log: HardwareLog) -> tuple[str, dict[str, float]] | None:
    """The experiment the header names, with its parameters (None: no ``experiment`` header).

    Raises:
        LogError: an unknown experiment or bad parameters, naming the file.
    """
    name = log.meta.get("experiment")
    if name is None:
        return None
    return name, experiment_params(name, log.meta.get("experiment_params"),
                                   f"{log.source}: header 'experiment_params'")


def column_loads(log: HardwareLog) -> tuple[NodeLoad, ...]:
    """The ``load_N/<node>/<axis>`` columns as node loads (an axis not logged is 0 N).

    Raises:
        LogError: a node whose axis columns are not sampled on the same rows, or not at all.
    """
    nodes = list(dict.fromkeys(item.rpartition("/")[0] for item in log.series.items("load")))
    out = []
    for node in nodes:
        columns = np.stack([log.series.channels.get(f"load/{node}/{a}",
                                                    np.full(log.series.time.size, np.nan))
                            for a in AXES], axis=1)
        logged = [a for a in AXES if f"load/{node}/{a}" in log.series.channels]
        sampled = ~np.isnan(columns[:, [AXES.index(a) for a in logged]])
        if (sampled != sampled[:, :1]).any():
            row = int(np.argmax((sampled != sampled[:, :1]).any(axis=1)))
            raise LogError(f"{log.source}: load columns of node {node!r}: expected every axis "
                           f"sampled on the same rows; time {log.series.time[row]:g} s has some "
                           "and not others")
        rows = sampled[:, 0]
        if not rows.any():
            raise LogError(f"{log.source}: load columns of node {node!r}: no sample; expected "
                           "at least one row with a force (0 for none)")
        out.append(NodeLoad(node, log.series.time[rows] - log.start,
                            np.nan_to_num(columns[rows], nan=0.0)))
    return tuple(out)


def replay_loads(log: HardwareLog) -> tuple[NodeLoad, ...]:
    """The loads to replay: the load columns, else the header experiment's, else none."""
    loads = column_loads(log)
    if loads:
        return loads
    named = log_experiment(log)
    return EXPERIMENTS[named[0]].loads(named[1]) if named else ()


def loads_for(log: HardwareLog, structure: Structure) -> tuple[NodeLoad, ...]:
    """:func:`replay_loads`, checked against ``structure``'s nodes.

    Raises:
        LogError: a load on a node ``structure`` lacks, naming the file.
    """
    loads = replay_loads(log)
    nodes = {n.name for n in structure.nodes}
    for load in loads:
        if load.node not in nodes:
            raise LogError(f"{log.source}: a load acts on node {load.node!r}, which "
                           f"{structure.name!r} lacks; expected one of {sorted(nodes)[:6]}...")
    return loads


def load_window(loads: tuple[NodeLoad, ...]) -> tuple[float, float] | None:
    """The time span in which any load is not zero [s] (None: no load ever acts)."""
    spans = []
    for load in loads:
        on = np.abs(load.forces).max(axis=1) > 0
        if not on.any():
            continue
        first, last = int(np.argmax(on)), int(on.size - 1 - np.argmax(on[::-1]))
        start = load.times[max(first - 1, 0)] if first > 0 else -np.inf
        end = load.times[last + 1] if last + 1 < on.size else np.inf
        spans.append((float(start), float(end)))
    if not spans:
        return None
    return min(s for s, _ in spans), max(e for _, e in spans)
