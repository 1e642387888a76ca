"""Tetraspine: a spine of tetrahedral segments joined by six cables per joint.

Dimensions, masses, cables and controller follow the hardware Tetraspine3 of Mirletz et al.,
"Towards bridging the reality gap between tensegrity simulation and robotic hardware" (IROS 2015),
as the original simulator modelled it for the hardware comparison, in SI units, Z up, X forward.
"""

from __future__ import annotations

from tensim.control import ImpedanceController, ImpedanceGains
from tensim.structure import Cable, Motor, Node, PointMass, Rod, Structure

SEGMENT_SPACING = 0.23  # m, x offset between consecutive segments
BASE_CLEARANCE = 0.005  # m, base node centres above the ground at build time
ROD_RADIUS = 0.003175  # m
ROD_LINEAR_DENSITY = 0.0201 / 0.38  # kg/m, carbon fibre
FRICTION = 0.075  # robot-ground Coulomb coefficient
STIFFNESS = 229.16  # N/m, the 227 N/m spring in series with the cable
DAMPING = 20.0  # N s/m
MOTOR = Motor(max_speed=0.07, max_tension=50.0, min_rest_length=0.01, min_length=0.01)

# node positions in the segment frame [m]
_TOP_Z = 0.3290897
_NODES = {
    "right": (0.0, -0.19, 0.0),
    "left": (0.0, 0.19, 0.0),
    "top": (0.0, 0.0, _TOP_Z),
    "tip": (0.25, 0.0, 0.1096966),
    "pcb_right": (0.0, -0.095, _TOP_Z / 2),
    "pcb_left": (0.0, 0.095, _TOP_Z / 2),
}
_RODS = (("right", "left"), ("right", "pcb_right"), ("pcb_right", "top"), ("left", "pcb_left"),
         ("pcb_left", "top"), ("right", "tip"), ("left", "tip"), ("top", "tip"))
# point masses [kg]: (each base corner, tip, each PCB node) for the front, middle and rear segment
_MASSES = {"front": (0.140, 0.040, 0.070), "middle": (0.180, 0.120, 0.070),
           "rear": (0.100, 0.120, 0.095)}
# cable name -> (node on the front segment F, node on the rear segment R)
_CABLES = {
    "outer_right": ("right", "right"), "outer_left": ("left", "left"),
    "outer_top": ("top", "top"), "inner_right": ("right", "tip"),
    "inner_left": ("left", "tip"), "inner_top": ("top", "tip"),
}
_PRETENSION = {"top": 20.0, "left": 7.0, "right": 7.0}  # N, by the cable's side

# impedance law: group -> (K [N/m], B [N s/m])
_GAINS = {"top": (500.0, 150.0), "left": (100.0, 100.0), "right": (100.0, 100.0)}
# cable -> (T0 joint 1, T0 joint 2) [N] and (L* joint 1, L* joint 2) [m]
_OFFSET_TENSION = {"inner_top": (28, 10), "inner_left": (15, 10), "inner_right": (18, 8),
                   "outer_top": (15, 6), "outer_left": (11, 8), "outer_right": (10, 4)}
_TARGET_LENGTH = {"inner_top": (0.190, 0.180), "inner_left": (0.215, 0.225),
                  "inner_right": (0.215, 0.225), "outer_top": (0.185, 0.198),
                  "outer_left": (0.192, 0.188), "outer_right": (0.193, 0.192)}


def node_name(segment: int, node: str) -> str:
    """Name of a segment's node, e.g. ``s0_tip``."""
    return f"s{segment}_{node}"


def _segment_masses(segment: int, n_segments: int) -> tuple[float, float, float]:
    if segment == 0:
        return _MASSES["front"]
    return _MASSES["rear"] if segment == n_segments - 1 else _MASSES["middle"]


def tetraspine(n_segments: int = 12) -> Structure:
    """A Tetraspine of ``n_segments`` segments (segment 0 in front, at x = 0).

    The first and last segments carry the front and rear masses of Tetraspine3, every other
    segment the middle one's.
    """
    if n_segments < 2:
        raise ValueError(f"a spine needs at least 2 segments, got {n_segments}")
    nodes, rods, masses, cables = [], [], [], []
    for i in range(n_segments):
        tag = f"segment_{i}"
        for name, (x, y, z) in _NODES.items():
            nodes.append(Node(node_name(i, name), (x - SEGMENT_SPACING * i, y, z + BASE_CLEARANCE),
                              tags=(tag, name)))
        for a, b in _RODS:
            rods.append(Rod(f"s{i}_{a}_{b}", (node_name(i, a), node_name(i, b)), ROD_RADIUS,
                            linear_density=ROD_LINEAR_DENSITY, friction=FRICTION, tags=(tag,)))
        corner, tip, pcb = _segment_masses(i, n_segments)
        for name, mass in (("right", corner), ("left", corner), ("top", corner), ("tip", tip),
                           ("pcb_right", pcb), ("pcb_left", pcb)):
            masses.append(PointMass(node_name(i, name), mass, ROD_RADIUS))
    for j in range(1, n_segments):
        for kind, (front, rear) in _CABLES.items():
            side = kind.split("_")[1]
            cables.append(Cable(
                f"{kind}_{j}", (node_name(j - 1, front), node_name(j, rear)), STIFFNESS,
                damping=DAMPING, pretension=_PRETENSION[side], anchor_offset=ROD_RADIUS,
                motor=MOTOR, tags=(kind, kind.split("_")[0], side, f"joint_{j}"),
            ))
    return Structure(f"tetraspine{n_segments}", tuple(nodes), tuple(rods), tuple(cables),
                     tuple(masses))


def tetraspine3() -> Structure:
    """The three-segment hardware robot Tetraspine3."""
    return tetraspine(3)


def impedance_controller(n_segments: int = 3) -> ImpedanceController:
    """The impedance controller of the disturbance test (joint 2's values for joints >= 2)."""
    gains = {}
    for j in range(1, n_segments):
        for kind in _CABLES:
            k, b = _GAINS[kind.split("_")[1]]
            column = 0 if j == 1 else 1
            gains[f"{kind}_{j}"] = ImpedanceGains(float(_OFFSET_TENSION[kind][column]), k, b,
                                                  _TARGET_LENGTH[kind][column])
    return ImpedanceController(gains)
