"""The tetrahedral-complex and octahedral-complex spines of the original toolkit.

Tom Flemons' tensegrity spines, as Brian Tietz modelled them in NTRTsim (2014,
``examples/learningSpines/TetrahedralComplex/FlemonsSpineModelLearning.cpp`` and
``OctahedralComplex/FlemonsSpineModelLearningCL.cpp``): each vertebra is four (tetrahedral) or
six (octahedral) rods from a centre node, neighbouring vertebrae interleave, and eight cables
join each pair. The toolkit's numbers (centimetre scale, 981 cm/s^2 gravity) in SI: rod tips
0.1 m from the centre along the vertex directions, rods of radius 5 mm and density
4.2/300 kg/cm^3 = 14,000 kg/m^3 ("high enough or things fly apart"), friction 0.5; tetrahedral
vertebrae 0.115 m apart, octahedral ones 0.125 m, each octahedral vertebra turned 45 degrees
(alternately about the lateral and the vertical axis) and the whole spine 45 degrees about its
axis. Cables: 1000 N/m and 10 N s/m (tetrahedral, and the octahedral cross-links; stiffness and
damping are the same numbers in every length unit), 2000 N/m and 20 N s/m for the octahedral
saddle cables; motors 0.12 m/s (octahedral 0.24 m/s) and 70 N (7000 kg cm/s^2).

The toolkit built these spines with zero pretension and let gravity load them. Here they start
self-stressed instead: each joint's eight cables carry one tension per cable class, in the ratio
that balances them along the spine (the other five balance conditions hold by symmetry), with
10 N in the most loaded class (the toolkit's 10 N passive saddle pretension).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from tensim.structure import Cable, Motor, Node, Rod, Structure

TIP = 0.1  # m, rod tip offset from the centre along each axis
ROD_RADIUS = 0.005  # m
ROD_DENSITY = 4.2 / 300.0 * 1e6  # kg/m^3 (the toolkit's 4.2/300 kg/cm^3)
FRICTION = 0.5
CLEARANCE = 0.005  # m, lowest rod surface above the ground at build time
MAX_PRETENSION = 10.0  # N, in the most loaded cable class

_TETRA_SPACING = 0.115  # m
_TETRA_TIPS = {"front_top": (1, 1, 1), "front_bottom": (1, -1, -1),
               "rear_bottom": (-1, 1, -1), "rear_top": (-1, -1, 1)}


@dataclasses.dataclass(frozen=True)
class _CableKind:
    """Spring and motor of one class of cable: stiffness [N/m], damping [N s/m]."""

    stiffness: float
    damping: float
    motor: Motor


_TETRA_CABLE = _CableKind(1000.0, 10.0, Motor(max_speed=0.12, max_tension=70.0))

_OCTA_SPACING = 0.125  # m
# the toolkit's node names, in its Y-up frame (spine along -z), before the 45 degree turns
_OCTA_TIPS = {"top": (0, 1, 0), "bottom": (0, -1, 0), "front": (0, 0, 1), "back": (0, 0, -1),
              "right": (1, 0, 0), "left": (-1, 0, 0)}
# (front vertebra's node, rear vertebra's node) for even / odd joint numbers (the first is 1)
_OCTA_SADDLE = {0: (("bottom", "front"), ("back", "front"), ("bottom", "right"), ("back", "right")),
                1: (("left", "top"), ("back", "top"), ("left", "front"), ("back", "front"))}
_OCTA_CROSS = {0: (("right", "front"), ("left", "right"), ("bottom", "top"), ("back", "bottom")),
               1: (("top", "front"), ("bottom", "top"), ("left", "right"), ("back", "left"))}
_OCTA_SADDLE_CABLE = _CableKind(2000.0, 20.0, Motor(max_speed=0.24, max_tension=70.0))
_OCTA_CROSS_CABLE = _CableKind(1000.0, 10.0, Motor(max_speed=0.24, max_tension=70.0))

# the toolkit's frame (Y up, spine along -z) to ours (Z up, spine along -x): (x, y, z) -> (z, x, y)
_FROM_TOOLKIT = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def _name(segment: int, node: str) -> str:
    return f"s{segment}_{node}"


def _axial_ratio(pos: dict[str, np.ndarray], a: list[tuple[str, str]],
                 b: list[tuple[str, str]]) -> float:
    """Tension ratio T_b / T_a that balances the two cable classes along x on the rear body."""

    def pull(pairs: list[tuple[str, str]]) -> float:
        # x component of the unit vectors from the rear node toward the front node
        return sum((pos[f][0] - pos[r][0]) / np.linalg.norm(pos[f] - pos[r]) for f, r in pairs)

    return -pull(a) / pull(b)


def _spine(name: str, vertebrae: list[dict[str, np.ndarray]],
           joints: list[list[tuple[str, str, str, _CableKind]]]) -> Structure:
    """Assembles nodes, rods (centre to each tip) and cables; lifts it to CLEARANCE."""
    lift = CLEARANCE + ROD_RADIUS - min(p[2] for v in vertebrae for p in v.values())
    nodes, rods = [], []
    up = np.array([0.0, 0.0, lift])
    for i, vertebra in enumerate(vertebrae):
        tag = f"segment_{i}"
        for node, p in vertebra.items():
            nodes.append(Node(_name(i, node), tuple(p + up), tags=(tag, node)))
            if node != "centre":
                rods.append(Rod(_name(i, node), (_name(i, "centre"), _name(i, node)), ROD_RADIUS,
                                density=ROD_DENSITY, friction=FRICTION, tags=(tag,)))
    pos = {n.name: np.array(n.position) for n in nodes}
    cables = []
    for j, joint in enumerate(joints, start=1):
        classes = sorted({kind for kind, _, _, _ in joint})
        pairs = {k: [(_name(j - 1, f), _name(j, r)) for kind, f, r, _ in joint if kind == k]
                 for k in classes}
        ratio = _axial_ratio(pos, pairs[classes[0]], pairs[classes[1]])
        scale = MAX_PRETENSION / max(1.0, ratio)
        tension = {classes[0]: scale, classes[1]: scale * ratio}
        for kind, front, rear, spring in joint:
            cables.append(Cable(f"{kind}_{front}_{rear}_{j}", (_name(j - 1, front), _name(j, rear)),
                                spring.stiffness, damping=spring.damping, motor=spring.motor,
                                pretension=tension[kind], tags=(kind, f"joint_{j}")))
    return Structure(name, tuple(nodes), tuple(rods), tuple(cables))


def tetrahedral_complex(n_segments: int = 6) -> Structure:
    """The tetrahedral-complex spine: 4 rods per vertebra, 8 cables per joint.

    Each joint has four outer cables (a tip to the same tip of the next vertebra, along the
    spine) and four inner ones (the front vertebra's two rear tips to the next vertebra's two
    front tips, which sit between them).

    Raises:
        ValueError: fewer than 2 segments.
    """
    if n_segments < 2:
        raise ValueError(f"a spine needs at least 2 segments, got {n_segments}")
    vertebrae = [{"centre": np.array([-_TETRA_SPACING * i, 0.0, 0.0]),
                  **{k: np.array([-_TETRA_SPACING * i, 0.0, 0.0]) + TIP * np.array(d, float)
                     for k, d in _TETRA_TIPS.items()}} for i in range(n_segments)]
    outer = [("outer", tip, tip, _TETRA_CABLE) for tip in _TETRA_TIPS]
    inner = [("inner", front, rear, _TETRA_CABLE) for front in ("rear_bottom", "rear_top")
             for rear in ("front_top", "front_bottom")]
    return _spine(f"tetrahedral_complex{n_segments}", vertebrae,
                  [outer + inner] * (n_segments - 1))


def _octa_vertebra(i: int) -> dict[str, np.ndarray]:
    """Vertebra i's nodes: built in the toolkit's frame with its turns, then mapped to ours."""
    from scipy.spatial.transform import Rotation  # ~0.2 s to import: only for this preset

    centre = np.array([0.0, 0.0, -_OCTA_SPACING * i])
    turn = (Rotation.from_rotvec([math.pi / 4, 0.0, 0.0]) if i % 2 == 1
            else Rotation.from_rotvec([0.0, -math.pi / 4, 0.0]))
    spine_turn = Rotation.from_rotvec([0.0, 0.0, math.pi / 4])
    local = {"centre": np.zeros(3), **{k: TIP * np.array(d, float) for k, d in _OCTA_TIPS.items()}}
    return {k: _FROM_TOOLKIT @ spine_turn.apply(centre + turn.apply(p)) for k, p in local.items()}


def octahedral_complex(n_segments: int = 6) -> Structure:
    """The cross-linked octahedral-complex spine: 6 rods per vertebra, 8 cables per joint.

    Each joint has four saddle cables and four cross-links, in the toolkit's pattern, which
    alternates between joints. Node names are the toolkit's (top, bottom, front, back, right,
    left) before the 45 degree turns, so they no longer point where their names say.

    Raises:
        ValueError: fewer than 2 segments.
    """
    if n_segments < 2:
        raise ValueError(f"a spine needs at least 2 segments, got {n_segments}")
    vertebrae = [_octa_vertebra(i) for i in range(n_segments)]
    joints = []
    for j in range(1, n_segments):
        parity = j % 2  # the toolkit alternates the pattern with the joint number
        joints.append([("saddle", f, r, _OCTA_SADDLE_CABLE) for f, r in _OCTA_SADDLE[parity]]
                      + [("cross", f, r, _OCTA_CROSS_CABLE) for f, r in _OCTA_CROSS[parity]])
    return _spine(f"octahedral_complex{n_segments}", vertebrae, joints)
