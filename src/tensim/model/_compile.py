"""Compiles a :class:`~tensim.structure.Structure` into a MuJoCo model through ``mujoco.MjSpec``.

One body per rigid group (free unless one of its nodes is fixed), rods as capsules, point masses
as spheres, each cable a spatial tendon between two anchor sites plus an unlimited tendon
actuator through which the cable law applies its tension. Names are deterministic: bodies after
their group, geoms after their rod (``mass_<node>`` for point masses), tendons and actuators
after their cable, anchor sites ``<cable>_0`` and ``<cable>_1`` (and ``<cable>_via<k>`` at the
via nodes of a routed cable). A contact cable's tendon also runs over the beads of
:mod:`tensim.model._beads` (bodies ``<cable>_bead<k>``, span springs ``<cable>_span<k>``).
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math

import mujoco
import numpy as np

from tensim.model import _beads
from tensim.model._law_layout import (
    A_PEAK,
    A_PEAK_POWER,
    A_PEAK_SPEED,
    ACTDIM,
    CABLE_LAWS,
    DC_ACTDIM,
    GAIN,
    IMPLICIT_EXTRA,
    LAW_EXPLICIT,
    LAW_IMPLICIT,
    LAW_IMPLICITFAST,
    MODE_PD,
    MODE_REST,
    LawParameters,
    biasprm,
    dynprm,
    gainprm,
    implicit,
)
from tensim.model._split import split_cables
from tensim.structure import Cable, Rod, Structure, mass_properties
from tensim.structure._mass import MassProperties
from tensim.terrain import Flat, Terrain, add_terrain, place_on_terrain, restitution_dampratio

log = logging.getLogger(__name__)

# Robot geoms outrank the ground, so robot-ground contacts use the rod's own friction.
_ROBOT_PRIORITY = 1
BUILD_KEY = "build"  # the keyframe of the build pose: rest lengths in act, commands in ctrl
WORLD_FRAME_SITE = "world_frame"  # reference frame of the node-load inputs
_CONES = {"pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL, "elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC}
# each cable law's MuJoCo integrator: the implicit laws' native gain term is what discrete
# (stiffness and damping) and implicitfast (damping) integrate implicitly (docs/architecture.md)
INTEGRATORS = {LAW_EXPLICIT: mujoco.mjtIntegrator.mjINT_EULER,
               LAW_IMPLICIT: mujoco.mjtIntegrator.mjINT_DISCRETE,
               LAW_IMPLICITFAST: mujoco.mjtIntegrator.mjINT_IMPLICITFAST}


class ModelError(ValueError):
    """A structure cannot be compiled into a sound MuJoCo model."""


@dataclasses.dataclass(frozen=True)
class WorldOptions:
    """The world the structure is placed in.

    Attributes:
        timestep: physics step [s].
        gravity: (3,) gravitational acceleration [m/s^2].
        ground: add an infinite ground plane at z = 0.
        min_inertia_ratio: a body whose smallest principal moment is below this fraction of
            its largest gets the small moments raised to it (thin single rods: MuJoCo spins up
            bodies with a tiny axial inertia); see ``thin_body``.
        thin_body: ``"regularize"`` (raise the moments and say so at WARNING, with the figures)
            or ``"refuse"`` (raise an error). ``min_inertia_ratio=0`` turns the floor off.
        contact_timeconst: time constant of MuJoCo's soft contact [s] (0.02 is MuJoCo's default;
            keep it >= 2 timesteps).
        terrain: the ground (``tensim.terrain``; flat by default); the robot is lifted onto it
            where it is higher than z = 0 under the robot. Needs ``ground``.
        midphase: use MuJoCo's bounding-volume midphase in collision detection. Off by default:
            with a few geoms per body it costs more than it saves, and the contacts it finds
            are the same (the disturbance test runs bit-identical, 1.1x faster; docs/speed.md).
        self_collision: the robot's rigid bodies collide with each other (MuJoCo's default).
            ``False`` keeps only contacts with the ground: faster (1.2x for Tetraspine3, whose
            neighbouring segments' capsules are tested every step and never touch in the
            disturbance test), but it changes the physics wherever the robot's parts do touch.
        cone: MuJoCo's friction cone, ``"pyramidal"`` (its default) or ``"elliptic"`` (the
            exact Coulomb cone; softer stick-slip transitions, docs/speed.md).
        noslip_iterations: iterations of MuJoCo's no-slip solver after the main one (0: off);
            it removes the creep of soft contacts under tangential load, so sticking feet stay.
        condim: contact dimensionality of the robot's contacts: 3 (sliding friction), 4 (plus
            torsional friction about the contact normal) or 6 (plus rolling friction).
        torsional_friction: torsional friction coefficient [m] (condim 4 and 6).
        rolling_friction: rolling friction coefficient [m] (condim 6).
        cable_law: ``"explicit"`` (the default: the law computes each cable's force and MuJoCo
            integrates it with its semi-implicit Euler step, as the paper's figures were made),
            ``"implicit"`` (MuJoCo's ``discrete`` integrator takes half of each taut cable's
            stiffness and damping implicitly through a native actuator term, a trapezoidal
            step, and solves the contacts in the same metric: stiff, strongly damped cables at
            1-10 ms steps) or
            ``"implicitfast"`` (the same term under MuJoCo's cheaper ``implicitfast``, which
            takes only the damping, and only each body's own share of it: right for cables
            anchored to the world, poor for cables between free bodies); docs/speed.md.
        split_margin: under ``cable_law="implicit"``, keep on the explicit law the cables
            that the explicit step integrates stably with this margin [-]: in order of each
            cable's own explicit step bound, the longest first, as many as keep the explicit
            bound of them all together at least ``split_margin`` times the step, at the
            build pose (:mod:`tensim.model._split`); the rest are handed to MuJoCo's
            ``discrete`` step, whose cost grows with the cables it is handed. A model with no
            cable handed over runs MuJoCo's Euler step, as the explicit law does. 0 (the
            default): every cable handed over. The other laws ignore it.
    """

    timestep: float = 1e-3
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)
    ground: bool = True
    min_inertia_ratio: float = 0.01
    thin_body: str = "regularize"
    contact_timeconst: float = 0.02
    terrain: Terrain = dataclasses.field(default_factory=Flat)
    midphase: bool = False
    self_collision: bool = True
    cone: str = "pyramidal"
    noslip_iterations: int = 0
    condim: int = 3
    torsional_friction: float = 0.005
    rolling_friction: float = 0.0001
    cable_law: str = LAW_EXPLICIT
    split_margin: float = 0.0

    def __post_init__(self) -> None:
        if not 0 < self.timestep <= 0.05:
            raise ValueError(f"timestep must be in (0, 0.05] s, got {self.timestep}")
        if self.thin_body not in ("regularize", "refuse"):
            raise ValueError(f"thin_body must be 'regularize' or 'refuse', got {self.thin_body!r}")
        if not 0 <= self.min_inertia_ratio < 1:
            raise ValueError("min_inertia_ratio must be in [0, 1)")
        if self.contact_timeconst <= 0:
            raise ValueError(f"contact_timeconst must be > 0 s, got {self.contact_timeconst}")
        if not self.ground and self.terrain != Flat():
            raise ValueError("a terrain needs ground=True")
        if self.cable_law not in CABLE_LAWS:
            raise ValueError(f"cable_law must be one of {', '.join(CABLE_LAWS)}, got "
                             f"{self.cable_law!r}"[:200])
        margin = self.split_margin
        if not (isinstance(margin, int | float) and not isinstance(margin, bool)
                and math.isfinite(margin) and (margin == 0 or margin >= 1)):
            raise ValueError("split_margin must be 0 (every cable handed to the implicit law's "
                             f"integrator) or a finite number >= 1, got {margin!r}"[:200])
        if self.cone not in _CONES:
            raise ValueError(f"cone must be 'pyramidal' or 'elliptic', got {self.cone!r}")
        if isinstance(self.noslip_iterations, bool) or not isinstance(
                self.noslip_iterations, int) or not 0 <= self.noslip_iterations <= 1000:
            raise ValueError("noslip_iterations must be a whole number in [0, 1000], got "
                             f"{self.noslip_iterations!r}"[:200])
        if self.condim not in (3, 4, 6) or isinstance(self.condim, bool):
            raise ValueError(f"condim must be 3, 4 or 6, got {self.condim!r}"[:200])
        for name in ("torsional_friction", "rolling_friction"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and not isinstance(value, bool)
                    and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0 [m], got {value!r}")

    def geom_friction(self, sliding: float) -> list[float]:
        """MuJoCo's geom friction [sliding, torsional, rolling] for a sliding coefficient."""
        return [sliding, self.torsional_friction, self.rolling_friction]


