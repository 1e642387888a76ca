"""Reading and writing structures as YAML files.

The file is a mapping with ``name``, ``nodes``, ``rods``, ``cables``, ``point_masses`` (lists of
mappings whose keys are the record fields) and an optional ``defaults`` mapping with ``rod``,
``cable`` and ``point_mass`` entries merged under every item of that kind. Cables take a nested
``motor`` mapping (in it, a ``dc`` mapping for a DC motor; a cable with no ``motor``, here or in
``defaults``, is passive: no motor winds it), when routed a ``via`` list of the
nodes they pass through, and a ``contact`` that is ``true`` or a mapping of
:class:`CableContact` fields. Rods may give a ``section`` mapping (:class:`RodSection`) and
cables a ``breaking_load``, for member checks. All values are SI units (the README lists every
field).
"""

from __future__ import annotations

import dataclasses
import functools
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from tensim._files import write_text
from tensim._input import InputError, describe, load_yaml_file
from tensim.structure._emit import block_yaml
from tensim.structure._errors import StructureError
from tensim.structure._records import (
    PASSIVE,
    Cable,
    CableContact,
    DCMotor,
    Motor,
    Node,
    PointMass,
    Rod,
    RodSection,
)
from tensim.structure._structure import Structure

_SECTIONS = {"nodes": Node, "rods": Rod, "cables": Cable, "point_masses": PointMass}
_DEFAULTS = {"rod": "rods", "cable": "cables", "point_mass": "point_masses"}
_TOP = {"name", "defaults", *_SECTIONS}
MAX_ITEMS = 10_000  # most nodes, rods, cables or point masses a structure file may list


def _fields(cls: type) -> list[str]:
    return [f.name for f in dataclasses.fields(cls)]


def _build(cls: type, raw: Any, item: str) -> Any:
    if not isinstance(raw, dict):
        raise StructureError(f"expected a mapping of {_fields(cls)}, got {describe(raw)}",
                             item=item)
    unknown = sorted(set(raw) - set(_fields(cls)))
    if unknown:
        raise StructureError(f"unknown field {unknown[0]!r}; expected one of {_fields(cls)}",
                             item=item)
    values = dict(raw)
    if cls is Cable:  # no motor given, here or in the defaults: a passive cable
        motor = values.get("motor")
        values["motor"] = PASSIVE if motor is None else _build(Motor, motor, f"{item} motor")
    if cls is Motor and values.get("dc") is not None:
        values["dc"] = _build(DCMotor, values["dc"], f"{item} dc")
    if cls is Rod and isinstance(values.get("section"), dict):
        values["section"] = _build(RodSection, values["section"], f"{item} section")
    if cls is Cable and isinstance(values.get("contact"), dict):
        values["contact"] = _build(CableContact, values["contact"], f"{item} contact")
    try:
        return cls(**values)
    except StructureError as err:  # a nested record has no name of its own: name it by its path
        nested = cls in (Motor, DCMotor, CableContact, RodSection) or err.item in (
            "motor", "contact", "section")
        raise StructureError(err.detail, item=item if nested else err.item or item) from None
    except TypeError as err:  # a required field is missing
        raise StructureError(f"{err}; expected fields {_fields(cls)}", item=item) from None


def _merge(default: dict[str, Any], raw: Any) -> Any:
    if not isinstance(raw, dict):
        return raw
    merged = {**default, **raw}
    if isinstance(default.get("motor"), dict) and isinstance(raw.get("motor"), dict):
        merged["motor"] = _merge(default["motor"], raw["motor"])
    if isinstance(default.get("section"), dict) and isinstance(raw.get("section"), dict):
        merged["section"] = {**default["section"], **raw["section"]}
    if isinstance(default.get("dc"), dict) and isinstance(raw.get("dc"), dict):
        merged["dc"] = {**default["dc"], **raw["dc"]}
    return merged


