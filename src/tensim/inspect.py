"""What a structure is made of, as plain data: nodes, rods, rigid bodies, cables, motors, gains.

:func:`structure_info` returns a JSON-ready mapping (``tensim info --json`` writes it) and
:func:`format_info` the tables ``tensim info`` prints. Nothing here imports MuJoCo: lengths are
those of the build pose (a cable that wraps around rods has its length only once compiled).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

from tensim.sim import load_cell_tension
from tensim.structure import Cable, Motor, Node, Rod, Structure, mass_properties

MOTOR_SOURCES = {
    "cable": "given with the cable",
    "defaults": "from the file's defaults.cable.motor",
    "none": "no motor: passive",
    "preset": "set by the preset",
    "given": "given in Python",
}


def _round(value: float, digits: int = 6) -> float:
    return round(float(value), digits)


def _motor(motor: Motor) -> dict[str, Any] | None:
    if motor.passive:
        return None
    out: dict[str, Any] = {k: _round(getattr(motor, k)) for k in
                           ("max_speed", "max_tension", "min_rest_length", "min_length")}
    out["kind"] = "kinematic" if motor.dc is None else "dc"
    if motor.dc is not None:
        out["dc"] = {k: v for k, v in dataclasses.asdict(motor.dc).items()}
    return out


def _cable(structure: Structure, cable: Cable, source: str, gains: Any) -> dict[str, Any]:
    build = structure.cable_length(cable) if not cable.wrap else None
    rest = structure.rest_length(cable) if build is not None or cable.rest_length else None
    pretension = None
    if build is not None and rest is not None:
        pretension = float(load_cell_tension(build, rest, cable.stiffness))
    return {
        "name": cable.name, "nodes": list(cable.nodes), "via": list(cable.via),
        "wrap": list(cable.wrap),
        "build_length_m": None if build is None else _round(build),
        "rest_length_m": None if rest is None else _round(rest),
        "pretension_N": None if pretension is None else _round(pretension),
        "stiffness_N_per_m": _round(cable.stiffness),
        "damping_N_s_per_m": _round(cable.damping),
        "motor": _motor(cable.motor), "motor_source": source,
        "gains": None if gains is None else {k: _round(v) for k, v in
                                              dataclasses.asdict(gains).items()},
        "tags": list(cable.tags),
    }


def structure_info(structure: Structure, gains: Mapping[str, Any] | None = None,
                   motor_sources: Mapping[str, str] | None = None,
                   controller: str | None = None) -> dict[str, Any]:
    """The structure as plain data (SI units in the key names).

    Args:
        structure: the robot in its build pose.
        gains: cable name -> :class:`~tensim.control.ImpedanceGains` of its controller (None:
            no controller); cables not in it are listed without gains.
        motor_sources: cable name -> where its motor came from (a key of
            :data:`MOTOR_SOURCES`, as :func:`tensim.structure.motor_sources` gives for a file);
            None: ``"given"`` for every cable.
        controller: what the gains come from, for the record.
    """
    sources = motor_sources or {}
    bodies = []
    for group in structure.rigid_groups():
        mass = mass_properties(structure, group)
        bodies.append({"name": group.name, "rods": list(group.rods), "nodes": list(group.nodes),
                       "fixed": group.fixed, "mass_kg": _round(mass.mass),
                       "com_m": [_round(x) for x in mass.com]})
    cables = [_cable(structure, c, sources.get(c.name, "given"),
                     (gains or {}).get(c.name)) for c in structure.cables]
    tags: dict[str, list[str]] = {}
    named: list[Node | Rod | Cable] = [*structure.nodes, *structure.rods, *structure.cables]
    for item in named:
        for tag in item.tags:
            tags.setdefault(tag, []).append(item.name)
    return {
        "name": structure.name,
        "total_mass_kg": _round(structure.total_mass()),
        "nodes": [{"name": n.name, "position_m": [_round(x) for x in n.position],
                   "fixed": n.fixed, "tags": list(n.tags)} for n in structure.nodes],
        "rods": [{"name": r.name, "nodes": list(r.nodes), "radius_m": _round(r.radius),
                  "length_m": _round(structure.distance(*r.nodes)), "tags": list(r.tags)}
                 for r in structure.rods],
        "rigid_bodies": bodies,
        "cables": cables,
        "motorised_cables": [c["name"] for c in cables if c["motor"] is not None],
        "tags": tags,
        "controller": controller,
        "controlled_cables": [c["name"] for c in cables if c["gains"] is not None],
    }


def _value(x: float | None, fmt: str = "8.4f") -> str:
    return f"{'-':>8}" if x is None else format(x, fmt)


def _motor_text(cable: dict[str, Any]) -> str:
    motor = cable["motor"]
    if motor is None:
        return "passive"
    kind = "DC" if motor["kind"] == "dc" else f"kinematic {motor['max_speed']:g} m/s"
    return f"{kind}, {motor['max_tension']:g} N ({cable['motor_source']})"


def _gains_text(gains: dict[str, float] | None) -> str:
    if gains is None:
        return "-"
    return (f"T0 {gains['offset_tension']:g} N, K {gains['stiffness_gain']:g} N/m, "
            f"B {gains['damping_gain']:g} N s/m, L* {gains['target_length']:.4f} m")


def format_info(info: dict[str, Any]) -> str:
    """The tables ``tensim info`` prints for :func:`structure_info`'s mapping."""
    lines = [f"{info['name']}: {len(info['nodes'])} nodes, {len(info['rods'])} rods, "
             f"{len(info['rigid_bodies'])} rigid bodies, {len(info['cables'])} cables "
             f"({len(info['motorised_cables'])} motorised), {info['total_mass_kg']:.4g} kg",
             "", "nodes [m]:"]
    w = max((len(x["name"]) for key in ("nodes", "rods", "rigid_bodies", "cables")
             for x in info[key]), default=8)
    wn = max((len(n["name"]) for n in info["nodes"]), default=4)
    for n in info["nodes"]:
        x, y, z = n["position_m"]
        extra = " fixed" if n["fixed"] else ""
        lines.append(f"  {n['name']:<{w}} {x:8.4f} {y:8.4f} {z:8.4f}{extra}  "
                     f"{' '.join(n['tags'])}")
    lines += ["", "rods:"]
    for r in info["rods"]:
        lines.append(f"  {r['name']:<{w}} {r['nodes'][0]} - {r['nodes'][1]}, "
                     f"{r['length_m']:.4f} m, radius {r['radius_m']:g} m")
    lines += ["", "rigid bodies (mass [kg], centre of mass [m]):"]
    for b in info["rigid_bodies"]:
        com = " ".join(f"{x:8.4f}" for x in b["com_m"])
        fixed = " fixed" if b["fixed"] else ""
        lines.append(f"  {b['name']:<{w}} {b['mass_kg']:8.4f}  {com}  nodes "
                     f"{', '.join(b['nodes'])}{fixed}")
    lines += ["", "cables (build and rest length [m], pretension [N], k [N/m], b [N s/m], "
              "motor):"]
    for c in info["cables"]:
        ends = f"{c['nodes'][0]} - {c['nodes'][1]}"
        lines.append(f"  {c['name']:<{w}} {ends:<{2 * wn + 3}} {_value(c['build_length_m'])} "
                     f"{_value(c['rest_length_m'])} {_value(c['pretension_N'], '8.3f')} "
                     f"{c['stiffness_N_per_m']:8g} {c['damping_N_s_per_m']:6g}  "
                     f"{_motor_text(c)}")
    if info["controller"] is None:
        lines += ["", "controller: none (tensim controller init writes one)"]
    else:
        lines += ["", f"controller: {info['controller']}"]
        for c in info["cables"]:
            if c["motor"] is not None:
                lines.append(f"  {c['name']:<{w}} {_gains_text(c['gains'])}")
    if info["tags"]:
        lines += ["", "tags:"]
        wt = max(len(tag) for tag in info["tags"])
        for tag, names in info["tags"].items():
            lines.append(f"  {tag:<{wt}} {', '.join(names)}")
    return "\n".join(lines)