@dataclasses.dataclass(frozen=True)
class ModelIndex:
    """Ids looked up once after compilation.

    Attributes:
        cables: cable names, in structure order.
        tendon: (n_cables,) tendon id of each cable.
        actuator: (n_cables,) actuator id of each cable.
        bodies: rigid-body names, in group order.
        body: (n_bodies,) MuJoCo body id of each rigid body.
        node_body: node name -> MuJoCo body id (0 for world-fixed nodes).
        node_local: node name -> (3,) node position in its body's frame [m].
        load_nodes: nodes with external force inputs, in input order.
        rest_act: (n_cables,) address in ``act`` of each cable's rest length; its peak tension
            follows it, and a DC motor's line speed follows that.
        beads: the contact cables' bead bodies, in cable and path order.
        bead: (n_beads,) MuJoCo body id of each bead.
    """

    cables: tuple[str, ...]
    tendon: np.ndarray
    actuator: np.ndarray
    bodies: tuple[str, ...]
    body: np.ndarray
    node_body: dict[str, int]
    node_local: dict[str, np.ndarray]
    load_nodes: tuple[str, ...] = ()
    rest_act: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.int32))
    beads: tuple[str, ...] = ()
    bead: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=np.int32))

    def cable_act(self, act: np.ndarray, part: int = 0) -> np.ndarray:
        """Each cable's activation ``part`` (a slot of ``_law_layout.ACT``: A_REST, A_PEAK,
        A_PEAK_SPEED, A_PEAK_POWER) from ``act`` (..., na): a view where every cable has as
        many activations, else a copy."""
        stride = self._act_stride
        if stride:
            return act[..., part:stride * len(self.cables):stride]
        return act[..., self.rest_act + part]

    def cable_peaks(self, act: np.ndarray) -> np.ndarray:
        """(..., 3, n) each cable's running maxima over every step from ``act`` (..., na): the
        load-cell tension [N], the motor's line speed |dl/dt| [m/s], and their product [W]."""
        return np.stack([self.cable_act(act, part)
                         for part in (A_PEAK, A_PEAK_SPEED, A_PEAK_POWER)], axis=-2)

    @functools.cached_property
    def _act_stride(self) -> int:
        """The activations per cable where every cable has as many, else 0 (looked up once:
        the recorder and the checks call :meth:`cable_act` every few steps)."""
        n = len(self.cables)
        return next((stride for stride in range(ACTDIM, DC_ACTDIM + IMPLICIT_EXTRA + 1)
                     if np.array_equal(self.rest_act, np.arange(0, stride * n, stride))), 0)

    def cable_id(self, name: str) -> int:
        """Position of cable ``name`` in the per-cable arrays."""
        try:
            return self.cables.index(name)
        except ValueError:
            raise KeyError(f"unknown cable {name!r}; cables: {list(self.cables)}") from None


