"""A motorised 3-bar rolling robot: the triangular prism at the size labs roll it.

The size is that of a published MuJoCo model of a lab's 3-bar rolling robot: three bars of
1.376 m and 4 kg each, six actuated cables along the two end triangles and three passive
vertical cables, stiff cables of about 10 kN/m. The form is the self-stressed twisted prism of
:mod:`tensim.models.prism3` (top triangle turned 150 degrees; force densities 1 : sqrt(3) :
-sqrt(3) in the triangle cables, verticals and bars), with end triangles of 0.35 m
circumradius (0.606 m sides), so the bars' 1.376 m fix the height at 1.198 m. The robot is
built lying on its side (on nodes b0, b1 and t2), as it rolls: sideways, about its long axis.
Pretension: 400 N in each triangle cable (less lets the prism sag on its soft mode).

Motors: each end-triangle cable is wound at up to 0.5 m/s and 2 kN (chosen here, not a lab's
data: fast enough to roll, strong enough for the stiff cables); the verticals have no motor.

Time step: the bars are heavy enough for the explicit cable law to hold 10 kN/m cables at
tensim's default 1 ms step (:data:`DEFAULT_TIMESTEP`): ``tensim check three_bar`` is clean
there, warns at 5 ms and asks for 2 ms or less; the stiffness need not be lowered.

Standing: the pose is the static pose under gravity on the three feet as on frictionless
ground (the design tools' :func:`~tensim.design.inverse.settle` with ``sliding``), so the robot
neither sags when released nor leans on friction: held where they first touched, the feet
had to push outward, and MuJoCo's soft friction let them creep (14 mm in 5 s, a slow turn
about the vertical); on frictionless feet nothing moves more than a millimetre in 5 s
(``tests/test_standing.py``).
"""

from __future__ import annotations

import math

import numpy as np

from tensim.models._standing import lying, stored_standing
from tensim.models._standing import standing as settled
from tensim.structure import PASSIVE, Cable, Motor, Node, Rod, Structure

BAR_LENGTH = 1.376  # m
BAR_MASS = 4.0  # kg
BAR_RADIUS = 0.025  # m
RADIUS = 0.35  # m, circumradius of the end triangles
TWIST = math.radians(150.0)
HEIGHT = math.sqrt(BAR_LENGTH**2 - (2 * RADIUS * math.sin(TWIST / 2))**2)  # m
STIFFNESS = 10_000.0  # N/m
DAMPING = 50.0  # N s/m
TRIANGLE_TENSION = 400.0  # N
FRICTION = 1.0
MOTOR = Motor(max_speed=0.5, max_tension=2000.0, min_rest_length=0.1, min_length=0.1)
DEFAULT_TIMESTEP = 1e-3  # s, at which `tensim check three_bar` is clean


def _prism_nodes() -> dict[str, np.ndarray]:
    """Node positions of the upright prism, bottom triangle at z = 0 [m]."""
    def at(angle: float, z: float) -> np.ndarray:
        return np.array([RADIUS * math.cos(angle), RADIUS * math.sin(angle), z])

    nodes = {f"b{i}": at(2 * math.pi * i / 3, 0.0) for i in range(3)}
    nodes.update({f"t{i}": at(2 * math.pi * i / 3 + TWIST, HEIGHT) for i in range(3)})
    return nodes


def three_bar(clearance: float = 0.0, standing: bool = True) -> Structure:
    """The 3-bar lying on its side face b0-b1-t2, its lowest bar surface ``clearance`` metres
    up, in its static pose on frictionless feet (:func:`tensim.models._standing.standing`).
    ``standing=False``: the self-stressed prism, unsettled, lying the same way. With the default
    arguments the pose is read, bit for bit, from the stored file
    (:func:`tensim.models._standing.stored_standing`), not solved again."""
    upright = _prism_nodes()
    nodes = tuple(Node(n, tuple(p), tags=("bottom" if n[0] == "b" else "top",))
                  for n, p in upright.items())
    rods = tuple(Rod(f"bar_{i}", (f"b{i}", f"t{i}"), BAR_RADIUS,
                     linear_density=BAR_MASS / BAR_LENGTH, friction=FRICTION,
                     tags=(f"bar_{i}",)) for i in range(3))
    members = [(f"bottom_{i}", f"b{i}", f"b{(i + 1) % 3}", 1.0, "bottom", MOTOR)
               for i in range(3)]
    members += [(f"top_{i}", f"t{i}", f"t{(i + 1) % 3}", 1.0, "top", MOTOR) for i in range(3)]
    members += [(f"vertical_{i}", f"b{i}", f"t{(i + 2) % 3}", math.sqrt(3), "vertical", PASSIVE)
                for i in range(3)]
    side = RADIUS * math.sqrt(3)
    q = TRIANGLE_TENSION / side  # force density of the triangle cables [N/m]
    cables = tuple(
        Cable(name, (a, b), STIFFNESS, damping=DAMPING,
              pretension=q * ratio * float(np.linalg.norm(upright[a] - upright[b])),
              motor=motor, tags=(tag,))
        for name, a, b, ratio, tag, motor in members)
    form = Structure("three_bar", nodes, rods, cables)
    if standing and clearance == 0.0:  # the pose solved once and stored (_standing.STORED)
        return stored_standing(form)
    robot = lying(form, ("b0", "b1", "t2"), clearance + BAR_RADIUS)
    return settled(robot) if standing else robot
