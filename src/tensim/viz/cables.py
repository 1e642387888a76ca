"""Cables as a person should see them: coloured by tension, slack ones hanging loose.

Taut cables are drawn straight between their anchors in a colour that runs from blue (just
taut) to red (``max_tension``); slack ones (zero load-cell tension) are drawn grey, dashed and
sagging under gravity, with the motor's rest length as the cable's true length, so a slack
cable looks as long as it is. The drawings are MuJoCo scene geoms added after
``mjv_updateScene`` (offscreen) or into the passive viewer's ``user_scn``; the model's own
tendon drawing is switched off so each cable is drawn once.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import mujoco
import numpy as np

from tensim.model import CompiledModel
from tensim.sim import load_cell_tension
from tensim.viz._scene import add_connector
from tensim.viz._turbo import turbo

SLACK_RGBA = (0.55, 0.55, 0.55, 1.0)
DOWN = np.array([0.0, 0.0, -1.0])  # the direction slack cables sag in (gravity's)
_COLOR_RANGE = (0.1, 0.95)  # the part of the colour map used: skips the near-black ends
_CAPSULE = mujoco.mjtGeom.mjGEOM_CAPSULE


@dataclasses.dataclass(frozen=True)
class TensionColors:
    """Colour of a cable by its tension.

    Attributes:
        max_tension: tension drawn in the top colour (red); higher ones are clipped [N].
    """

    max_tension: float

    def __post_init__(self) -> None:
        if not (np.isfinite(self.max_tension) and self.max_tension > 0):
            raise ValueError(f"max_tension must be a finite tension > 0 N, "
                             f"got {self.max_tension}")

    @classmethod
    def for_model(cls, compiled: CompiledModel) -> TensionColors:
        """For a run not yet simulated: twice the highest tension at the start (the
        pretension), rounded up to 1, 2 or 5 x 10^k N, and no more than the strongest motor's
        tension limit; 50 N for a structure with no tension at the start.
        """
        data = mujoco.MjData(compiled.model)
        mujoco.mj_fwdPosition(compiled.model, data)
        length = data.ten_length[compiled.index.tendon]
        law = compiled.law()
        start = load_cell_tension(length, compiled.rest_length, law.stiffness)
        top = nice_ceiling(2 * float(start.max(initial=0.0))) if start.size else 50.0
        limits = law.max_tension[np.isfinite(law.max_tension)]
        return cls(min(top or 50.0, float(limits.max())) if limits.size else top or 50.0)

    @classmethod
    def for_run(cls, tension: np.ndarray) -> TensionColors:
        """Scaled to a recorded run: its highest tension [N], rounded up to 1, 2 or 5 x 10^k N
        (50 N when no cable was ever taut)."""
        top = float(np.nanmax(tension, initial=0.0))
        return cls(nice_ceiling(top) if top > 0 else 50.0)

    def rgba(self, tension: np.ndarray) -> np.ndarray:
        """(n, 4) colours for (n,) tensions [N]: grey where slack (tension <= 0)."""
        tension = np.asarray(tension, dtype=float)
        low, high = _COLOR_RANGE
        share = np.clip(tension / self.max_tension, 0.0, 1.0)
        colors = turbo(low + (high - low) * share)  # matplotlib's turbo, without matplotlib
        colors[tension <= 0] = SLACK_RGBA
        return colors.astype(np.float32)

    def colorbar(self, width: int, height: int) -> np.ndarray:
        """A (height, width, 3) uint8 legend image: 0 N on the left, max_tension on the right."""
        ramp = self.rgba(np.linspace(1e-9, self.max_tension, width))[:, :3]
        return np.repeat((255 * ramp[None]).astype(np.uint8), height, axis=0)

    def legend(self) -> str:
        """The legend's text."""
        return (f"cable tension: blue 0 N ... red {self.max_tension:g} N; "
                "grey dashed: slack")


def nice_ceiling(value: float) -> float:
    """The smallest of 1, 2, 2.5, 5 x 10^k at or above ``value`` (> 0); 0 for 0."""
    if value <= 0:
        return 0.0
    decade = 10.0 ** math.floor(math.log10(value))
    return next(step * decade for step in (1.0, 2.0, 2.5, 5.0, 10.0)
                if step * decade >= value * (1 - 1e-12))


def sag_depth(span: np.ndarray, length: np.ndarray) -> np.ndarray:
    """Depth of a parabola of arc length ``length`` hung over ``span`` [m] (0 where taut).

    The arc length of y = 4 h s (1 - s) over a span x is
    L = sqrt(x² + 16 h²) / 2 + x² / (8 h) asinh(4 h / x); it grows with h, so each depth is
    the root of L(h) = length, found by bisection on [0, length] for every slack cable at
    once, to within one part in 10^13 of the length (scipy's brentq per cable was exact as
    well, but its import cost the command that draws a robot's frame 0.2-0.3 s).
    """
    span, length = np.broadcast_arrays(np.asarray(span, float), np.asarray(length, float))
    depth = np.zeros(span.shape)
    slack = length > span * (1 + 1e-9)
    if not slack.any():
        return depth
    x, target = np.maximum(span[slack], 1e-9), length[slack]
    low, high = np.full(x.shape, 1e-12), target.copy()  # L(low) < target <= L(high)
    for _ in range(200):
        middle = 0.5 * (low + high)
        short = _parabola_length(x, middle) < target
        low, high = np.where(short, middle, low), np.where(short, high, middle)
        if np.all(high - low <= 1e-13 * target):
            break
    depth[slack] = 0.5 * (low + high)
    return depth