@dataclasses.dataclass(frozen=True)
class CompiledModel:
    """A structure compiled to MuJoCo, with its per-cable parameters as arrays.

    Attributes:
        structure: the description it came from.
        world: the world options used.
        model: the MuJoCo model.
        index: id lookups.
        rest_length: (n_cables,) the build pose's rest lengths [m] (the keyframe's).
        inertia_adjusted: names of bodies whose inertia was regularized.
        spec: the ``MjSpec`` the model was compiled from (for export, e.g. ``spec.to_xml()``).
    """

    structure: Structure
    world: WorldOptions
    model: mujoco.MjModel
    index: ModelIndex
    rest_length: np.ndarray
    inertia_adjusted: tuple[str, ...] = ()
    spec: mujoco.MjSpec | None = None

    def __getstate__(self) -> dict[str, object]:
        # an MjSpec does not pickle (the MjModel does): send copies to workers without it
        return {**self.__dict__, "spec": None}

    @property
    def n_cables(self) -> int:
        """Number of cables."""
        return len(self.index.cables)

    def law(self, model: mujoco.MjModel | None = None) -> LawParameters:
        """The cables' law parameters (stiffness, damping, motor limits, impedance gains) as
        live views of ``model``'s arrays: of this model by default, or of a copy of it that a
        simulation steps (``sim.model``, with its controller's gains and any physics scale).

        The parameters are stored only there, where the law reads them, so these views never
        go stale.
        """
        return LawParameters(self.model if model is None else model, self.n_cables)

    @property
    def command(self) -> np.ndarray:
        """(n_cables,) each cable's command at build (the build keyframe's ``ctrl``): its rest
        length, or a PD motor's target (its ``pd_target``, else the cable's build length) [m]."""
        return self.model.key(BUILD_KEY).ctrl[:self.n_cables].copy()

    def with_load_nodes(self, nodes: tuple[str, ...]) -> CompiledModel:
        """This model with force inputs at ``nodes`` (itself if it already has them)."""
        wanted = tuple(dict.fromkeys((*self.index.load_nodes, *nodes)))
        if wanted == self.index.load_nodes:
            return self
        return compile_structure(self.structure, self.world, load_nodes=wanted)


