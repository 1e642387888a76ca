"""Writes a compiled model as MJCF, so other MuJoCo tools (viewers, MJX, other simulators' MJCF
importers) can open it.

The XML holds everything MuJoCo itself knows: bodies, inertias, rod and mass geoms, contact
settings, the cables' spatial tendons (with their via sites) and one plain tendon actuator per
cable (ctrl = the signed tendon force, -tension [N]). It cannot hold the cable law and the
motors, which tensim runs in its own compiled actuator callbacks. With ``springs=True`` (the
default) each tendon gets MuJoCo's own spring as a stand-in: stiffness k, damping b and a dead
band [0, rest length], so that, like the cable, it pulls only while stretched past its rest
length, with k (x - l) + b dx/dt.
Two differences remain: MuJoCo damps a slack tendon too (the cable law does not), and the rest
lengths stay fixed (no motors, no controller). MuJoCo writes numbers with 6 significant digits.

Each cable actuator's ``user`` numbers carry the cable as tensim has it (stiffness, damping,
rest length and motor, in the order the custom text ``tensim_cable_user`` names), each rod and
mass geom its own mass, and a hidden site ``node_<name>`` marks each node, so that
``tensim import-mjcf`` reads the structure back as it was; other tools ignore them.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import mujoco

from tensim._files import write_text
from tensim.io._mjcf_motors import MOTOR_KIND, NODE_SITE, USER_FIELDS, USER_TEXT
from tensim.model import CompiledModel, compile_spec, without_cable_law
from tensim.structure import Cable, Structure

_COMMENT = ("Written by tensim from structure {name!r}. Each cable is a spatial tendon plus a "
            "tendon actuator (ctrl = -tension [N]); tensim computes the tension in its cable law. "
            "{springs}")
_SPRINGS = ("The tendon springs (stiffness, damping, springlength dead band [0, rest length]) "
            "stand in for the tension-only cable law, with the build-time rest lengths.")
_NO_SPRINGS = "Without tensim the tendons are slack unless their actuators are driven."


def mjcf_spec(compiled: CompiledModel, *, springs: bool = True) -> mujoco.MjSpec:
    """A copy of the model's ``MjSpec``, with tendon springs standing in for the cables.

    Args:
        compiled: the compiled model.
        springs: give each cable's tendon MuJoCo's spring-damper (see the module docstring).
    """
    spec = without_cable_law(compiled)
    spec.comment = _COMMENT.format(name=compiled.structure.name,
                                   springs=_SPRINGS if springs else _NO_SPRINGS)
    _geom_masses(spec, compiled.structure)
    _node_sites(spec, compiled)
    spec.add_text(name=USER_TEXT, data=" ".join(USER_FIELDS))
    for actuator, cable, rest in zip(spec.actuators, compiled.structure.cables,
                                     compiled.rest_length, strict=False):
        actuator.userdata = _user(cable, float(rest))
    if springs:
        law = compiled.law()
        for name, k, b, rest in zip(compiled.index.cables, law.stiffness, law.damping,
                                    compiled.rest_length, strict=True):
            tendon = spec.tendon(name)
            tendon.stiffness = [float(k), 0.0, 0.0]
            tendon.damping = [float(b), 0.0, 0.0]
            tendon.springlength = [0.0, float(rest)]  # dead band: no force below the rest length
    return spec


def _geom_masses(spec: mujoco.MjSpec, structure: Structure) -> None:
    """Gives each rod and point-mass geom its own mass, so that the file says how a body's mass
    is shared; the bodies' inertials hold the sums (``inertiafromgeom="false"``: MuJoCo's
    writer keeps geom masses only then)."""
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    for body in spec.bodies:  # the inertial still holds: the compiler takes no other
        body.explicitinertial = False
    for rod in structure.rods:
        spec.geom(rod.name).mass = rod.mass_per_length() * structure.distance(*rod.nodes)
    for mass in structure.point_masses:
        geom = spec.geom(f"mass_{mass.node}")
        if geom is not None:
            geom.mass = mass.mass


def _node_sites(spec: mujoco.MjSpec, compiled: CompiledModel) -> None:
    """A hidden site ``node_<name>`` at every node, so that an import names the nodes as the
    structure did."""
    m, index = compiled.model, compiled.index
    for node in compiled.structure.nodes:
        body = index.node_body[node.name]
        parent = spec.worldbody if body == 0 else spec.body(m.body(body).name)
        parent.add_site(name=f"{NODE_SITE}{node.name}", pos=index.node_local[node.name].tolist(),
                        size=[0.001, 0, 0], group=5)


def _user(cable: Cable, rest_length: float) -> list[float]:
    """The cable's numbers in the order of ``USER_FIELDS``."""
    motor = cable.motor
    kind = "passive" if motor.passive else "kinematic" if motor.dc is None else "dc"
    values = {"motor": MOTOR_KIND[kind], "stiffness": cable.stiffness, "damping": cable.damping,
              "rest_length": rest_length, "max_speed": motor.max_speed,
              "max_tension": motor.max_tension, "min_rest_length": motor.min_rest_length,
              "min_length": motor.min_length, "lag_time": motor.lag_time,
              "saturate": float(motor.saturate), "pd_stiffness": motor.pd_stiffness,
              "pd_damping": motor.pd_damping, "pd_target": motor.pd_target or 0.0}
    if motor.dc is not None:
        values.update({k: float(v) for k, v in dataclasses.asdict(motor.dc).items()})
    return [float(values.get(field, 0.0)) for field in USER_FIELDS]


def to_mjcf(compiled: CompiledModel, *, springs: bool = True) -> str:
    """The model as an MJCF document (see :func:`mjcf_spec`)."""
    spec = mjcf_spec(compiled, springs=springs)
    compile_spec(spec)  # the XML writer needs a compiled spec
    return spec.to_xml()


def save_mjcf(compiled: CompiledModel, path: str | os.PathLike[str], *,
              springs: bool = True) -> Path:
    """Writes the model as an MJCF file, atomically; returns the path."""
    path = Path(path)
    write_text(path, to_mjcf(compiled, springs=springs))
    return path
