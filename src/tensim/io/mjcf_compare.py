"""Runs an imported MJCF robot in tensim beside MuJoCo's own run of the file, and measures how
far apart their nodes get: the check that an import means what the file meant.

Both start from the file's pose with its initial controls (the first keyframe's, else 0); the
given controls are applied from the start, to MuJoCo as ``ctrl`` and to tensim as the
rest-length commands their actuator mappings give. tensim's run keeps the file's thin-rod
inertia (``min_inertia_ratio=0``), so that only the cable and motor laws differ.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping

import mujoco
import numpy as np

from tensim.io.mjcf_import import MjcfImport, import_mjcf
from tensim.model import compile_structure
from tensim.sim import Simulation


@dataclasses.dataclass(frozen=True)
class Agreement:
    """How closely tensim's run of an import follows MuJoCo's run of the file.

    Attributes:
        duration: time compared [s].
        max_difference: largest distance between a node in tensim and its site (or sphere,
            or rod end) in MuJoCo, over the samples [m].
        final_difference: the same at the end [m].
        max_displacement: largest distance a node moved from its start in MuJoCo's run [m].
    """

    duration: float
    max_difference: float
    final_difference: float
    max_displacement: float


def compare_with_mujoco(path: str | os.PathLike[str], duration: float = 3.0,
                        controls: Mapping[str, float] | None = None,
                        sample_period: float = 0.05) -> Agreement:
    """Simulates the file with MuJoCo and its import with tensim for ``duration`` seconds.

    Args:
        path: the MJCF file.
        duration: time to compare [s].
        controls: actuator name -> ctrl held from the start (others keep their start values).
        sample_period: time between compared samples [s].

    Raises:
        KeyError: a control names no actuator of the file.
        ValueError: a control of an actuator whose ctrl is a rate or that maps to no motor.
    """
    result = import_mjcf(path, warn=False)
    compiled = compile_structure(result.structure,
                                 dataclasses.replace(result.world, min_inertia_ratio=0.0))
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    if m.nkey:
        d.ctrl[:], d.act[:] = m.key_ctrl[0], m.key_act[0]
    with Simulation(compiled) as sim:
        for name, u in (controls or {}).items():
            cable = compiled.index.cable_id(_cable(result, name))
            sim.drive.rest_command[cable] = _rest(result, name, u)
            d.actuator(name).ctrl = u
        reference = _positions(result, sim, m, d)[1]
        steps = max(1, round(sample_period / sim.dt))
        differences, moved = [], 0.0
        for _ in range(max(1, round(duration / (steps * sim.dt)))):
            sim.step(steps)
            while d.time < sim.data.time - 1e-9:
                mujoco.mj_step(m, d)
            ours, theirs = _positions(result, sim, m, d)
            differences.append(float(np.linalg.norm(ours - theirs, axis=1).max()))
            moved = max(moved, float(np.linalg.norm(theirs - reference, axis=1).max()))
        return Agreement(sim.time, max(differences), differences[-1], moved)


def _cable(result: MjcfImport, actuator: str) -> str:
    for mapping in result.actuators:
        if mapping.actuator == actuator:
            return mapping.cable
    raise KeyError(f"no actuator {actuator!r} in {result.source}; actuators: "
                   f"{[a.actuator for a in result.actuators]}")


def _rest(result: MjcfImport, actuator: str, u: float) -> float:
    mapping = next(a for a in result.actuators if a.actuator == actuator)
    if mapping.command is None or mapping.command.rate:
        raise ValueError(f"actuator {actuator!r} ({mapping.kind}): its control is not a target "
                         "that maps to a rest length")
    return mapping.command.offset + mapping.command.scale * u


def _positions(result: MjcfImport, sim: Simulation, m: mujoco.MjModel,
               d: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
    """(n_nodes, 3) node positions in tensim's run and in MuJoCo's (the sites, sphere centres
    or rod ends the nodes came from) [m]."""
    mujoco.mj_kinematics(m, d)
    index = sim.compiled.index
    ours, theirs = [], []
    for node in result.structure.nodes:
        body = index.node_body[node.name]
        ours.append(sim.data.xpos[body] + sim.data.xmat[body].reshape(3, 3)
                    @ index.node_local[node.name])
        theirs.append(_file_point(result, node.name, m, d))
    return np.array(ours), np.array(theirs)


def _file_point(result: MjcfImport, node: str, m: mujoco.MjModel,
                d: mujoco.MjData) -> np.ndarray:
    """Where the file's body carries a node now: the node's build position moved with the body
    that held it in the file."""
    body, local = result.node_frames[node]
    return d.xpos[body] + d.xmat[body].reshape(3, 3) @ local
