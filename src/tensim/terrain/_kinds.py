"""Terrain descriptions: plain, validated records, one per kind of ground.

Every kind carries the contact parameters of its surface: ``friction`` (Coulomb coefficient of
a robot-terrain contact) and ``restitution``. Left unset (None), contacts use each rod's own
friction and restitution, as on the default flat ground, so a preset's calibrated friction
holds on any terrain. Set, the terrain's values replace the robot's in every robot-terrain
contact (the terrain geoms then outrank the robot's in MuJoCo's ``priority``).

Features are placed ahead of a robot built at the origin facing +x (slope, stairs, blocks, wall
start at x > 0); height fields cover the origin, and the robot is lifted onto them (see
:func:`~tensim.terrain.place_on_terrain`). Lengths in metres, angles in degrees.
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

import numpy as np

from tensim._input import is_real
from tensim.limits import MAX_GRID_CELLS, MAX_TERRAIN_BOXES
from tensim.terrain._errors import TerrainError
from tensim.terrain._fields import hills_grid, load_grid, rough_grid
from tensim.terrain._geometry import Box, Geometry, Grid

FAR = 50.0  # m, half extent of "endless" boxes
THICKNESS = 1.0  # m, depth of boxes that carry a surface


@dataclasses.dataclass(frozen=True, kw_only=True)
class Surface:
    """Contact parameters shared by every kind of terrain.

    Attributes:
        friction: Coulomb friction coefficient of robot-terrain contacts; None keeps each
            rod's own.
        restitution: coefficient of restitution of robot-terrain contacts (0 plastic, < 1);
            only with ``friction`` set (the terrain's contact parameters then replace the
            robot's).
    """

    kind: ClassVar[str] = ""

    friction: float | None = None
    restitution: float | None = None

    def __post_init__(self) -> None:
        self._reals()
        if self.friction is not None and not (math.isfinite(self.friction)
                                              and self.friction >= 0):
            self._fail("friction", "a coefficient >= 0", self.friction)
        if self.restitution is not None:
            if not 0 <= self.restitution < 1:
                self._fail("restitution", "a coefficient in [0, 1)", self.restitution)
            if self.friction is None:
                raise TerrainError(
                    f"terrain {self.kind!r}: restitution={self.restitution} takes effect only "
                    "together with friction (the terrain's contact parameters then replace the "
                    "robot's); give friction=... as well")

    def geometry(self) -> Geometry:
        """The shapes this terrain is made of."""
        raise NotImplementedError

    def files(self) -> tuple[str, ...]:
        """The files building this terrain reads (none, but for a height field's)."""
        return ()

    def _fail(self, field: str, expected: str, got: object) -> None:
        raise TerrainError(f"terrain {self.kind!r}: {field} must be {expected}, got {got!r}")

    def _whole(self, field: str, minimum: int, maximum: int | None = None) -> None:
        value = getattr(self, field)
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            self._fail(field, f"an integer >= {minimum}", value)
        if maximum is not None and value > maximum:
            self._fail(field, f"at most {maximum} (the limit of boxes in one terrain)", value)

    def _reals(self) -> None:
        """Every float field holds a finite number (not a boolean, not a string)."""
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if "float" in str(field.type) and value is not None and not is_real(value):
                self._fail(field.name, "a finite number", value)

    def _positive(self, *fields: str) -> None:
        for field in fields:
            value = getattr(self, field)
            if not (math.isfinite(value) and value > 0):
                self._fail(field, "> 0 [m]", value)


@dataclasses.dataclass(frozen=True, kw_only=True)
class Flat(Surface):
    """Flat ground: an infinite plane at z = 0 (the default world)."""

    kind: ClassVar[str] = "flat"

    def geometry(self) -> Geometry:
        return Geometry(plane=0.0)


@dataclasses.dataclass(frozen=True, kw_only=True)
class Slope(Surface):
    """Flat ground up to ``start``, then an incline along +x, then a plateau.

    Attributes:
        angle: incline angle [deg]; negative goes downhill.
        start: x where the incline begins [m].
        length: length of the incline along its surface [m].
    """

    kind: ClassVar[str] = "slope"

    angle: float = 10.0
    start: float = 0.5
    length: float = 5.0

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (math.isfinite(self.angle) and 0 < abs(self.angle) <= 60):
            self._fail("angle", "a nonzero angle in [-60, 60] deg", self.angle)
        if not math.isfinite(self.start):
            self._fail("start", "a finite x [m]", self.start)
        self._positive("length")

    def geometry(self) -> Geometry:
        pitch = math.radians(self.angle)
        c, s = math.cos(pitch), math.sin(pitch)
        run, rise = self.length * c, self.length * s
        end = self.start + run
        flat = Box((self.start - FAR / 2, 0.0, -THICKNESS / 2), (FAR / 2, FAR, THICKNESS / 2))
        # the incline's top face runs from (start, 0) to (end, rise)
        mid = np.array([self.start + run / 2, 0.0, rise / 2]) - THICKNESS / 2 * np.array(
            [-s, 0.0, c])
        incline = Box(tuple(mid.tolist()), (self.length / 2, FAR, THICKNESS / 2), pitch)
        plateau = Box((end + FAR / 2, 0.0, rise - THICKNESS / 2), (FAR / 2, FAR, THICKNESS / 2))
        return Geometry(boxes=(flat, incline, plateau))


@dataclasses.dataclass(frozen=True, kw_only=True)
class Hills(Surface):
    """Rolling hills, the height field h sin(2πx/λ) cos(2πy/λ).

    Attributes:
        height: amplitude h [m].
        wavelength: λ [m].
        size: half extent of the field along x and y [m]; outside it, flat ground 1 cm below
            the lowest point.
        resolution: grid spacing [m].
    """

    kind: ClassVar[str] = "hills"

    height: float = 0.1
    wavelength: float = 2.0
    size: float = 10.0
    resolution: float = 0.05

    def __post_init__(self) -> None:
        super().__post_init__()
        self._positive("height", "wavelength", "size", "resolution")
        _check_grid(self)

    def geometry(self) -> Geometry:
        return _field_geometry(hills_grid(self.height, self.wavelength, self.size,
                                          self.resolution))


@dataclasses.dataclass(frozen=True, kw_only=True)
class Rough(Surface):
    """Random rough ground: Gaussian-filtered noise of a given RMS height, from a seed.

    Attributes:
        roughness: RMS height about the mean (z = 0) [m].
        correlation: horizontal correlation length (the Gaussian filter's sigma) [m].
        seed: random seed; the same seed gives the same ground.
        size: half extent of the field [m]; outside it, flat ground 1 cm below its lowest point.
        resolution: grid spacing [m].
    """

    kind: ClassVar[str] = "rough"

    roughness: float = 0.02
    correlation: float = 0.2
    seed: int = 0
    size: float = 5.0
    resolution: float = 0.02

    def __post_init__(self) -> None:
        super().__post_init__()
        self._positive("roughness", "correlation", "size", "resolution")
        self._whole("seed", 0)
        _check_grid(self)

    def geometry(self) -> Geometry:
        return _field_geometry(rough_grid(self.roughness, self.correlation, self.seed,
                                          self.size, self.resolution))


@dataclasses.dataclass(frozen=True, kw_only=True)
class Stairs(Surface):
    """Flat ground, then ``steps`` steps up along +x, then a landing.

    Attributes:
        rise: height of each step [m].
        run: depth of each step [m].
        steps: number of steps.
        start: x of the first step's front face [m].
        width: extent across (y) [m].
        landing: depth of the flat top after the last step [m].
    """

    kind: ClassVar[str] = "stairs"

    rise: float = 0.05
    run: float = 0.3
    steps: int = 5
    start: float = 0.5
    width: float = 4.0
    landing: float = 5.0

    def __post_init__(self) -> None:
        super().__post_init__()
        self._positive("rise", "run", "width", "landing")
        self._whole("steps", 1, MAX_TERRAIN_BOXES)

    def geometry(self) -> Geometry:
        boxes = []
        for k in range(self.steps):
            depth = self.run + (self.landing if k == self.steps - 1 else 0.0)
            top = (k + 1) * self.rise
            boxes.append(Box((self.start + k * self.run + depth / 2, 0.0, top / 2),
                             (depth / 2, self.width / 2, top / 2)))
        return Geometry(plane=0.0, boxes=tuple(boxes))


@dataclasses.dataclass(frozen=True, kw_only=True)
class Blocks(Surface):
    """A field of square blocks of random position and height on flat ground.

    Attributes:
        count: number of blocks.
        size: edge length of each block [m].
        height: tallest block [m]; heights are uniform in [height/2, height].
        start: x where the field begins [m].
        length: extent of the field along x [m].
        width: extent of the field across (y), centred [m].
        seed: random seed.
    """

    kind: ClassVar[str] = "blocks"

    count: int = 40
    size: float = 0.2
    height: float = 0.05
    start: float = 0.5
    length: float = 4.0
    width: float = 3.0
    seed: int = 0

    def __post_init__(self) -> None:
        super().__post_init__()
        self._positive("size", "height", "length", "width")
        self._whole("count", 1, MAX_TERRAIN_BOXES)
        self._whole("seed", 0)
        if self.size > min(self.length, self.width):
            self._fail("size", f"at most the field's length and width ({self.length}, "
                       f"{self.width} m)", self.size)

    def geometry(self) -> Geometry:
        rng = np.random.default_rng(self.seed)
        half = self.size / 2
        x = rng.uniform(self.start + half, self.start + self.length - half, self.count)
        y = rng.uniform(-self.width / 2 + half, self.width / 2 - half, self.count)
        top = rng.uniform(self.height / 2, self.height, self.count)
        return Geometry(plane=0.0, boxes=tuple(
            Box((float(a), float(b), float(h) / 2), (half, half, float(h) / 2))
            for a, b, h in zip(x, y, top, strict=True)))


@dataclasses.dataclass(frozen=True, kw_only=True)
class Wall(Surface):
    """A wall across the robot's way on flat ground.

    Attributes:
        height: wall height [m].
        distance: x of the wall's near face [m].
        thickness: wall depth along x [m].
        width: wall extent across (y) [m].
    """

    kind: ClassVar[str] = "wall"

    height: float = 0.1
    distance: float = 0.5
    thickness: float = 0.1
    width: float = 4.0

    def __post_init__(self) -> None:
        super().__post_init__()
        self._positive("height", "thickness", "width")
        if not math.isfinite(self.distance):
            self._fail("distance", "a finite x [m]", self.distance)

    def geometry(self) -> Geometry:
        box = Box((self.distance + self.thickness / 2, 0.0, self.height / 2),
                  (self.thickness / 2, self.width / 2, self.height / 2))
        return Geometry(plane=0.0, boxes=(box,))


@dataclasses.dataclass(frozen=True, kw_only=True)
class HeightField(Surface):
    """A height field read from an image or an array file, centred at the origin.

    Images (.png, .jpg, ...): grey level 0..1 (black to white) times ``height``, the top row
    of the picture at +y (as seen from above). Arrays (.npy, .csv, .txt): heights in metres,
    row 0 at -y, column 0 at -x.

    Attributes:
        file: path of the image or array file.
        length: extent along x [m].
        width: extent along y [m]; None keeps the file's aspect ratio.
        height: elevation of a white pixel [m] (images only; default 0.1).
    """

    kind: ClassVar[str] = "heightfield"

    file: str = ""
    length: float = 10.0
    width: float | None = None
    height: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.file:
            self._fail("file", "the path of an image or array file", self.file)
        self._positive("length")
        if self.width is not None:
            self._positive("width")
        if self.height is not None:
            self._positive("height")

    def files(self) -> tuple[str, ...]:
        return (self.file,)

    def geometry(self) -> Geometry:
        heights = load_grid(self.file, self.height)
        rows, cols = heights.shape
        width = self.width or self.length * (rows - 1) / (cols - 1)
        return _field_geometry(Grid(heights, self.length / 2, width / 2))


Terrain = Flat | Slope | Hills | Rough | Stairs | Blocks | Wall | HeightField
KINDS: dict[str, type[Terrain]] = {k.kind: k for k in (Flat, Slope, Hills, Rough, Stairs,
                                                         Blocks, Wall, HeightField)}
_MAX_SAMPLES = MAX_GRID_CELLS  # height-field samples; MuJoCo holds them as float32


def _check_grid(terrain: Hills | Rough) -> None:
    n = (2 * terrain.size / terrain.resolution + 1) ** 2
    if n > _MAX_SAMPLES:
        terrain._fail("resolution", f"coarse enough for at most {_MAX_SAMPLES} samples over "
                      f"+-{terrain.size} m (that one needs {n:.3g})", terrain.resolution)


def _field_geometry(grid: Grid) -> Geometry:
    """A height field with a catch plane 1 cm below its lowest point."""
    return Geometry(plane=float(grid.heights.min()) - 0.01, grid=grid)