def _regularize(name: str, props: MassProperties, world: WorldOptions) -> tuple[np.ndarray, bool]:
    """Inertia tensor with tiny principal moments raised to ``min_inertia_ratio`` of the largest."""
    moments, axes = np.linalg.eigh(props.inertia)
    floor = world.min_inertia_ratio * moments[-1]
    if moments[0] >= floor:
        return props.inertia, False
    if world.thin_body == "refuse":
        raise ModelError(
            f"rigid body {name!r}: smallest principal inertia {moments[0]:.3g} kg m^2 is below "
            f"{world.min_inertia_ratio} of the largest ({moments[-1]:.3g}); MuJoCo spins such thin "
            "bodies up. Use thin_body='regularize', thicken the rod, or join it to other rods."
        )
    raised = np.maximum(moments, floor)
    return axes @ np.diag(raised) @ axes.T, True


_WARNED: set[str] = set()  # thin-body warnings already given (each once per process)


def _warn_thin(structure: Structure, raised: list[tuple[str, float, float]],
               world: WorldOptions) -> None:
    """One WARNING for the bodies whose smallest principal inertia was raised, with figures."""
    if not raised:
        return
    names = ", ".join(n for n, _, _ in raised[:4]) + (" ..." if len(raised) > 4 else "")
    low, high = min(r[1] for r in raised), max(r[2] for r in raised)
    factor = max(new / old if old > 0 else np.inf for _, old, new in raised)
    message = (f"{structure.name}: {len(raised)} rigid bod{'y' if len(raised) == 1 else 'ies'} "
               f"({names}): smallest principal inertia raised to {world.min_inertia_ratio:g} of "
               f"the largest (from {low:.3g} to {high:.3g} kg m^2, up to {factor:.3g}x; MuJoCo "
               "spins thin rods up), which slows their spin about their axis; give the rods their "
               "axial_inertia in the structure file (kept as given), a larger radius or point "
               "masses, or turn the floor off with --inertia-floor 0 "
               "(WorldOptions(min_inertia_ratio=0))")
    if message not in _WARNED:
        _WARNED.add(message)
        log.warning(message)


