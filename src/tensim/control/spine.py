"""CPGs on any structure: the coupling rule, the learnable parameter layout and the gait.

Every actuated cable has an oscillator, coupled to every other cable that shares a rigid body
with it (paper section II-B; :func:`shared_body_pairs`). :func:`spine_parameters` lays out the
learnable parameters with the symmetry rule below; :meth:`CPGParameters.gait` turns one
parameter vector into a :class:`SpineCPG`. Nothing here is particular to a spine: the rule
reads two things off each cable's tags, and a robot without those tags gets one class per
coupled pair of cables.

- its *position* along the robot: its ``joint_<j>`` tag, else 0 (:func:`cable_position`);
- its *kind*: its ``kind_<name>`` tag, else its name without the ``_<j>`` suffix of its
  joint tag, else its name (:func:`cable_kind`). Cables of one kind are symmetric copies.

Symmetry rule. A directed coupling i <- j (i driven, j driving) belongs to the class
(d, {kind_i, kind_j}): d = position(i) − position(j) is the joint offset, and the *unordered*
pair of kinds ignores which of the two cables is driven. Every coupling of a class shares one
weight and one phase offset. This is the "upper triangular" edge table of the original
simulator's spine CPG controller (NTRT BaseSpineCPGControl / tgCPGStringControl): per joint
offset, a symmetric kind x kind table, with the diagonal of offset 0 (a cable with itself) left
out. With K kinds per joint that is K(K−1)/2 classes at d = 0 and K(K+1)/2 at each of d = ±1.
Tetraspine has K = 6, and a cable couples only to cables of its own or a neighbouring joint
(those share a segment), so its 132 couplings fall in 15 + 21 + 21 = 57 classes, i.e. 114
coupling parameters, plus one shared amplitude and one shared frequency: 116 parameters, for any
spine of 3 or more segments (the classes repeat along the spine; a 2-segment spine has only the
15 offset-0 classes). Within a class at d = 0, a coupling and its reverse (i <- j and j <- i)
share a parameter; the reverse gets the negated phase (φ_ji = −φ_ij), so a pair of cables has
one consistent phase lag. The original simulator gave both the same phase, which can only lock
at 0 or π; the negation is this package's choice. An untagged robot whose cables all couple
(a 3-bar prism: 9 cables, 72 couplings) gets 36 classes, one per pair: 74 parameters.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Sequence

import numpy as np

from tensim.control._common import has_joint_tag, joint_index, per_item
from tensim.control.cpg import (
    DEFAULT_SETTINGS,
    Coupling,
    CPGNetwork,
    SolverSettings,
    _Arrays,
    _network_arrays,
    _solve,
)
from tensim.control.parameters import Bounds, Parameter, ParameterLayout
from tensim.control.velocity_table import VelocityTable
from tensim.structure import Cable, Structure


def _cable_names(structure: Structure, cables: Sequence[str] | None) -> tuple[str, ...]:
    names = tuple(c.name for c in structure.cables) if cables is None else tuple(cables)
    for name in names:
        structure.cable(name)  # KeyError for an unknown cable
    if not names or len(set(names)) != len(names):
        raise ValueError(f"cables must be unique and at least one, got {names}")
    return names


def shared_body_pairs(structure: Structure, cables: Sequence[str] | None = None
                      ) -> tuple[tuple[int, int], ...]:
    """Directed pairs (i, j), i != j, of cables whose endpoints share a rigid body.

    Bodies are ``structure.rigid_groups()``; a node on no body (fixed to the world without a
    mass) couples nothing.

    Args:
        structure: the robot.
        cables: the cables, indexed in this order (None: every cable in structure order).
    """
    names = _cable_names(structure, cables)
    body = {node: g.name for g in structure.rigid_groups() for node in g.nodes}
    bodies = [{body[n] for n in structure.cable(c).nodes if n in body} for c in names]
    m = len(names)
    return tuple((i, j) for i in range(m) for j in range(m) if i != j and bodies[i] & bodies[j])


def spine_network(structure: Structure, cables: Sequence[str] | None,
                  frequency: float | Sequence[float], amplitude: float | Sequence[float],
                  weights: float | Callable[[str, str], float],
                  phases: float | Callable[[str, str], float],
                  a: float = 20.0) -> CPGNetwork:
    """One oscillator per cable, coupled to every cable that shares a rigid body with it.

    Args:
        structure: the robot.
        cables: the actuated cables (None: every cable).
        frequency: ν [Hz], shared or per cable.
        amplitude: R [m/s], shared or per cable.
        weights: w_ij [rad/m], shared or a function of (driven cable, driving cable).
        phases: φ_ij [rad], shared or a function of (driven cable, driving cable).
        a: convergence constant [1/s].
    """
    names = _cable_names(structure, cables)

    def value(spec: float | Callable[[str, str], float], i: int, j: int) -> float:
        return float(spec(names[i], names[j])) if callable(spec) else float(spec)

    couplings = tuple(Coupling(i, j, value(weights, i, j), value(phases, i, j))
                      for i, j in shared_body_pairs(structure, names))
    return CPGNetwork(names, frequency, amplitude, a, couplings)


# default ranges: r_j w_ij (the coupling rate) is R·w, so with R ~ 0.02 m/s a weight of 20 rad/m
# gives ~0.4 rad/s; the amplitude bound matches Tetraspine's 0.07 m/s motors.
DEFAULT_WEIGHT = Bounds(0.0, 100.0, 20.0)  # rad/m
DEFAULT_PHASE = Bounds(-math.pi, math.pi, 0.0)  # rad
DEFAULT_AMPLITUDE = Bounds(0.0, 0.07, 0.02)  # m/s
DEFAULT_FREQUENCY = Bounds(0.1, 2.0, 0.5)  # Hz


@dataclasses.dataclass(frozen=True)
class CPGParameters(ParameterLayout):
    """The learnable parameters of a CPG with shared couplings, one amplitude and frequency.

    The vector is ``[weight/c0, phase/c0, weight/c1, phase/c1, ..., amplitude, frequency]``
    over the coupling classes ``classes``; couplings of a class share its weight and phase.

    Attributes:
        oscillators: the oscillators' (cables') names.
        classes: coupling class labels ``<joint offset>/<kind>|<kind>``.
        edges: (i, j, class, sign) per coupling i <- j: it gets the class's weight and
            sign (±1) times its phase.
        weight, phase, amplitude, frequency: ranges [rad/m, rad, m/s, Hz].
        convergence: a [1/s] of every oscillator (not learned).
    """

    oscillators: tuple[str, ...]
    classes: tuple[str, ...]
    edges: tuple[tuple[int, int, int, int], ...]
    weight: Bounds = DEFAULT_WEIGHT
    phase: Bounds = DEFAULT_PHASE
    amplitude: Bounds = DEFAULT_AMPLITUDE
    frequency: Bounds = DEFAULT_FREQUENCY
    convergence: float = 20.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "oscillators", tuple(self.oscillators))
        object.__setattr__(self, "classes", tuple(self.classes))
        object.__setattr__(self, "edges", tuple(tuple(int(v) for v in e) for e in self.edges))
        if len(set(self.classes)) != len(self.classes):
            raise ValueError("coupling class labels must be unique")
        n, k = len(self.oscillators), len(self.classes)
        for i, j, c, sign in self.edges:
            if not (0 <= i < n and 0 <= j < n and i != j and 0 <= c < k and sign in (-1, 1)):
                raise ValueError(f"invalid edge {(i, j, c, sign)} for {n} oscillators and "
                                 f"{k} classes")
        unused = set(range(k)) - {e[2] for e in self.edges}
        if unused:
            raise ValueError(f"coupling classes {[self.classes[c] for c in sorted(unused)]} "
                             "have no coupling")
        if not (math.isfinite(self.convergence) and self.convergence > 0):
            raise ValueError(f"convergence must be > 0 1/s, got {self.convergence}")

    # -- the vector layout --------------------------------------------------------------------

    @property
    def size(self) -> int:
        """Number of parameters: 2 per coupling class + amplitude + frequency."""
        return 2 * len(self.classes) + 2

    @functools.cached_property
    def parameters(self) -> tuple[Parameter, ...]:
        """The entries, in vector order (made once: every bounds check reads them)."""
        pairs = [(Parameter(f"weight/{c}", self.weight), Parameter(f"phase/{c}", self.phase))
                 for c in self.classes]
        return (*(p for pair in pairs for p in pair), Parameter("amplitude", self.amplitude),
                Parameter("frequency", self.frequency))

    def network(self, values: Sequence[float] | np.ndarray | None = None) -> CPGNetwork:
        """The CPG for a parameter vector (None: the nominal values).

        Raises:
            ValueError: a wrong shape, or values outside the bounds.
        """
        v = self.check_bounds(self.nominal if values is None else values)
        k = len(self.classes)
        weights, phases = v[0:2 * k:2], v[1:2 * k:2]
        couplings = tuple(Coupling(i, j, weights[c], sign * phases[c])
                          for i, j, c, sign in self.edges)
        return CPGNetwork(self.oscillators, float(v[-1]), float(v[-2]), self.convergence,
                          couplings)

    @functools.cached_property
    def _edge_array(self) -> np.ndarray:
        return np.array(self.edges, dtype=np.intp).reshape(-1, 4)

    def _arrays(self, values: Sequence[float] | np.ndarray) -> _Arrays:
        """:meth:`network`'s arrays, the same numbers without a :class:`Coupling` per edge."""
        v = self.check_bounds(values)
        if v[-1] < 0 or v[-2] < 0:
            return _network_arrays(self.network(v))  # CPGNetwork refuses them, naming the field
        k, n = len(self.classes), len(self.oscillators)
        i, j, c, sign = self._edge_array.T
        return _Arrays(np.full(n, 2 * np.pi * float(v[-1])), np.full(n, float(v[-2])),
                       np.full(n, self.convergence), i, j, v[0:2 * k:2][c],
                       sign * v[1:2 * k:2][c])

    def gait(self, values: Sequence[float] | np.ndarray | None = None, *,
             initial_phase: Sequence[float] | None = None,
             initial_amplitude: float = 0.0) -> SpineCPG:
        """The gait for a parameter vector (None: the nominal values)."""
        v = self.check_bounds(self.nominal if values is None else values)
        return SpineCPG(self, tuple(float(x) for x in v), initial_phase, initial_amplitude)


