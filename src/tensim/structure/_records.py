"""Plain, validated records that describe a tensegrity structure (no MuJoCo here).

All quantities are SI: metres, kilograms, newtons, seconds.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Sequence
from typing import TypedDict, Unpack

import numpy as np

from tensim._input import describe, is_real
from tensim.structure._errors import StructureError


def _check(condition: bool, item: str, message: str) -> None:
    if not condition:
        raise StructureError(message, item=item)


def _real(record: object, item: str, field: str, unit: str, optional: bool = False) -> None:
    """Checks that ``record.field`` is a finite number (not a boolean, not a string) and stores
    it as a float."""
    value = getattr(record, field)
    if optional and value is None:
        return
    if not is_real(value):
        raise StructureError(f"{field} must be a finite number [{unit}], got {describe(value)}",
                             item=item)
    object.__setattr__(record, field, float(value))


def _name(value: object, item: str, field: str = "name") -> str:
    if not (isinstance(value, str) and value):  # the message only when it is needed
        raise StructureError(f"{field} must be a non-empty string, got {describe(value)}",
                             item=item)
    return value


def _names(value: object, item: str, field: str) -> tuple[str, ...]:
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise StructureError(f"{field} must be a list of names, got {describe(value)}",
                             item=item)
    return tuple(_name(v, item, f"each of {field}") for v in value)


def _ends(value: object, item: str) -> tuple[str, str]:
    ends = _names(value, item, "nodes")
    _check(len(ends) == 2, item, f"nodes must be two node names, got {describe(list(ends))}")
    return ends  # type: ignore[return-value]


def _vec3(value: Sequence[float], item: str, field: str) -> tuple[float, float, float]:
    if isinstance(value, str) or not isinstance(value, Sequence | np.ndarray) \
            or not all(is_real(v) for v in value):
        raise StructureError(f"{field} must be three finite numbers [m], got "
                             f"{describe(value)}", item=item)
    _check(len(value) == 3, item, f"{field} must be three numbers [m], got {len(value)}")
    return tuple(float(v) for v in value)  # type: ignore[return-value]


def _field_names(cls: type) -> list[str]:
    return [f.name for f in dataclasses.fields(cls)]


def _nested(cls: type, raw: dict, item: str) -> object:
    """A nested record from a mapping, errors naming ``item``."""
    unknown = sorted(set(raw) - set(_field_names(cls)))
    _check(not unknown, item, f"unknown field {unknown[:1]}; expected {_field_names(cls)}")
    try:
        return cls(**raw)
    except StructureError as err:
        raise StructureError(err.detail, item=item) from None
    except TypeError as err:  # a required field is missing
        raise StructureError(f"{err}; expected fields {_field_names(cls)}", item=item) from None


def _tags(value: Sequence[str], item: str) -> tuple[str, ...]:
    if isinstance(value, str):
        raise StructureError("tags must be a list of strings, got a single string", item=item)
    return _names(value, item, "tags")


@dataclasses.dataclass(frozen=True)
class Node:
    """A named point of the structure where rods, cables and masses meet.

    Attributes:
        name: unique node name.
        position: (3,) initial position in the world frame [m].
        tags: labels used to select nodes.
        fixed: welded to the world (a test fixture or an anchor), not free to move.
    """

    name: str
    position: tuple[float, float, float]
    tags: tuple[str, ...] = ()
    fixed: bool = False

    def __post_init__(self) -> None:
        _name(self.name, "node")
        _check(isinstance(self.fixed, bool), f"node {self.name!r}",
               f"fixed must be true or false, got {describe(self.fixed)}")
        position = _vec3(self.position, f"node {self.name!r}", "position")
        object.__setattr__(self, "position", position)
        object.__setattr__(self, "tags", _tags(self.tags, f"node {self.name!r}"))


@dataclasses.dataclass(frozen=True)
class RodSection:
    """A rod's cross-section and material, for member checks (``tensim design members``).

    The simulation treats rods as rigid; the section says whether the real rod holds: Euler
    buckling of a pin-ended tube, pi^2 E I / L^2 with I = pi (D^4 - d^4) / 64, and yield at
    sigma_y A with A = pi (D^2 - d^2) / 4.

    Attributes:
        outer_diameter: D, the tube's outside diameter [m].
        inner_diameter: d, its inside diameter (0 for a solid rod) [m].
        modulus: Young's modulus E [Pa].
        yield_strength: sigma_y, the stress at which it yields [Pa].
        density: the material's density [kg/m^3], for the mass of the section; None: not
            given.
    """

    outer_diameter: float
    modulus: float
    yield_strength: float
    inner_diameter: float = 0.0
    density: float | None = None

    def __post_init__(self) -> None:
        for field, unit in (("outer_diameter", "m"), ("inner_diameter", "m"),
                            ("modulus", "Pa"), ("yield_strength", "Pa")):
            _real(self, "section", field, unit)
        _real(self, "section", "density", "kg/m^3", optional=True)
        for field in ("outer_diameter", "modulus", "yield_strength"):
            value = getattr(self, field)
            _check(value > 0, "section", f"{field} must be > 0, got {value}")
        _check(0 <= self.inner_diameter < self.outer_diameter, "section",
               f"inner_diameter must be >= 0 m and below outer_diameter "
               f"{self.outer_diameter} m, got {self.inner_diameter}")
        _check(self.density is None or self.density > 0, "section",
               f"density must be > 0 kg/m^3, got {self.density}")

    @property
    def area(self) -> float:
        """Cross-section area A [m^2]."""
        return math.pi * (self.outer_diameter**2 - self.inner_diameter**2) / 4

    @property
    def second_moment(self) -> float:
        """Second moment of area I [m^4]."""
        return math.pi * (self.outer_diameter**4 - self.inner_diameter**4) / 64

    def buckling_load(self, length: float) -> float:
        """Euler load of the pin-ended rod of ``length`` [m]: pi^2 E I / L^2 [N]."""
        return math.pi**2 * self.modulus * self.second_moment / length**2

    def yield_load(self) -> float:
        """Axial load at which the section yields: sigma_y A [N]."""
        return self.yield_strength * self.area


@dataclasses.dataclass(frozen=True)
class Rod:
    """A rigid compression member between two nodes, modelled as a solid cylinder.

    Give its mass as either ``linear_density`` [kg/m] or ``density`` [kg/m^3].

    Attributes:
        name: unique rod name.
        nodes: the two end nodes.
        radius: rod radius [m].
        linear_density: mass per length [kg/m].
        density: volumetric density [kg/m^3], used when linear_density is None.
        friction: Coulomb friction coefficient against the ground [-].
        restitution: fraction of normal velocity kept after an impact [0, 1).
        tags: labels used to select rods.
        axial_inertia: moment of inertia about the rod's own axis [kg m^2] (None: the solid
            cylinder's m r^2 / 2). A rigid body whose rods all give it keeps it: the
            compiler's floor on thin bodies' inertia (``WorldOptions.min_inertia_ratio``)
            leaves it alone.
        section: its cross-section and material (:class:`RodSection`), for member checks;
            None: not given (the simulation never needs it).
    """

    name: str
    nodes: tuple[str, str]
    radius: float
    linear_density: float | None = None
    density: float | None = None
    friction: float = 1.0
    restitution: float = 0.0
    tags: tuple[str, ...] = ()
    axial_inertia: float | None = None
    section: RodSection | None = None

    def __post_init__(self) -> None:
        item = f"rod {self.name!r}"
        _name(self.name, "rod")
        object.__setattr__(self, "nodes", _ends(self.nodes, item))
        _check(self.nodes[0] != self.nodes[1], item, "a rod needs two different nodes")
        _real(self, item, "radius", "m")
        _real(self, item, "linear_density", "kg/m", optional=True)
        _real(self, item, "density", "kg/m^3", optional=True)
        _real(self, item, "friction", "-")
        _real(self, item, "restitution", "-")
        _check(self.radius > 0, item, f"radius must be > 0 m, got {self.radius}")
        _real(self, item, "axial_inertia", "kg m^2", optional=True)
        _check(self.axial_inertia is None or self.axial_inertia > 0, item,
               f"axial_inertia must be > 0 kg m^2, got {self.axial_inertia}")
        _check(
            (self.linear_density is None) != (self.density is None),
            item,
            "give exactly one of linear_density [kg/m] or density [kg/m^3]",
        )
        for field in ("linear_density", "density"):
            value = getattr(self, field)
            _check(value is None or value > 0, item, f"{field} must be > 0, got {value}")
        _check(self.friction >= 0, item, f"friction must be >= 0, got {self.friction}")
        _check(0 <= self.restitution < 1, item,
               f"restitution must be in [0, 1), got {self.restitution}")
        object.__setattr__(self, "tags", _tags(self.tags, item))
        if isinstance(self.section, dict):
            object.__setattr__(self, "section", _nested(RodSection, self.section,
                                                        f"{item} section"))
        _check(self.section is None or isinstance(self.section, RodSection), item,
               f"section must be a mapping of {_field_names(RodSection)}, got "
               f"{describe(self.section)}")

    def mass_per_length(self) -> float:
        """Mass per length [kg/m]."""
        if self.linear_density is not None:
            return self.linear_density
        assert self.density is not None
        return self.density * math.pi * self.radius**2


@dataclasses.dataclass(frozen=True)
class PointMass:
    """A concentrated mass (motor, board, spool) at a node, modelled as a small solid sphere.

    Attributes:
        node: the node it sits on.
        mass: mass [kg].
        radius: sphere radius [m]; it also collides with the ground.
    """

    node: str
    mass: float
    radius: float = 0.005

    def __post_init__(self) -> None:
        item = f"point mass at {self.node!r}"
        _name(self.node, "point mass", "node")
        _real(self, item, "mass", "kg")
        _real(self, item, "radius", "m")
        _check(self.mass > 0, item, f"mass must be > 0 kg, got {self.mass}")
        _check(self.radius > 0, item, f"radius must be > 0 m, got {self.radius}")


class _MotorFields(TypedDict, total=False):
    """The DCMotor fields that DCMotor.from_constants takes as keywords."""

    spool_radius: float
    rotor_inertia: float
    viscous_friction: float
    coulomb_friction: float
    back_drivable: bool
    position_time: float


@dataclasses.dataclass(frozen=True)
class DCMotor:
    """A DC motor with gearbox and spool that winds the cable (instead of the kinematic motor).

    Every quantity is at the spool (after the gearbox): torque and speed of the output shaft,
    the rotor's inertia reflected through the gear ratio (J_rotor N^2, plus the spool's own).
    The torque-speed curve is linear: tau = stall_torque (u - omega / no_load_speed) for a
    drive u in [-1, 1] (the fraction of full voltage); u comes from a proportional position
    loop that saturates at a rest-length error of no_load_speed x spool_radius x
    position_time. The cable's tension drives the spool back where it exceeds what the motor
    holds, unless the gearbox is not back-drivable (a worm gear): then the spool turns only
    where the motor drives it.

    Attributes:
        spool_radius: R, cable length wound per radian [m].
        stall_torque: torque at zero speed and full voltage [N m].
        no_load_speed: speed at full voltage and no load [rad/s].
        rotor_inertia: J, inertia turning with the spool [kg m^2].
        viscous_friction: torque per speed opposing motion [N m s/rad].
        coulomb_friction: constant torque opposing motion, or holding the spool at rest [N m].
        back_drivable: the cable can turn the spool against (or without) the motor.
        position_time: the position loop's time constant: full voltage at an error of
            no_load_speed x spool_radius x position_time [s].
    """

    spool_radius: float = 0.01
    stall_torque: float = 0.5
    no_load_speed: float = 10.0
    rotor_inertia: float = 5e-4
    viscous_friction: float = 0.0
    coulomb_friction: float = 0.01
    back_drivable: bool = True
    position_time: float = 0.05

    def __post_init__(self) -> None:
        for field, unit in (("spool_radius", "m"), ("stall_torque", "N m"),
                            ("no_load_speed", "rad/s"), ("rotor_inertia", "kg m^2"),
                            ("viscous_friction", "N m s/rad"), ("coulomb_friction", "N m"),
                            ("position_time", "s")):
            _real(self, "DC motor", field, unit)
        for field in ("spool_radius", "stall_torque", "no_load_speed", "position_time"):
            value = getattr(self, field)
            _check(value > 0, "DC motor", f"{field} must be > 0, got {value}")
        for field in ("rotor_inertia", "viscous_friction", "coulomb_friction"):
            value = getattr(self, field)
            _check(value >= 0, "DC motor", f"{field} must be >= 0, got {value}")
        _check(isinstance(self.back_drivable, bool), "DC motor",
               f"back_drivable must be true or false, got {describe(self.back_drivable)}")
        try:  # a radius so small or large that the cable's view of the motor is not finite
            line = self.line()
        except (ZeroDivisionError, OverflowError):
            line = {"mass": math.inf}
        bad = [k for k, v in line.items() if not math.isfinite(v)
               or (k in ("stall_force", "no_load_line_speed") and v <= 0)]
        _check(not bad, "DC motor", f"spool_radius {self.spool_radius:g} m makes the motor's "
               f"{bad[0] if bad else ''} in cable coordinates zero or not finite; expected "
               "the radius of a spool (e.g. 0.01 m)")

    @classmethod
    def from_constants(cls, torque_constant: float, resistance: float, voltage: float,
                       gear_ratio: float, **fields: Unpack[_MotorFields]) -> DCMotor:
        """The motor of a torque constant K_t [N m/A] (= back-EMF constant [V s/rad]), an
        armature resistance [ohm] and a supply voltage [V] behind a gear ratio N [-]:
        stall_torque = N K_t V / R_a, no_load_speed = V / (N K_t). Other fields as keywords."""
        return cls(stall_torque=gear_ratio * torque_constant * voltage / resistance,
                   no_load_speed=voltage / (gear_ratio * torque_constant), **fields)

    def line(self) -> dict[str, float]:
        """The motor in cable coordinates: stall force [N], no-load line speed [m/s],
        reflected mass [kg], viscous [N s/m] and Coulomb [N] friction."""
        r = self.spool_radius
        return {"stall_force": self.stall_torque / r, "no_load_line_speed": self.no_load_speed * r,
                "mass": self.rotor_inertia / r**2, "viscous": self.viscous_friction / r**2,
                "coulomb": self.coulomb_friction / r}


@dataclasses.dataclass(frozen=True)
class Motor:
    """Limits of the motor that winds a cable's rest length.

    By default the motor is kinematic: the rest length moves toward its command at up to
    ``max_speed``. With ``dc`` it is a DC motor (:class:`DCMotor`) whose speed is a state
    driven by its torque-speed curve, its inertia, friction and the cable's tension;
    ``max_speed`` then has no effect. A ``passive`` cable has no motor: its rest length stays
    what it was built with and no controller may drive it (:data:`PASSIVE`; a structure
    file's cable without a ``motor`` gets it unless the file's ``defaults`` give one).

    Attributes:
        max_speed: fastest rest-length change of the kinematic motor [m/s].
        max_tension: the motor stops reeling in once the static tension k(x - l) would exceed
            this [N].
        min_rest_length: floor on the rest length [m].
        min_length: the motor stops reeling in once the actual length is at or below this [m].
        dc: the DC motor, or None for the kinematic one.
        passive: no motor at all (the other fields are then unused).
        lag_time: the kinematic motor's first-order lag [s]: each step its rest length moves
            1 - exp(-dt / lag_time) of the way to its target (still at most max_speed dt), as
            an actuator filter; 0 (the default): all the way.
        saturate: the kinematic motor's max_tension is a force cap that saturates: where the
            static tension k(x - l) would exceed it, the cable back-drives the motor, which
            pays out (at any speed) so that it holds max_tension. False (the default): the
            motor only stops reeling in there.
        pd_stiffness: kp of a PD motor [N/m] (0, the default: none). A PD motor is a lab's
            position servo on the cable's length, in parallel with the cable's spring: it
            pulls T = kp (x - L) + kd dx/dt, clamped to [0, max_tension] (it never pushes),
            toward its target length L, the cable's command (starting at ``pd_target``). The
            rest length then stays as built; max_speed, min_rest_length and min_length do not
            apply. A controller that puts the cable under the impedance law (impedance, CPG
            and sine gaits) replaces the servo by it.
        pd_damping: kd of a PD motor [N s/m] (needs pd_stiffness > 0).
        pd_target: a PD motor's target length at build [m]; None (the default): the cable's
            build length, where the servo pulls nothing, so the build pose's statics are the
            spring's (the design tools see the spring only).
    """

    max_speed: float = 0.07
    max_tension: float = 50.0
    min_rest_length: float = 0.01
    min_length: float = 0.01
    dc: DCMotor | None = None
    passive: bool = False
    lag_time: float = 0.0
    saturate: bool = False
    pd_stiffness: float = 0.0
    pd_damping: float = 0.0
    pd_target: float | None = None

    def __post_init__(self) -> None:
        _check(isinstance(self.passive, bool), "motor",
               f"passive must be true or false, got {describe(self.passive)}")
        _check(not (self.passive and self.dc is not None), "motor",
               "a passive cable has no motor, so no dc motor either")
        _check(self.dc is None or isinstance(self.dc, DCMotor), "motor",
               f"dc must be a mapping of DC-motor parameters, got {describe(self.dc)}")
        for field, unit in (("max_speed", "m/s"), ("max_tension", "N"),
                            ("min_rest_length", "m"), ("min_length", "m"), ("lag_time", "s"),
                            ("pd_stiffness", "N/m"), ("pd_damping", "N s/m")):
            _real(self, "motor", field, unit)
        _real(self, "motor", "pd_target", "m", optional=True)
        self._check_pd()
        _check(self.lag_time >= 0, "motor", f"lag_time must be >= 0 s, got {self.lag_time}")
        _check(isinstance(self.saturate, bool), "motor",
               f"saturate must be true or false, got {describe(self.saturate)}")
        for field in ("max_speed", "max_tension"):
            value = getattr(self, field)
            _check(value > 0, "motor", f"{field} must be > 0, got {value}")
        for field in ("min_rest_length", "min_length"):
            value = getattr(self, field)
            _check(value >= 0, "motor", f"{field} must be >= 0 m, got {value}")


    def _check_pd(self) -> None:
        for field in ("pd_stiffness", "pd_damping"):
            value = getattr(self, field)
            _check(value >= 0, "motor", f"{field} must be >= 0, got {value}")
        for field, value, unit in (("pd_damping", self.pd_damping, "N s/m"),
                                   ("pd_target", self.pd_target, "m")):
            _check(not value or self.pd_stiffness > 0, "motor",
                   f"{field} {value} {unit} needs pd_stiffness > 0 N/m (a PD motor)")
        _check(self.pd_target is None or self.pd_target > 0, "motor",
               f"pd_target must be > 0 m, got {self.pd_target}")
        if self.pd_stiffness > 0:
            other = [name for name, on in (("passive", self.passive),
                                           ("dc", self.dc is not None),
                                           ("lag_time", self.lag_time > 0),
                                           ("saturate", self.saturate)) if on]
            _check(not other, "motor", f"a PD motor (pd_stiffness > 0) pulls on the length "
                   f"directly, so it takes no {other[0] if other else ''} (that acts on a "
                   "rest-length motor); remove one of them")

    @property
    def pd(self) -> bool:
        """Whether this is a PD motor (pd_stiffness > 0)."""
        return self.pd_stiffness > 0


# a cable without a motor: its rest length stays as built (no floor lifts a short one)
PASSIVE = Motor(min_rest_length=0.0, min_length=0.0, passive=True)


@dataclasses.dataclass(frozen=True)
class CableContact:
    """How a contact cable touches the world: light beads along its path (see docs/cables.md).

    Attributes:
        spacing: largest distance between neighbouring beads (and anchors) along the build
            path [m]; each span between path points gets ceil(span / spacing) - 1 beads
            (at least one).
        radius: bead radius: the cable's contact thickness [m].
        mass: mass of each bead: its share of the cable's weight [kg]. The compiler adds the
            inertia a bead needs to be stable at the world's timestep as weightless armature
            (see docs/cables.md).
    """

    spacing: float = 0.05
    radius: float = 0.005
    mass: float = 0.001

    def __post_init__(self) -> None:
        _real(self, "contact", "spacing", "m")
        _real(self, "contact", "radius", "m")
        _real(self, "contact", "mass", "kg")
        for field in ("spacing", "radius", "mass"):
            value = getattr(self, field)
            _check(value > 0, "contact", f"{field} must be > 0, got {value}")


@dataclasses.dataclass(frozen=True)
class Cable:
    """A tension-only spring-cable between two nodes (paper eq. 1-2), wound by a motor.

    Give either ``pretension`` (the rest length then follows from the build-time anchor-to-anchor
    length) or ``rest_length``. A routed cable also passes through ``via`` nodes in order (as
    over frictionless eyelets): its length is the sum of its spans, its tension is the same in
    every span, and each via node feels the pull of both spans that meet there.

    Attributes:
        name: unique cable name.
        nodes: the two end nodes.
        stiffness: spring stiffness k [N/m].
        damping: linear damping b [N s/m].
        pretension: tension at build time [N].
        rest_length: rest length l [m].
        anchor_offset: each anchor sits this far from its node toward the other end [m]
            (e.g. on the surface of the node's sphere).
        motor: the motor's limits.
        tags: labels used to select cables.
        via: intermediate nodes the cable passes through, from ``nodes[0]`` to ``nodes[1]``.
        wrap: rods the cable wraps around between its ends, in order: it follows the shortest
            path over each (MuJoCo's cylinder wrapping) and the law acts on that length.
            Needs ``rest_length`` (the wrapped build length is not known before compiling)
            and no ``via`` nodes.
        side: for each rod in ``wrap``, a direction from the rod's axis toward the side the
            cable runs over (``(0, 0, 1)``: over the top at build); the wrap holds that side
            as the bodies move. Empty: each side follows from the build pose (see
            :meth:`Structure.wrap_sides`).
        contact: None for a cable that passes through everything; else the cable's path can
            touch the ground, terrain, blocks and walls, through light collision beads it runs
            over (``True`` takes the default :class:`CableContact`). Not with ``wrap``.
        breaking_load: the tension at which the cable breaks [N], for member checks; None:
            not given.
    """

    name: str
    nodes: tuple[str, str]
    stiffness: float
    damping: float = 0.0
    pretension: float | None = None
    rest_length: float | None = None
    anchor_offset: float = 0.0
    motor: Motor = dataclasses.field(default_factory=Motor)
    tags: tuple[str, ...] = ()
    via: tuple[str, ...] = ()
    wrap: tuple[str, ...] = ()
    side: tuple[tuple[float, float, float], ...] = ()
    contact: CableContact | None = None
    breaking_load: float | None = None

    def __post_init__(self) -> None:
        item = f"cable {self.name!r}"
        if self.contact is True:
            object.__setattr__(self, "contact", CableContact())
        elif self.contact is False:
            object.__setattr__(self, "contact", None)
        elif isinstance(self.contact, dict):
            unknown = sorted(set(self.contact) - {f.name for f in
                                                  dataclasses.fields(CableContact)})
            _check(not unknown, item, f"contact: unknown field {unknown[:1]}; expected spacing, "
                   "radius, mass")
            try:
                object.__setattr__(self, "contact", CableContact(**self.contact))
            except StructureError as err:
                raise StructureError(err.detail, item=f"{item} contact") from None
        _check(self.contact is None or isinstance(self.contact, CableContact), item,
               f"contact must be true, false or a mapping of spacing, radius and mass, got "
               f"{describe(self.contact)}")
        _name(self.name, "cable")
        object.__setattr__(self, "nodes", _ends(self.nodes, item))
        _check(self.nodes[0] != self.nodes[1], item, "a cable needs two different nodes")
        for field, unit in (("stiffness", "N/m"), ("damping", "N s/m"), ("anchor_offset", "m")):
            _real(self, item, field, unit)
        _real(self, item, "pretension", "N", optional=True)
        _real(self, item, "rest_length", "m", optional=True)
        _real(self, item, "breaking_load", "N", optional=True)
        _check(self.breaking_load is None or self.breaking_load > 0, item,
               f"breaking_load must be > 0 N, got {self.breaking_load}")
        _check(isinstance(self.motor, Motor), item,
               f"motor must be a mapping of motor limits, got {describe(self.motor)}")
        _check(self.stiffness > 0, item, f"stiffness must be > 0 N/m, got {self.stiffness}")
        _check(self.damping >= 0, item, f"damping must be >= 0 N s/m, got {self.damping}")
        _check(
            (self.pretension is None) != (self.rest_length is None),
            item,
            "give exactly one of pretension [N] or rest_length [m]",
        )
        _check(
            self.pretension is None or self.pretension >= 0,
            item,
            f"pretension must be >= 0 N, got {self.pretension}",
        )
        _check(
            self.rest_length is None or self.rest_length > 0,
            item,
            f"rest_length must be > 0 m, got {self.rest_length}",
        )
        _check(self.anchor_offset >= 0, item, "anchor_offset must be >= 0 m")
        object.__setattr__(self, "tags", _tags(self.tags, item))
        if isinstance(self.via, str):
            raise StructureError("via must be a list of node names, got a single string",
                                 item=item)
        object.__setattr__(self, "via", _names(self.via, item, "via"))
        if isinstance(self.wrap, str):
            raise StructureError("wrap must be a list of rod names, got a single string",
                                 item=item)
        object.__setattr__(self, "wrap", _names(self.wrap, item, "wrap"))
        if self.wrap:
            _check(not self.via, item, "a cable either wraps around rods or runs through via "
                   "nodes, not both")
            _check(self.rest_length is not None, item, "a cable that wraps around rods needs "
                   "rest_length [m] (its wrapped build length is only known once compiled)")
            _check(len(set(self.wrap)) == len(self.wrap), item,
                   f"wrap names a rod twice: {list(self.wrap)}")
            _check(self.contact is None, item, "a cable either wraps around rods or touches "
                   "the world through contact beads, not both")
        self._check_side(item)
        path = self.path
        for a, b in itertools.pairwise(path):
            _check(a != b, item, f"node {a!r} follows itself on the cable's path {list(path)}")

    def _check_side(self, item: str) -> None:
        if isinstance(self.side, str) or not isinstance(self.side, Sequence | np.ndarray):
            raise StructureError(f"side must be a list of directions [x, y, z], one per wrapped "
                                 f"rod, got {describe(self.side)}", item=item)
        _check(not self.side or len(self.side) == len(self.wrap), item,
               f"side gives {len(self.side)} directions for {len(self.wrap)} wrapped rods "
               f"({list(self.wrap)}); give one per rod, or none to take them from the build pose")
        sides = tuple(_vec3(v, item, "each side") for v in self.side)
        for v in sides:
            _check(0 < math.hypot(*v) < math.inf, item,
                   f"each side must be a non-zero direction, got {list(v)}")
        object.__setattr__(self, "side", sides)

    @property
    def path(self) -> tuple[str, ...]:
        """Every node the cable passes, in order: first end, via nodes, second end."""
        return (self.nodes[0], *self.via, self.nodes[1])
