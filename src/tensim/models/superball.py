"""SUPERball at full scale: the six-strut icosahedron with 1.68 m, 3.5 kg struts, 24 cables.

SUPERball (Sabelhaus et al., "System design and locomotion of SUPERball, an untethered
tensegrity robot", ICRA 2015) is NASA Ames' planetary-probe tensegrity: six struts of about
1.7 m and 3.5 kg. The numbers below are those of the original toolkit's model of it
(``resources/YamlStructures/BaseStructures/SuperBall.yaml`` in NTRTsim, decimetre scale),
converted to SI: struts 16.84 dm long, radius 0.31 dm, density 0.688 kg/dm^3 (so
0.688e3 kg/m^3 x pi x 0.031^2 m^2 x 1.684 m = 3.50 kg per strut, 21.0 kg in all), friction
0.99, no restitution; springs of 613 N/m (stiffness is the same number in every length unit,
kg/s^2), damping 200 N s/m, pretension 2452 kg dm/s^2 = 245.2 N.

The geometry is the symmetric form of :mod:`tensim.models.six_bar` (parallel struts half a
strut apart), in which equal pretensions are a state of self-stress; the toolkit's file spaces
the pairs 15 dm apart instead, a pose its cables then pull towards this one.

Motor limits are the built robot's, from J. Bruce's dissertation ("Design, Building, Testing,
and Control of SUPERball: A Tensegrity Robot to Enable New Forms of Planetary Exploration",
UC Santa Cruz, 2016; its LaTeX sources are public in the author's ``Advancement_UCSC``
repository on GitHub). Each motor is a 100 W Maxon brushless motor (24 V, 26,500 rpm no-load,
691 mN m stall) behind a 109:1 three-stage gearbox rated 3 N m continuous and 3.5 N m peak
(the chapter "SUPERball v1 Design", table "100W Maxon BLDC Motor Parameters"). The spools were
cut from 30 mm to 18 mm diameter so that the gearboxes could hold the cables' tensions, which
"reduces the actuation speed to 47% of" the 30 cm/s that Iscen et al.'s rolling controller
needed (appendix, "Cable Tension"): ``max_speed`` = 0.47 x 0.30 m/s = 0.14 m/s. ``max_tension``
is the gearbox's rated continuous torque on that spool, 3 N m / 0.009 m = 333 N (the
dissertation designed for 200 N continuous, measured about 240 N nominal and over 400 N at
most, and its controllers capped any cable at 250 N). The built robot had 12 motors; the
preset motorises all 24 cables, the fully actuated design its papers propose. Not modelled:
the motors' 0.4 m stroke (the rolling gait's travel stays inside it: half of a 0.63 m rest
length) and the robot's 998 N/m and 2850 N/m springs (the cables keep the toolkit's 613 N/m).

As built, it rests on a closed triangle of cables (as SUPERball rests between rolls) in its
static pose under gravity on frictionless feet, so it stands still when released (under
1 mm in 5 s at 1 ms, ``tests/test_standing.py``).
"""

from __future__ import annotations

import itertools

import numpy as np

from tensim.models._standing import lying, stored_standing
from tensim.models._standing import standing as settled
from tensim.models.six_bar import six_bar_nodes
from tensim.structure import Cable, Motor, Node, Rod, Structure

STRUT_LENGTH = 1.684  # m
ROD_RADIUS = 0.031  # m
ROD_DENSITY = 688.0  # kg/m^3
FRICTION = 0.99
STIFFNESS = 613.0  # N/m
DAMPING = 200.0  # N s/m
PRETENSION = 245.2  # N, the same in every cable
# the built robot: 18 mm spools at 47 % of 0.30 m/s; a 3 N m gearbox on a 9 mm radius
MOTOR = Motor(max_speed=0.47 * 0.30, max_tension=3.0 / 0.009)


def superball(clearance: float = 0.0, standing: bool = True) -> Structure:
    """SUPERball resting on a closed triangle of cables, as it rests between rolls: in its
    static pose under gravity on frictionless feet (:func:`tensim.models._standing.standing`:
    it stands still as built), its lowest strut surface ``clearance`` metres up before it
    settles. ``standing=False``: the symmetric self-stressed form, unsettled (rest lengths from
    the pretension), lifted the same way. With the
    default arguments the pose is read, bit for bit, from the stored file
    (:func:`tensim.models._standing.stored_standing`), not solved again."""
    positions = six_bar_nodes(STRUT_LENGTH)
    length = STRUT_LENGTH * np.sqrt(6) / 4
    pairs = [(a, b) for a, b in itertools.combinations(positions, 2)
             if abs(np.linalg.norm(positions[a] - positions[b]) - length) < 1e-9]
    face = next(f for f in itertools.combinations(positions, 3)
                if all(p in pairs for p in itertools.combinations(f, 2)))
    nodes = tuple(Node(n, tuple(p)) for n, p in positions.items())
    rods = tuple(
        Rod(f"rod_{axis}{pair}", (f"{axis}{pair}0", f"{axis}{pair}1"), ROD_RADIUS,
            density=ROD_DENSITY, friction=FRICTION, tags=(f"rod_{axis}{pair}",))
        for axis in "xyz" for pair in (0, 1)
    )
    cables = tuple(
        Cable(f"cable_{a}_{b}", (a, b), STIFFNESS, damping=DAMPING, pretension=PRETENSION,
              motor=MOTOR)
        for a, b in pairs
    )
    form = Structure("superball", nodes, rods, cables)
    if standing and clearance == 0.0:  # the pose solved once and stored (_standing.STORED)
        return stored_standing(form)
    robot = lying(form, face, clearance + ROD_RADIUS)
    return settled(robot) if standing else robot
