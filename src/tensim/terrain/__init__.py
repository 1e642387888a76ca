"""Terrain: the ground a robot is placed on, as plain validated data, and its MuJoCo shapes.

Kinds: :class:`Flat` (the default), :class:`Slope`, :class:`Hills`, :class:`Rough`,
:class:`Stairs`, :class:`Blocks`, :class:`Wall` and :class:`HeightField` (from an image or
array file), each with its own friction and restitution. :func:`parse_terrain` reads the
``--terrain NAME[:key=value,...]`` strings; ``WorldOptions(terrain=...)`` puts a robot on one.
"""

from tensim.terrain._build import add_terrain, contact_parameters, restitution_dampratio
from tensim.terrain._errors import TerrainError
from tensim.terrain._geometry import Box, Geometry, Grid
from tensim.terrain._kinds import (
    KINDS,
    Blocks,
    Flat,
    HeightField,
    Hills,
    Rough,
    Slope,
    Stairs,
    Surface,
    Terrain,
    Wall,
)
from tensim.terrain._parse import format_terrain, parse_terrain
from tensim.terrain._place import footprint_height, place_on_terrain

__all__ = [
    "KINDS",
    "Blocks",
    "Box",
    "Flat",
    "Geometry",
    "Grid",
    "HeightField",
    "Hills",
    "Rough",
    "Slope",
    "Stairs",
    "Surface",
    "Terrain",
    "TerrainError",
    "Wall",
    "add_terrain",
    "contact_parameters",
    "footprint_height",
    "format_terrain",
    "parse_terrain",
    "place_on_terrain",
    "restitution_dampratio",
]