def compile_structure(structure: Structure, world: WorldOptions | None = None,
                      load_nodes: tuple[str, ...] = ()) -> CompiledModel:
    """Builds the MuJoCo model of ``structure`` in ``world``.

    Every cable is a tendon with one actuator that carries the cable law (rest length and peak
    tension in its activations, its command in ``ctrl``); ``load_nodes`` each get three
    world-frame force inputs in ``ctrl`` after the cables'. The keyframe ``build`` holds the
    build pose with the build rest lengths.

    Raises:
        ModelError: a rigid body would be unsound (see ``WorldOptions.thin_body``), or a load
            node is unknown or fixed to the world.
    """
    world = world or WorldOptions()
    if world.ground:
        structure = place_on_terrain(structure, world.terrain)
    spec = mujoco.MjSpec()
    spec.modelname = structure.name
    spec.option.timestep = world.timestep
    spec.option.gravity = list(world.gravity)
    spec.option.integrator = INTEGRATORS[world.cable_law]
    if not world.midphase:
        spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_MIDPHASE
    spec.option.cone = _CONES[world.cone]
    spec.option.noslip_iterations = world.noslip_iterations
    # without self-collision a robot geom only meets geoms whose contype has bit 1 (the ground)
    robot_contype = 1 if world.self_collision else 0
    spec.compiler.autolimits = True
    spec.worldbody.add_light(pos=[0, 0, 5], dir=[0, 0, -1])
    if world.ground:
        add_terrain(spec, world.terrain, world.contact_timeconst)
        for geom in spec.geoms:  # a terrain that outranks the robot: the world's contact model
            if geom.priority > _ROBOT_PRIORITY:
                geom.condim = world.condim
                geom.friction[1:] = [world.torsional_friction, world.rolling_friction]
    rods = {r.name: r for r in structure.rods}
    masses = {p.node: p for p in structure.point_masses}
    node_body: dict[str, str] = {}
    node_local: dict[str, np.ndarray] = {}
    adjusted: list[str] = []
    raised: list[tuple[str, float, float]] = []  # (body, smallest moment, raised) [kg m^2]
    moving_mass = 0.0
    for group in structure.rigid_groups():
        props = mass_properties(structure, group)
        moving_mass += 0.0 if group.fixed else props.mass
        given = bool(group.rods) and all(rods[r].axial_inertia is not None for r in group.rods)
        inertia, changed = (props.inertia, False) if given else \
            _regularize(group.name, props, world)
        if changed:
            adjusted.append(group.name)
            raised.append((group.name, float(np.linalg.eigvalsh(props.inertia)[0]),
                           float(np.linalg.eigvalsh(inertia)[0])))
        body = spec.worldbody.add_body(name=group.name, pos=props.com.tolist())
        if not group.fixed:
            body.add_freejoint(name=f"{group.name}_free")
        body.explicitinertial = True
        body.mass = props.mass
        body.ipos = [0, 0, 0]
        body.fullinertia = [inertia[0, 0], inertia[1, 1], inertia[2, 2],
                            inertia[0, 1], inertia[0, 2], inertia[1, 2]]
        for node in group.nodes:
            node_body[node] = group.name
            node_local[node] = structure.position(node) - props.com
        for name in group.rods:
            rod = rods[name]
            ends = [node_local[n] for n in rod.nodes]
            body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                          fromto=np.concatenate(ends).tolist(), size=[rod.radius, 0, 0],
                          friction=world.geom_friction(rod.friction), condim=world.condim,
                          priority=_ROBOT_PRIORITY, contype=robot_contype, conaffinity=1,
                          solref=[world.contact_timeconst,
                                  restitution_dampratio(rod.restitution)],
                          rgba=[0.25, 0.25, 0.3, 1])
        for node in group.nodes:
            if node in masses:
                touching = [r for r in structure.rods if node in r.nodes]
                # a sphere inside a rod's end cap adds no surface, only duplicate contacts
                covered = any(r.radius >= masses[node].radius for r in touching)
                friction = max((r.friction for r in touching), default=1.0)
                body.add_geom(name=f"mass_{node}", type=mujoco.mjtGeom.mjGEOM_SPHERE,
                              pos=node_local[node].tolist(), size=[masses[node].radius, 0, 0],
                              friction=world.geom_friction(friction), condim=world.condim,
                              priority=_ROBOT_PRIORITY,
                              contype=0 if covered else robot_contype,
                              conaffinity=0 if covered else 1,
                              solref=[world.contact_timeconst, 1.0],
                              rgba=[0.7, 0.45, 0.2, 1])
    for anchor in structure.nodes:
        if anchor.name not in node_body:  # a fixed anchor point in the world
            node_body[anchor.name] = "world"
            node_local[anchor.name] = structure.position(anchor.name)
    _warn_thin(structure, raised, world)
    _beads.check_beads(structure, world.timestep, moving_mass)
    bodies = {b.name: b for b in spec.bodies}
    bead_paths: dict[str, list[str]] = {}  # contact cables: every site along the path
    for cable in structure.cables:
        tendon = spec.add_tendon(name=cable.name, rgba=[0.8, 0.1, 0.1, 1], width=0.002)
        # anchor site, a site at each via node (MuJoCo pulls each along both spans), anchor site
        sites = [f"{cable.name}_0", *(f"{cable.name}_via{k}" for k in range(len(cable.via))),
                 f"{cable.name}_1"]
        points = structure.cable_points(cable)
        # a contact cable also runs over the bead sites of each span (docs/cables.md)
        beads = _beads.add_beads(spec, cable, points, world.timestep, world.contact_timeconst) \
            if cable.contact is not None else None
        for k, (site, node, point) in enumerate(zip(sites, cable.path, points, strict=True)):
            body = bodies[node_body[node]]
            local = point - (structure.position(node) - node_local[node])
            body.add_site(name=site, pos=local.tolist(), size=[0.002, 0, 0])
            for bead in beads[k - 1] if beads and k else ():
                tendon.wrap_site(bead)
                bead_paths.setdefault(cable.name, [sites[0]]).append(bead)
            tendon.wrap_site(site)
            if beads and k:
                bead_paths[cable.name].append(site)
            if k == 0:  # between the anchors: the rods the cable wraps around, in order
                for j, (wrapped, side) in enumerate(zip(cable.wrap, structure.wrap_sides(cable),
                                                        strict=True)):
                    geom = _wrap_geom(spec, bodies, rods[wrapped], node_body, node_local)
                    tendon.wrap_geom(geom, _side_site(spec, structure, bodies, rods[wrapped],
                                                      f"{cable.name}_side{j}", side, node_body,
                                                      node_local))
    for cable in structure.cables:  # cable actuators first: ids 0..n_cables-1
        _add_cable_actuator(spec, cable, structure.rest_length(cable), world.cable_law)
    _add_load_actuators(spec, bodies, node_body, node_local, load_nodes)
    _add_bead_springs(spec, structure, world, bead_paths)
    rest = [structure.rest_length(c) for c in structure.cables]
    # per cable: rest length, peak tension, line speed and power 0 (and a DC motor's spool at
    # rest; the implicit law's pull: the law sets it in the first step)
    pull = (0.0,) * (IMPLICIT_EXTRA if world.cable_law != LAW_EXPLICIT else 0)
    act = [v for c, r in zip(structure.cables, rest, strict=True)
           for v in (r,) + (0.0,) * ((ACTDIM if c.motor.dc is None else DC_ACTDIM) - 1) + pull]
    spec.add_key(name=BUILD_KEY, act=act, ctrl=rest + [0.0] * (3 * len(load_nodes)))
    model = _compile_spec(spec)
    if world.cable_law == LAW_IMPLICIT and world.split_margin > 0:
        model = _split_cables(spec, model, world)
    _check_wraps(structure, model)
    _relax_pd_targets(structure, spec, model)
    return dataclasses.replace(
        _assemble(structure, world, model, node_body, node_local, tuple(adjusted), load_nodes),
        spec=spec)