def cable_position(cable: Cable) -> int:
    """A cable's joint along the robot: its ``joint_<j>`` tag, else 0.

    Raises:
        ValueError: more than one ``joint_<j>`` tag.
    """
    return joint_index(cable) if has_joint_tag(cable) else 0


def cable_kind(cable: Cable) -> str:
    """A cable's symmetry kind: its ``kind_<name>`` tag, else its name without the ``_<j>`` of
    its joint tag (``outer_top_2`` -> ``outer_top``), else its name.

    Raises:
        ValueError: more than one ``kind_<name>`` tag.
    """
    kinds = [t.removeprefix("kind_") for t in cable.tags if t.startswith("kind_")]
    if len(kinds) > 1:
        raise ValueError(f"cable {cable.name!r} has {len(kinds)} 'kind_<name>' tags {kinds}; a "
                         "cable has one symmetry kind")
    if kinds:
        return kinds[0]
    if has_joint_tag(cable):
        return cable.name.removesuffix(f"_{joint_index(cable)}")
    return cable.name


def _offset_label(offset: int) -> str:
    return f"{offset:+d}" if offset else "0"


def spine_parameters(structure: Structure, cables: Sequence[str] | None = None, *,
                     weight: Bounds = DEFAULT_WEIGHT, phase: Bounds = DEFAULT_PHASE,
                     amplitude: Bounds = DEFAULT_AMPLITUDE,
                     frequency: Bounds = DEFAULT_FREQUENCY, convergence: float = 20.0,
                     kind: Callable[[Cable], str] = cable_kind,
                     joint: Callable[[Cable], int] = cable_position) -> CPGParameters:
    """The parameter layout of a CPG on any structure with the module's symmetry rule.

    The couplings are those of :func:`spine_network`; coupling i <- j belongs to the class
    (joint(i) − joint(j), {kind(i), kind(j)}); see the module docstring. Tetraspine3 gives 57
    classes, 116 parameters.

    Args:
        structure: the spine.
        cables: the actuated cables (None: every cable).
        weight, phase, amplitude, frequency: ranges [rad/m, rad, m/s, Hz].
        convergence: a [1/s].
        kind: a cable's symmetry kind (default :func:`cable_kind`).
        joint: a cable's joint index (default :func:`cable_position`).
    """
    names = _cable_names(structure, cables)
    kinds = [kind(structure.cable(n)) for n in names]
    joints = [joint(structure.cable(n)) for n in names]
    rank = {k: r for r, k in enumerate(dict.fromkeys(kinds))}
    keyed = []
    for i, j in shared_body_pairs(structure, names):
        offset = joints[i] - joints[j]
        first, second = sorted((i, j), key=lambda c: (rank[kinds[c]], c))
        sign = -1 if offset == 0 and first != i else 1
        keyed.append(((abs(offset), -offset, rank[kinds[first]], rank[kinds[second]]),
                      f"{_offset_label(offset)}/{kinds[first]}|{kinds[second]}", i, j, sign))
    labels = dict.fromkeys(label for _, label, *_ in sorted(keyed, key=lambda e: e[0]))
    index = {label: c for c, label in enumerate(labels)}
    edges = tuple((i, j, index[label], sign) for _, label, i, j, sign in keyed)
    return CPGParameters(names, tuple(labels), edges, weight, phase, amplitude, frequency,
                         convergence)