def _parabola_length(span: np.ndarray, depth: np.ndarray) -> np.ndarray:
    root = np.hypot(span, 4 * depth)
    return 0.5 * root + span**2 / (8 * depth) * np.arcsinh(4 * depth / span)


def sag_curve(start: np.ndarray, end: np.ndarray, length: float, points: int = 17,
              down: np.ndarray = DOWN) -> np.ndarray:
    """(points, 3) positions along a cable of ``length`` [m] hung between two anchors [m].

    A parabola in the plane of the chord and ``down`` (gravity), sagging perpendicular to the
    chord; straight when the anchors are ``length`` or more apart.
    """
    start, end = np.asarray(start, float), np.asarray(end, float)
    chord = end - start
    span = float(np.linalg.norm(chord))
    s = np.linspace(0.0, 1.0, points)[:, None]
    straight = start + s * chord
    depth = float(sag_depth(np.array(span), np.array(length)))
    if depth == 0.0:
        return straight
    axis = chord / span if span > 0 else np.array([1.0, 0.0, 0.0])
    sideways = down - (down @ axis) * axis
    if np.linalg.norm(sideways) < 1e-6:  # a vertical chord: hang it off to one side
        sideways = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    sideways /= np.linalg.norm(sideways)
    return straight + 4 * depth * s * (1 - s) * sideways


class CableArtist:
    """Adds one drawing per cable to an ``MjvScene`` (see the module docstring).

    Args:
        compiled: the compiled model (anchor sites ``<cable>_0`` and ``<cable>_1``).
        colors: the tension colour map.
        width: radius of a taut cable's drawing [m].
        segments: line pieces of a slack cable's sag curve (every other one drawn: dashed).
    """

    def __init__(self, compiled: CompiledModel, colors: TensionColors | None = None,
                 width: float = 0.004, segments: int = 16):
        model = compiled.model
        self.colors = colors or TensionColors.for_model(compiled)
        self.width, self.segments = width, segments
        self.sites = np.array([[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, f"{c}_{end}")
                                for end in (0, 1)] for c in compiled.index.cables],
                              dtype=int).reshape(-1, 2)
        self.tendons = np.asarray(compiled.index.tendon, dtype=int)
        # a routed, wrapped or contact cable: one piece per span of its tendon's path (each
        # wrap adds up to 2 points, each contact bead 1)
        spans = [max(len(c.via) + 2 * len(c.wrap), wraps - 2) + 1 for c, wraps in
                 zip(compiled.structure.cables, model.tendon_num[compiled.index.tendon],
                     strict=True)]
        self._most = sum(max(s, self.segments // 2 + 1) for s in spans)

    @property
    def max_geoms(self) -> int:
        """The most geoms one :meth:`draw` adds."""
        return self._most

    def draw(self, scene: mujoco.MjvScene, data: mujoco.MjData, tension: np.ndarray,
             rest_length: np.ndarray) -> None:
        """Appends the cables to ``scene`` (anchors from ``data.site_xpos``).

        Args:
            scene: the scene to add to (its ``ngeom`` grows).
            data: positions, after kinematics.
            tension: (n_cables,) load-cell tensions [N].
            rest_length: (n_cables,) motor rest lengths [m]: a slack cable's length.
        """
        colors = self.colors.rgba(tension)
        for i in range(len(self.sites)):
            path = self._path(data, i)
            start, end = path[0], path[-1]
            if len(path) > 2:  # routed through via nodes or wrapped around rods: its real path
                width = self.width if tension[i] > 0 else 0.5 * self.width
                for p, q in itertools.pairwise(path):
                    add_connector(scene, _CAPSULE, width, p, q, colors[i])
                continue
            if tension[i] > 0 or np.linalg.norm(end - start) >= rest_length[i]:
                add_connector(scene, _CAPSULE, self.width, start, end, colors[i])
                continue
            curve = sag_curve(start, end, float(rest_length[i]), self.segments + 1)
            for k in range(0, self.segments, 2):
                add_connector(scene, _CAPSULE, 0.5 * self.width, curve[k], curve[k + 1],
                              colors[i])

    def _path(self, data: mujoco.MjData, i: int) -> np.ndarray:
        """(k, 3) the points cable i runs through now: anchors, via sites, wrap tangent points."""
        t = self.tendons[i]
        adr, num = data.ten_wrapadr[t], data.ten_wrapnum[t]
        if num < 2:
            return np.stack([data.site_xpos[self.sites[i, 0]], data.site_xpos[self.sites[i, 1]]])
        return data.wrap_xpos.reshape(-1, 3)[adr:adr + num]


def hide_model_tendons(option: mujoco.MjvOption) -> None:
    """Switches MuJoCo's own tendon drawing off (the artist draws the cables)."""
    option.flags[mujoco.mjtVisFlag.mjVIS_TENDON] = 0