def _split_cables(spec: mujoco.MjSpec, model: mujoco.MjModel,
                  world: WorldOptions) -> mujoco.MjModel:
    """The model with the cables that :func:`tensim.model._split.split_cables` keeps explicit
    on the explicit law (their pull dropped from the keyframe), on MuJoCo's Euler step where
    none is handed over; ``model`` itself where every cable is."""
    cables = np.flatnonzero(implicit(model))
    explicit = split_cables(model, model.key(BUILD_KEY).id, cables, world.timestep,
                            world.split_margin)
    if not explicit.any():
        return model
    key = spec.key(BUILD_KEY)
    act = list(key.act)
    for i in sorted(cables[explicit], reverse=True):  # the pull is each cable's last slot
        _set_law(spec.actuators[i], LAW_EXPLICIT)
        del act[model.actuator_actadr[i] + model.actuator_actnum[i] - 1]
    key.act = act
    if explicit.all():
        spec.option.integrator = INTEGRATORS[LAW_EXPLICIT]
    return _compile_spec(spec)


def _relax_pd_targets(structure: Structure, spec: mujoco.MjSpec,
                      model: mujoco.MjModel) -> None:
    """Starts each PD motor's target (the build keyframe's ``ctrl``) at its ``pd_target``, or
    at its cable's build length, where it pulls nothing."""
    pd = [i for i, c in enumerate(structure.cables) if c.motor.pd]
    if not pd:
        return
    key = model.key(BUILD_KEY).id
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, key)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_tendon(model, data)
    for i in pd:
        target = structure.cables[i].motor.pd_target
        model.key_ctrl[key, i] = data.ten_length[model.actuator_trnid[i, 0]] \
            if target is None else target
    spec.key(BUILD_KEY).ctrl = model.key_ctrl[key].tolist()


def _compile_spec(spec: mujoco.MjSpec) -> mujoco.MjModel:
    """``spec.compile()``, with Python actuator callbacks set aside: MuJoCo's compiler runs
    them on a model Python cannot see, which fails (compiled ones are fine)."""
    saved = mujoco.get_mjcb_act_dyn(), mujoco.get_mjcb_act_bias()
    python = [callable(c) and not hasattr(c, "argtypes") for c in saved]
    if any(python):
        mujoco.set_mjcb_act_dyn(None)
        mujoco.set_mjcb_act_bias(None)
    try:
        return spec.compile()
    finally:
        if any(python):
            mujoco.set_mjcb_act_dyn(saved[0])
            mujoco.set_mjcb_act_bias(saved[1])


def without_cable_law(compiled: CompiledModel) -> mujoco.MjSpec:
    """A copy of the model's spec with each cable actuator a plain force input (ctrl = the
    actuator force [N], no dynamics, no activations) and no keyframe: the robot as MuJoCo
    alone sees it, for other tools and for engine-alone comparisons."""
    source = compiled.spec or compile_structure(compiled.structure, compiled.world,
                                                compiled.index.load_nodes).spec
    assert source is not None
    spec = source.copy()
    for actuator in spec.actuators[:compiled.n_cables]:
        actuator.dyntype = mujoco.mjtDyn.mjDYN_NONE
        actuator.actdim = -1
        actuator.actearly = False
        actuator.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        actuator.gainprm[:] = [1.0] + [0.0] * 9
        actuator.forcelimited = False
        actuator.biastype = mujoco.mjtBias.mjBIAS_NONE
        actuator.dynprm[:] = [1.0] + [0.0] * 9
        actuator.biasprm[:] = [0.0] * 10
    for key in list(spec.keys):
        spec.delete(key)
    return spec


def compile_spec(spec: mujoco.MjSpec) -> mujoco.MjModel:
    """Compiles a spec (see :func:`_compile_spec`)."""
    return _compile_spec(spec)


