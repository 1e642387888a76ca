"""``NAME[:key=value,...]`` terrain strings, as given to ``--terrain``, and back."""

from __future__ import annotations

import dataclasses
import math
import typing
from typing import Any

from tensim.terrain._errors import TerrainError
from tensim.terrain._kinds import KINDS, Surface, Terrain


def parse_terrain(text: str) -> Terrain:
    """The terrain a string such as ``"hills:height=0.1,wavelength=2"`` describes.

    The name is a kind (``flat``, ``slope``, ``hills``, ``rough``, ``stairs``, ``blocks``,
    ``wall``, ``heightfield``); the keys are that kind's fields (SI units, angles in degrees),
    ``friction`` and ``restitution`` for every kind.

    Raises:
        TerrainError: unknown kind or key, a value of the wrong type, or an invalid value; the
            message quotes the string and lists what is expected.
    """
    name, _, rest = text.strip().partition(":")
    name = name.strip().lower()
    cls = KINDS.get(name)
    if cls is None:
        raise TerrainError(f"terrain {text!r}: unknown kind {name!r}; expected one of "
                           f"{', '.join(KINDS)}")
    hints = typing.get_type_hints(cls)
    fields = [f.name for f in _fields(cls)]
    values: dict[str, Any] = {}
    for item in filter(None, (p.strip() for p in rest.split(","))):
        key, eq, raw = (s.strip() for s in item.partition("="))
        if not eq or not raw:
            raise TerrainError(f"terrain {text!r}: expected key=value, got {item!r}")
        if key not in fields:
            raise TerrainError(f"terrain {text!r}: unknown key {key!r} for {name}; expected "
                               f"one of {', '.join(fields)}")
        if key in values:
            raise TerrainError(f"terrain {text!r}: {key!r} given twice")
        values[key] = _convert(raw, hints[key], f"terrain {text!r}: {key}")
    try:
        return cls(**values)
    except TerrainError as err:
        raise TerrainError(f"{err} (in {text!r})") from None


def format_terrain(terrain: Terrain) -> str:
    """The string :func:`parse_terrain` reads back as ``terrain``, every field spelt out
    (unset contact parameters left out)."""
    items = []
    for field in _fields(type(terrain)):
        value = getattr(terrain, field.name)
        if value is not None:
            items.append(f"{field.name}={value}")
    return terrain.kind + (":" + ",".join(items) if items else "")


def _fields(cls: type) -> list[dataclasses.Field]:
    """The kind's own fields, then the contact parameters every kind shares."""
    shared = {f.name for f in dataclasses.fields(Surface)}
    every = dataclasses.fields(cls)
    return [f for f in every if f.name not in shared] + [f for f in every if f.name in shared]


def _convert(raw: str, hint: object, where: str) -> object:
    """``raw`` as the field's type (int, float, str, or one of them or None)."""
    kinds = typing.get_args(hint) or (hint,)
    if str in kinds:
        return raw
    if int in kinds:
        try:
            return int(raw)
        except ValueError:
            raise TerrainError(f"{where} expects an integer, got {raw!r}") from None
    try:
        value = float(raw)
    except ValueError:
        raise TerrainError(f"{where} expects a number, got {raw!r}") from None
    if not math.isfinite(value):
        raise TerrainError(f"{where} expects a finite number, got {raw!r}")
    return value
