"""Building a rolling robot as it rests: a face turned down, and its static pose on the ground.

A robot built in its self-stressed form and set down sags onto its feet and, where the ground
must push sideways to hold it (friction), creeps under MuJoCo's soft contacts. Built in the
static pose on frictionless feet, it stands still as built.

The shipped rolling presets, built with their default arguments, take that pose from a file
(``standing/<preset>.json``, written by ``tools/standing_poses.py``) instead of solving it at
every load: their rolling runs are chaotic, so a solve that moved the pose by round-off (a
change in the design tools, another numpy or LAPACK build) moved every rolling figure.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from tensim._input import InputError, describe, is_real, load_json, read_text
from tensim.structure import Structure, StructureError

STORED = Path(__file__).resolve().parent / "standing"  # the stored poses, one file a preset
REGENERATE = "python tools/standing_poses.py --write"
# how far a stored file's rest lengths may be from the preset's as built [m]: round-off only
# (the file is read for the self-stressed form in another placement than it was solved in)
REST_TOLERANCE = 1e-9


def face_down(nodes: dict[str, np.ndarray], face: tuple[str, str, str], lift: float
              ) -> dict[str, np.ndarray]:
    """``nodes`` [m] turned so that ``face``'s outward normal points straight down, the centre
    of the nodes over the origin and the lowest node ``lift`` metres up."""
    a, b, c = (nodes[n] for n in face)
    normal = np.cross(b - a, c - a)
    centre = np.mean(list(nodes.values()), axis=0)
    if normal @ (a - centre) < 0:
        normal = -normal
    # scipy loads here, not with the preset registry (0.25 s and 30 MiB of every command)
    from scipy.spatial.transform import Rotation

    turn, _ = Rotation.align_vectors([[0.0, 0.0, -1.0]], [normal / np.linalg.norm(normal)])
    turned = {n: turn.apply(p - centre) for n, p in nodes.items()}
    lowest = min(p[2] for p in turned.values())
    return {n: p + np.array([0.0, 0.0, lift - lowest]) for n, p in turned.items()}


def lying(structure: Structure, face: tuple[str, str, str], lift: float) -> Structure:
    """``structure`` with its nodes moved as :func:`face_down` moves them (a rigid motion: its
    cables keep their pretensions and, round-off aside, their rest lengths)."""
    moved = face_down({n.name: np.array(n.position) for n in structure.nodes}, face, lift)
    return dataclasses.replace(structure, nodes=tuple(
        dataclasses.replace(n, position=tuple(moved[n.name])) for n in structure.nodes))


def standing(structure: Structure) -> Structure:
    """``structure`` in its static pose under gravity on its lowest nodes, as on frictionless
    ground (the ground pushes only straight up; :func:`tensim.design.inverse.settle` with
    ``sliding``), its cables given the rest lengths of their pretensions: so it stands still as
    built instead of sagging onto its feet first or creeping on friction."""
    from tensim.design.inverse import feet, settle, with_rest_lengths

    rest = np.array([structure.rest_length(c) for c in structure.cables])
    explicit = with_rest_lengths(structure, rest)
    return settle(explicit, feet(explicit), sliding=True).pose


def pose_record(pose: Structure) -> dict[str, Any]:
    """The mapping a stored pose file holds for ``pose`` (a preset standing): its node
    positions [m] and cable rest lengths [m]. JSON writes each float as its shortest repr,
    which reads back as the same float, so the file keeps the pose bit for bit."""
    return {
        "about": f"the static pose of the preset {pose.name} standing, written by {REGENERATE}",
        "structure": pose.name,
        "nodes": {n.name: list(n.position) for n in pose.nodes},
        "rest_lengths": {c.name: pose.rest_length(c) for c in pose.cables},
    }


def stored_standing(form: Structure) -> Structure:
    """``form`` (a shipped preset's self-stressed form, in any placement) in its standing pose
    as stored in ``standing/<form.name>.json``: the file's node positions and rest lengths,
    bit for bit, and ``form``'s everything else (rods, masses, stiffness, motors...).

    Raises:
        StructureError: naming the file: missing or unreadable, not the expected mapping, or
            made for another structure (other nodes or cables, or a rest length more than
            :data:`REST_TOLERANCE` from ``form``'s: regenerate the files).
    """
    path = STORED / f"{form.name}.json"
    try:
        data = load_json(read_text(path), str(path))
    except (OSError, InputError) as err:
        raise StructureError(f"{err}; the preset {form.name!r} reads its standing pose from "
                             f"this file, which ships with tensim (a developer writes it with "
                             f"{REGENERATE})") from None
    positions, rest = _parse(data, form, str(path))
    for cable in form.cables:
        built = form.rest_length(cable)
        if abs(rest[cable.name] - built) > REST_TOLERANCE:
            raise StructureError(
                f"made for another {form.name}: cable {cable.name!r} has rest length "
                f"{rest[cable.name]!r} m in the file and {built!r} m as built; regenerate the "
                f"stored poses with {REGENERATE}", source=str(path))
    return dataclasses.replace(
        form,
        nodes=tuple(dataclasses.replace(n, position=positions[n.name]) for n in form.nodes),
        cables=tuple(dataclasses.replace(c, rest_length=rest[c.name], pretension=None)
                     for c in form.cables))


def _parse(data: Any, form: Structure, source: str
           ) -> tuple[dict[str, tuple[float, float, float]], dict[str, float]]:
    """The node positions and rest lengths of a stored pose file's mapping, checked."""
    def fail(item: str, message: str) -> StructureError:
        return StructureError(f"{message}; regenerate the stored poses with {REGENERATE}",
                              item=item, source=source)

    expected = {"about", "structure", "nodes", "rest_lengths"}
    if not isinstance(data, dict) or set(data) != expected:
        got = sorted(data) if isinstance(data, dict) else describe(data)
        raise fail("", f"expected a mapping with the keys {sorted(expected)}, got {got}")
    if data["structure"] != form.name:
        raise fail("structure", f"expected {form.name!r}, got {describe(data['structure'])}")
    positions = _named(data["nodes"], [n.name for n in form.nodes], "nodes", fail)
    rest = _named(data["rest_lengths"], [c.name for c in form.cables], "rest_lengths", fail)
    for name, value in positions.items():
        if not (isinstance(value, list) and len(value) == 3 and all(map(is_real, value))):
            raise fail(f"nodes.{name}", f"expected three finite numbers [m], got "
                       f"{describe(value)}")
    for name, value in rest.items():
        if not (is_real(value) and value > 0):
            raise fail(f"rest_lengths.{name}", f"expected a positive number [m], got "
                       f"{describe(value)}")
    return ({n: (float(p[0]), float(p[1]), float(p[2])) for n, p in positions.items()},
            {n: float(r) for n, r in rest.items()})


def _named(value: Any, names: list[str], field: str, fail: Any) -> dict[str, Any]:
    """``value``, checked to be a mapping over exactly ``names``."""
    if not isinstance(value, dict):
        raise fail(field, f"expected a mapping of names, got {describe(value)}")
    missing, extra = sorted(set(names) - set(value)), sorted(set(value) - set(names))
    if missing or extra:
        raise fail(field, f"expected exactly the structure's names; missing {missing}, "
                   f"unknown {extra}")
    return value