def _wrap_geom(spec: mujoco.MjSpec, bodies: dict[str, mujoco.MjsBody], rod: Rod,
               node_body: dict[str, str], node_local: dict[str, np.ndarray]) -> str:
    """The invisible, contact-free cylinder of ``rod`` that cables wrap around (made once)."""
    name = f"wrap_{rod.name}"
    if spec.geom(name) is None:
        ends = [node_local[n] for n in rod.nodes]
        bodies[node_body[rod.nodes[0]]].add_geom(
            name=name, type=mujoco.mjtGeom.mjGEOM_CYLINDER, fromto=np.concatenate(ends).tolist(),
            size=[rod.radius, 0, 0], contype=0, conaffinity=0, group=5, rgba=[0, 0, 0, 0])
    return name


def _check_wraps(structure: Structure, model: mujoco.MjModel) -> None:
    """Refuses a wrapped cable that MuJoCo runs straight past one of its rods in the build pose
    (a wrap it cannot hold on its side: more than about half a turn from a line clear of the
    rod), rather than simulate a straight cable."""
    wrapped = [c for c in structure.cables if c.wrap]
    if not wrapped:
        return
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key(BUILD_KEY).id)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_tendon(model, data)
    for cable in wrapped:
        t = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TENDON, cable.name)
        objects = data.wrap_obj[data.ten_wrapadr[t]:data.ten_wrapadr[t] + data.ten_wrapnum[t]]
        touching = [side[2] for side in structure.wrap_sides(cable)]
        for rod in (r for r, touches in zip(cable.wrap, touching, strict=True) if touches):
            geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"wrap_{rod}")
            if not np.any(objects == geom):
                raise ModelError(
                    f"cable {cable.name!r}: MuJoCo does not wrap it over rod {rod!r} in the build "
                    "pose (its wrap would run straight); move the anchors so that the cable "
                    "turns by at most half a turn around the rod, or give side")


def _side_site(spec: mujoco.MjSpec, structure: Structure, bodies: dict[str, mujoco.MjsBody],
               rod: Rod, name: str, side: tuple[np.ndarray, np.ndarray, bool],
               node_body: dict[str, str], node_local: dict[str, np.ndarray]) -> str:
    """A site on ``rod``'s body, off its surface on the side the cable runs over: MuJoCo's
    wrap then holds that side (without one it wraps only where the straight line crosses the
    rod, the shorter way round)."""
    centre, direction, _ = side
    node = rod.nodes[0]
    point = centre + 2 * rod.radius * direction
    local = point - (structure.position(node) - node_local[node])
    bodies[node_body[node]].add_site(name=name, pos=local.tolist(), size=[0.001, 0, 0], group=5)
    return name


def _add_cable_actuator(spec: mujoco.MjSpec, cable: Cable, rest_length: float,
                        law: str = LAW_EXPLICIT) -> None:
    """The cable's actuator: user dynamics (motor, peak), a gain, user bias (tension).

    Its parameters go into the slots that ``tensim.model._law_layout`` names (every body of the
    law reads them from there): rest mode, the motor's limits, L* = the build rest length;
    k and b in gainprm; act = [rest length, peak tension, peak line speed, peak power]
    (``_law_layout.ACT``); ctrl = the command. A DC motor adds its line speed to act and its
    parameters, in cable coordinates, to biasprm.
    The explicit law's gain is fixed at zero. The implicit law's is MuJoCo's affine one
    (k x + b xdot) times the pull, a last activation the law keeps at -theta while the cable is
    taut (read after this step's update: ``actearly``), and its force is limited to <= 0
    (tension only), so that MuJoCo drops the term's derivatives while it clamps.
    """
    actuator = spec.add_actuator(name=cable.name, target=cable.name,
                                 trntype=mujoco.mjtTrn.mjTRN_TENDON)
    actuator.dyntype = mujoco.mjtDyn.mjDYN_USER
    actuator.gainprm[:] = gainprm(cable.stiffness, cable.damping, cable.motor.pd_stiffness,
                                  cable.motor.pd_damping)
    actuator.gainprm[0] = GAIN
    actuator.biastype = mujoco.mjtBias.mjBIAS_USER
    motor, dc = cable.motor, cable.motor.dc
    actuator.dynprm[:] = dynprm(MODE_PD if motor.pd else MODE_REST, motor.max_speed,
                                motor.max_tension, motor.min_rest_length, motor.min_length,
                                0.0, 0.0, 0.0, rest_length)
    actuator.actdim = ACTDIM if dc is None else DC_ACTDIM
    _set_law(actuator, law)
    slots = None
    if dc is not None:
        line = dc.line()
        slots = {"stall_force": line["stall_force"], "no_load_speed": line["no_load_line_speed"],
                 "mass": line["mass"], "viscous": line["viscous"], "coulomb": line["coulomb"],
                 "position_time": dc.position_time,
                 "back_drivable": 1.0 if dc.back_drivable else 0.0}
    actuator.biasprm[:] = biasprm({**(slots or {}), "lag_time": motor.lag_time,
                                   "saturate": 1.0 if motor.saturate else 0.0})