def structure_from_dict(data: Any) -> Structure:
    """Builds a structure from the plain mapping a YAML file holds.

    Raises:
        StructureError: naming the item and what was expected.
    """
    if not isinstance(data, dict):
        raise StructureError("expected a mapping with 'name', 'nodes', 'rods', 'cables'")
    unknown = sorted(set(data) - _TOP)
    if unknown:
        raise StructureError(f"unknown top-level field {unknown[0]!r}; expected {sorted(_TOP)}")
    name = data.get("name", "structure")
    if not isinstance(name, str) or not name:
        raise StructureError(f"name must be a non-empty string, got {describe(name)}",
                             item="name")
    defaults = data.get("defaults") or {}
    if not isinstance(defaults, dict) or not all(isinstance(d, dict) for d in defaults.values()):
        raise StructureError("defaults must map 'rod', 'cable' or 'point_mass' to a mapping of "
                             f"fields, got {describe(defaults)}", item="defaults")
    bad = sorted(set(defaults) - set(_DEFAULTS))
    if bad:
        raise StructureError(f"unknown defaults entry {bad[0]!r}; expected {sorted(_DEFAULTS)}")
    sections: dict[str, tuple[Any, ...]] = {}
    for section, cls in _SECTIONS.items():
        items = data.get(section) or []
        if not isinstance(items, list):
            raise StructureError(f"'{section}' must be a list of mappings, got "
                                 f"{describe(items)}")
        if len(items) > MAX_ITEMS:
            raise StructureError(f"{len(items)} {section} is more than the limit of "
                                 f"{MAX_ITEMS}", item=section)
        default: dict[str, Any] = next(
            (d for k, d in defaults.items() if _DEFAULTS[k] == section), {})
        sections[section] = tuple(
            _build(cls, _merge(default, raw), f"{section}[{i}]"
                   + (f" {raw.get('name')!r}" if isinstance(raw, dict) and "name" in raw else ""))
            for i, raw in enumerate(items)
        )
    return Structure(name=name, **sections)


def structure_to_dict(structure: Structure) -> dict[str, Any]:
    """The plain mapping written to YAML (lists instead of tuples, no None fields)."""

    def plain(record: Any) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for key, value in _as_dict(record).items():
            if value is None or value == ():
                continue
            if key == "motor" and value.get("passive"):
                continue  # a passive cable is one without a motor
            if isinstance(value, dict):  # a nested record (motor, contact): drop its Nones
                # (and the options that are off, so files without them stay as they were)
                value = {k: v for k, v in value.items()
                         if v is not None and not (k == "passive" and v is False)
                         and not (k == "lag_time" and v == 0.0)
                         and not (k == "saturate" and v is False)
                         and not (k in ("pd_stiffness", "pd_damping") and v == 0.0)}
            out[key] = [list(v) if isinstance(v, tuple) else v for v in value] \
                if isinstance(value, tuple) else value
        return out

    return {
        "name": structure.name,
        **{section: [plain(r) for r in getattr(structure, section)] for section in _SECTIONS},
    }


def _as_dict(value: Any) -> Any:
    """``dataclasses.asdict`` for a structure's records, without its deep copy of every value
    (they are numbers and strings; the copy was most of a large robot's conversion)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {name: _as_dict(getattr(value, name)) for name in _field_names(type(value))}
    if type(value) in (list, tuple):
        return type(value)(_as_dict(v) for v in value)
    if type(value) is dict:
        return {_as_dict(k): _as_dict(v) for k, v in value.items()}
    return value


@functools.cache
def _field_names(cls: type) -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(cls))


def motor_sources(data: Any) -> dict[str, str]:
    """Where each cable of a structure mapping got its motor: ``"cable"`` (its own
    ``motor``), ``"defaults"`` (the file's ``defaults.cable.motor``) or ``"none"`` (passive).

    Args:
        data: the mapping a structure file holds (valid: :func:`structure_from_dict` accepts it).
    """
    default = ((data.get("defaults") or {}).get("cable") or {}).get("motor")
    sources = {}
    for raw in data.get("cables") or []:
        if raw.get("motor") is not None:
            sources[raw["name"]] = "cable"
        else:
            sources[raw["name"]] = "defaults" if default is not None else "none"
    return sources


def load_structure(path: str | os.PathLike[str]) -> Structure:
    """Reads a structure from a YAML file.

    Raises:
        StructureError: naming the file, the item and what was expected (also for a file that
            is not UTF-8 YAML, has a duplicate key, or is too deep or too large).
        FileNotFoundError: no such file.
    """
    path = Path(path)
    try:
        data = load_yaml_file(path)
    except InputError as err:  # the message names the file already
        raise StructureError(str(err)) from None
    try:
        return structure_from_dict(data)
    except StructureError as err:
        raise err.with_source(str(path)) from None


def save_structure(structure: Structure, path: str | os.PathLike[str],
                   header: Sequence[str] = ()) -> None:
    """Writes a structure to a YAML file atomically (never a half-written file).

    Args:
        structure: the structure.
        path: the file to write.
        header: lines written first as YAML comments (where the structure came from).
    """
    comments = "".join(f"# {line}\n" for text in header for line in str(text).splitlines())
    data = structure_to_dict(structure)
    text = block_yaml(data)  # PyYAML's text, written directly where it can be
    if text is None:
        text = yaml.dump(data, Dumper=_SafeDumper, sort_keys=False)
    write_text(Path(path), comments + text)


# libyaml's emitter where PyYAML has it: the same text as yaml.safe_dump, 4x faster (a robot of
# hundreds of cables writes half a megabyte)
_SafeDumper: type[yaml.SafeDumper] = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