@dataclasses.dataclass(frozen=True)
class SpineCPG:
    """A spine CPG gait: a parameter layout and one vector of values, plus the initial state.

    Attributes:
        layout: the parameter layout.
        values: the parameter vector, within the layout's bounds.
        initial_phase: θ(0) per oscillator [rad] (None: all 0).
        initial_amplitude: r(0) [m/s].
        settings: solver tolerances and guards.
    """

    layout: CPGParameters
    values: tuple[float, ...]
    initial_phase: Sequence[float] | None = None
    initial_amplitude: float = 0.0
    settings: SolverSettings = DEFAULT_SETTINGS

    def __post_init__(self) -> None:
        object.__setattr__(self, "values", tuple(float(v) for v in
                                                 self.layout.check_bounds(self.values)))
        if self.initial_phase is not None:
            object.__setattr__(self, "initial_phase", per_item(
                self.initial_phase, len(self.layout.oscillators), "initial_phase",
                "oscillator"))

    @property
    def cables(self) -> tuple[str, ...]:
        """The driven cables, in column order."""
        return self.layout.oscillators

    def network(self) -> CPGNetwork:
        """The oscillators and couplings these values give."""
        return self.layout.network(self.values)

    def velocity_table(self, duration: float, period: float) -> VelocityTable:
        """The CPG output V* sampled every ``period`` over ``duration`` [s].

        Raises:
            GaitError: the integration failed or ran away.
        """
        trajectory = _solve(self.layout._arrays(self.values), duration, period,
                            self.initial_phase, self.initial_amplitude, self.settings)
        return VelocityTable(self.cables, period, trajectory.velocity)