def _set_law(actuator: mujoco.MjsActuator, law: str) -> None:
    """Puts a cable actuator (its ``actdim`` already set) on ``law``: the explicit law's fixed
    gain, or the implicit laws' affine gain, tension-only force range and pull activation."""
    implicit = law != LAW_EXPLICIT
    was = actuator.gaintype == mujoco.mjtGain.mjGAIN_AFFINE
    actuator.gaintype = mujoco.mjtGain.mjGAIN_AFFINE if implicit else mujoco.mjtGain.mjGAIN_FIXED
    actuator.actearly = implicit
    # the explicit law keeps MjSpec's defaults (no force range)
    actuator.forcelimited = True if implicit else mujoco.mjtLimited.mjLIMITED_AUTO
    actuator.forcerange = [-np.inf, 0.0] if implicit else [0.0, 0.0]
    actuator.actdim += IMPLICIT_EXTRA * (int(implicit) - int(was))


def _add_bead_springs(spec: mujoco.MjSpec, structure: Structure, world: WorldOptions,
                      paths: dict[str, list[str]]) -> None:
    """The span springs of the contact cables (after every cable's tendon), and the world's
    geoms made touchable by their beads."""
    for name, path in paths.items():
        cable = structure.cable(name)
        _beads.add_span_springs(spec, cable, path, structure.cable_points(cable), world.timestep)
    if paths:
        _beads.let_world_touch_beads(spec)


def _add_load_actuators(spec: mujoco.MjSpec, bodies: dict[str, mujoco.MjsBody],
                        node_body: dict[str, str], node_local: dict[str, np.ndarray],
                        load_nodes: tuple[str, ...]) -> None:
    """Three world-frame force inputs (x, y, z) [N] at each node that takes external loads."""
    if not load_nodes:
        return
    spec.worldbody.add_site(name=WORLD_FRAME_SITE, size=[0.001, 0, 0])
    for node in load_nodes:
        if node not in node_body:
            raise ModelError(f"load at unknown node {node!r}")
        if node_body[node] == "world":
            raise ModelError(f"load at {node!r}: the node is fixed to the world")
        bodies[node_body[node]].add_site(name=f"load_{node}", pos=node_local[node].tolist(),
                                         size=[0.002, 0, 0])
        for axis, gear in zip("xyz", np.eye(3), strict=True):
            spec.add_actuator(name=f"load_{node}_{axis}", target=f"load_{node}",
                              trntype=mujoco.mjtTrn.mjTRN_SITE, refsite=WORLD_FRAME_SITE,
                              gear=[*gear, 0.0, 0.0, 0.0])


def _assemble(structure: Structure, world: WorldOptions, model: mujoco.MjModel,
              node_body: dict[str, str], node_local: dict[str, np.ndarray],
              adjusted: tuple[str, ...], load_nodes: tuple[str, ...]) -> CompiledModel:
    cables = structure.cables
    names = tuple(c.name for c in cables)
    groups = tuple(g.name for g in structure.rigid_groups())

    def ids(kind: mujoco.mjtObj, items: tuple[str, ...]) -> np.ndarray:
        return np.array([mujoco.mj_name2id(model, kind, n) for n in items], dtype=np.int32)

    index = ModelIndex(
        cables=names,
        tendon=ids(mujoco.mjtObj.mjOBJ_TENDON, names),
        actuator=ids(mujoco.mjtObj.mjOBJ_ACTUATOR, names),
        bodies=groups,
        body=ids(mujoco.mjtObj.mjOBJ_BODY, groups),
        node_body={n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, b)
                   for n, b in node_body.items()},
        node_local={n: np.asarray(p, dtype=float) for n, p in node_local.items()},
        load_nodes=load_nodes,
        rest_act=model.actuator_actadr[ids(mujoco.mjtObj.mjOBJ_ACTUATOR, names)].astype(
            np.int32),
        beads=(beads := _beads.bead_bodies(model, structure)),
        bead=ids(mujoco.mjtObj.mjOBJ_BODY, beads),
    )

    def column(get: object) -> np.ndarray:
        return np.array([get(c) for c in cables], dtype=float)  # type: ignore[operator]

    return CompiledModel(
        structure=structure,
        world=world,
        model=model,
        index=index,
        rest_length=column(structure.rest_length),
        inertia_adjusted=adjusted,
    )
