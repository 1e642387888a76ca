"""Turns an MJCF model's bodies into tensim nodes, rods and point masses.

Each body's capsules and cylinders become rods (their axis segments, the ends nodes), its
spheres point masses at nodes, and the sites its tendons use nodes where they sit (snapped onto
the nearest rod axis or sphere centre). A point on a rod between its ends splits the rod there:
rods that share a node are one rigid body in tensim, as they were one body in the file. Masses
are kept: the body's mass and inertia (from an explicit ``inertial`` or from its geoms, as
MuJoCo compiled them) are shared among its rods and spheres by a bounded least-squares fit of
mass, centre of mass and inertia, starting from the geoms' own masses.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from tensim.io._mjcf_motors import NODE_SITE, USER_TEXT
from tensim.io._mjcf_read import GEOM, ROD_GEOMS, Loaded, body_inertia
from tensim.structure import Node, PointMass, Rod
from tensim.structure._mass import _rod_inertia, _shift

TOL = 1e-5  # m: points this close are one node (MJCF numbers carry about 6 digits)
THIN = 0.0101  # a principal moment below this share of the largest is a thin rod's axis:
# MuJoCo and tensim raise it (WorldOptions.min_inertia_ratio), so the fit does not chase it
_NOTE_SHARE = 0.01  # inertia or centre-of-mass differences above 1% are noted
_PULL = 1e-6  # weight of the pull toward the geoms' own masses: it only picks among exact fits


@dataclasses.dataclass
class _Point:
    """A node of one body: where it is, what to call it, whether it is fixed."""

    position: np.ndarray
    hint: str
    fixed: bool
    rank: int = -1  # what gave the name: -1 none, 0 rod end, 1 sphere, 2 site, 3 tensim's mass


@dataclasses.dataclass
class Bodies:
    """The nodes, rods and point masses of every body, and where each used site went.

    Attributes:
        nodes: the nodes.
        rods: the rods.
        point_masses: the point masses.
        site_node: site id -> node name.
        node_body: node name -> id of the file's body that carries it.
        notes: what was approximated, one line each.
    """

    nodes: list[Node] = dataclasses.field(default_factory=list)
    rods: list[Rod] = dataclasses.field(default_factory=list)
    point_masses: list[PointMass] = dataclasses.field(default_factory=list)
    site_node: dict[int, str] = dataclasses.field(default_factory=dict)
    node_body: dict[str, int] = dataclasses.field(default_factory=dict)
    notes: list[str] = dataclasses.field(default_factory=list)


def convert(f: Loaded, used_sites: set[int], contact: dict[int, tuple[float, float]]) -> Bodies:
    """Every body with geoms or used sites, converted (see the module docstring).

    Args:
        f: the loaded file.
        used_sites: ids of the sites that tendons pass through.
        contact: geom id -> (sliding friction, restitution) of its contact with the ground.

    Raises:
        StructureError: a body that cannot be rods and spheres meeting at nodes.
    """
    out = Bodies()
    names: set[str] = set()
    for b in range(f.model.nbody):
        _Body(f, b, used_sites, contact, out, names).convert()
    return out


class _Body:
    """The conversion of one body (its geoms, sites and mass)."""

    def __init__(self, f: Loaded, b: int, used_sites: set[int],
                 contact: dict[int, tuple[float, float]], out: Bodies, names: set[str]):
        m = f.model
        self.f, self.b, self.out, self.names, self.contact = f, b, out, names, contact
        self.name = f.name(mujoco.mjtObj.mjOBJ_BODY, b, f"body{b}") if b else "world"
        self.item = f"body {self.name!r}"
        self.fixed = bool(b == 0 or m.body_jntnum[b] == 0)
        # the world's geoms are its ground and obstacles (tensim builds its own): only its
        # sites count, as anchors
        own = range(m.body_geomadr[b], m.body_geomadr[b] + m.body_geomnum[b]) if b else ()
        geoms = [g for g in own if GEOM(m.geom_type[g]) in (*ROD_GEOMS, GEOM.mjGEOM_SPHERE)
                 and (f.geom_mass[g] > 0 or m.geom_contype[g] or m.geom_conaffinity[g])]
        looks = [self._geom_name(g) for g in own if g not in geoms]
        if b and looks:
            out.notes.append(f"{self.item}: geoms {looks} have no mass and no contact (looks "
                             "only): not imported")
        self.rods = [g for g in geoms if GEOM(m.geom_type[g]) in ROD_GEOMS]
        self.spheres = [g for g in geoms if GEOM(m.geom_type[g]) == GEOM.mjGEOM_SPHERE]
        self.sites = [s for s in range(m.nsite) if m.site_bodyid[s] == b and s in used_sites]
        self.points: list[_Point] = []
        self.sphere_point: dict[int, int] = {}  # sphere geom id -> its point
        self.tensim = f.spec.text(USER_TEXT) is not None  # tensim's own export
        self._names: list[str] | None = None  # the nodes' names, once made

    # -- geometry ----------------------------------------------------------------------------

    def _ends(self, g: int) -> tuple[np.ndarray, np.ndarray]:
        d = self.f.data
        axis = d.geom_xmat[g].reshape(3, 3)[:, 2]
        half = self.f.model.geom_size[g][1]
        return d.geom_xpos[g] - half * axis, d.geom_xpos[g] + half * axis

    def _node(self, position: np.ndarray, hint: str) -> int:
        """Index of the point at ``position`` (made if new)."""
        for k, p in enumerate(self.points):
            if np.linalg.norm(p.position - position) <= TOL:
                return k
        self.points.append(_Point(np.asarray(position, float), hint, self.fixed))
        return len(self.points) - 1

    def _place(self, position: np.ndarray, what: str, spheres: bool = True) -> tuple[int, float]:
        """The node for a point on this body: a sphere centre within its radius (unless
        ``spheres`` is false), else the nearest point of a rod axis within the rod's radius (a
        rod end when within a radius of it). A point outside every geom but within one radius
        of a geom's surface (a cable's anchor on an end cap's outside, as labs often place
        it) goes to the candidate whose surface it is nearest. Returns the point's index and
        how far it moved [m]."""
        m, f = self.f.model, self.f
        near: list[tuple[float, float, np.ndarray]] = []  # (distance outside, radius, node)
        for g in self.spheres if spheres else ():
            centre = f.data.geom_xpos[g]
            radius = m.geom_size[g][0]
            if np.linalg.norm(position - centre) <= radius + TOL:
                return self._node(centre, ""), float(np.linalg.norm(position - centre))
            near.append((float(np.linalg.norm(position - centre)) - radius, radius, centre))
        for g in self.rods:
            p0, p1 = self._ends(g)
            length = float(np.linalg.norm(p1 - p0))
            axis = (p1 - p0) / length
            radius = m.geom_size[g][0]
            t = float(np.clip((position - p0) @ axis, 0.0, length))
            end = max(radius, TOL)
            on = p0 + t * axis
            at = p0 if t <= end else p1 if t >= length - end else on
            if np.linalg.norm(position - on) > radius + TOL:
                near.append((float(np.linalg.norm(position - on)) - radius, radius, at))
                continue
            return self._node(at, ""), float(np.linalg.norm(position - at))
        outside = [(gap, node) for gap, radius, node in near if gap <= radius]
        if outside:
            _, node = min(outside, key=lambda item: item[0])
            return self._node(node, ""), float(np.linalg.norm(position - node))
        raise f.refuse(self.item, f"{what} at {np.round(position, 6).tolist()} lies on none of "
                       "the body's rod axes" + (" or spheres" if spheres else "") +
                       ": tensim's nodes sit on rod axes (or at the centre of a lone sphere)")

    def _name_point(self, k: int, hint: str, rank: int) -> None:
        """Offers ``hint`` as point k's name; a higher ``rank`` wins (rod end 0, sphere 1,
        site 2, a sphere of tensim's export ``mass_<node>`` 3, its node site 4)."""
        point = self.points[k]
        if rank > point.rank:
            point.hint, point.rank = hint, rank

    # -- conversion --------------------------------------------------------------------------

    def convert(self) -> None:
        f = self.f
        if not (self.rods or self.spheres):
            if self.sites and not self.fixed:
                raise f.refuse(self.item, "carries sites that cables use but no capsule, "
                               "cylinder or sphere geom: give the body its rod or mass")
            site_point = {s: self._node(f.data.site_xpos[s], "") for s in self.sites}
            for s, k in site_point.items():
                self._name_point(k, *self._site_hint(s))
            names = self._finish_names()
            self.out.site_node.update({s: names[k] for s, k in site_point.items()})
            return
        for g in self.rods:
            for j, end in enumerate(self._ends(g)):
                self._name_point(self._node(end, ""), f"{self._rod_name(g)}_{j}", 0)
        if len(self.spheres) > 1 and not self.rods:
            raise f.refuse(self.item, "holds several spheres and no rod: tensim's point mass "
                           "is one sphere at a node; join them by a rod or give each a body")
        moved = 0.0
        for g in self.spheres:
            centre = f.data.geom_xpos[g]
            k, shift = self._place(centre, f"sphere {self._geom_name(g)!r}", spheres=False) \
                if self.rods else (self._node(centre, ""), 0.0)
            self.sphere_point[g] = k
            moved = max(moved, shift)
            hint = self._geom_name(g)
            self._name_point(k, hint.removeprefix("mass_"), 3 if hint.startswith("mass_") else 1)
        site_point = {}
        for s in self.sites:
            k, shift = self._place(f.data.site_xpos[s], f"site {self._site_name(s)!r}")
            site_point[s] = k
            moved = max(moved, shift)
            self._name_point(k, *self._site_hint(s))
        if moved > TOL:
            self.out.notes.append(f"{self.item}: spheres and sites moved onto a rod's axis "
                                  "or end (sites: or a sphere's centre) by up to "
                                  f"{moved:.3g} m (tensim's cables anchor at nodes)")
        names = self._finish_names()
        self.out.site_node.update({s: names[k] for s, k in site_point.items()})
        pieces = self._rods(names)
        self._check_connected(pieces)
        self._masses(pieces, names)

    def _geom_name(self, g: int) -> str:
        return self.f.name(mujoco.mjtObj.mjOBJ_GEOM, g, f"{self.name}_geom{g}")

    def _site_name(self, s: int) -> str:
        return self.f.name(mujoco.mjtObj.mjOBJ_SITE, s, f"{self.name}_site{s}")

    def _site_hint(self, s: int) -> tuple[str, int]:
        """The name a site offers its node, and its rank (a node site of tensim's export
        names it outright)."""
        name = self._site_name(s)
        if self.tensim and name.startswith(NODE_SITE):
            return name.removeprefix(NODE_SITE), 4
        return name, 2

    def _rod_name(self, g: int) -> str:
        k = self.rods.index(g)
        fallback = self.name if len(self.rods) == 1 else f"{self.name}_rod{k}"
        return self.f.name(mujoco.mjtObj.mjOBJ_GEOM, g, fallback)

    def _finish_names(self) -> list[str]:
        """Unique node names, made once (later calls return the same)."""
        if self._names is not None:
            return self._names
        names = []
        for k, p in enumerate(self.points):
            base = p.hint or f"{self.name}_node{k}"
            name, n = base, 1
            while name in self.names:
                name, n = f"{base}_{n}", n + 1
            self.names.add(name)
            names.append(name)
            self.out.nodes.append(Node(name, tuple(p.position), fixed=p.fixed))
            self.out.node_body[name] = self.b
        self._names = names
        return names

    def _rods(self, names: list[str]) -> list[tuple[int, str, int, int]]:
        """Each rod geom split at the nodes on its axis: (geom, rod name, node, node)."""
        pieces = []
        for g in self.rods:
            p0, p1 = self._ends(g)
            length = float(np.linalg.norm(p1 - p0))
            axis = (p1 - p0) / length
            inside = []
            for k, p in enumerate(self.points):
                t = (p.position - p0) @ axis
                if -TOL <= t <= length + TOL and \
                        np.linalg.norm(p.position - p0 - t * axis) <= TOL:
                    inside.append((t, k))
            order = [k for _, k in sorted(inside)]
            base = self._rod_name(g)
            for j in range(len(order) - 1):
                name = base if len(order) == 2 else f"{base}_{j}"
                pieces.append((g, name, order[j], order[j + 1]))
        return pieces

    def _check_connected(self, pieces: list[tuple[int, str, int, int]]) -> None:
        parent = list(range(len(self.points)))

        def find(x: int) -> int:
            while parent[x] != x:
                x = parent[x]
            return x

        for _, _, a, c in pieces:
            parent[find(a)] = find(c)
        roots = {find(k) for k in range(len(self.points))}
        if len(roots) > 1:
            raise self.f.refuse(self.item, "its rods, spheres and cable sites do not all meet "
                                "at shared rod ends or on rod axes: tensim joins the parts of a "
                                "rigid body only through shared nodes")

    # -- mass --------------------------------------------------------------------------------

    def _masses(self, pieces: list[tuple[int, str, int, int]], names: list[str]) -> None:
        """Shares the body's mass among its rod pieces and spheres (see the module docstring)
        and adds the rods and point masses."""
        f, m = self.f, self.f.model
        mass, com, inertia = body_inertia(f, self.b)
        if mass <= 0:
            raise f.refuse(self.item, "has no mass: tensim's rods and point masses need one "
                           "(give its geoms a mass or density, or an inertial)")
        parts, prior = [], []
        for g, _, a, c in pieces:
            p0, p1 = self.points[a].position, self.points[c].position
            length = float(np.linalg.norm(p1 - p0))
            total = float(np.linalg.norm(np.subtract(*self._ends(g))))
            parts.append((0.5 * (p0 + p1),
                          _rod_inertia(1.0, length, m.geom_size[g][0], (p1 - p0) / length)))
            prior.append(f.geom_mass[g] * length / total)
        ends = self._bare_ends(pieces)
        spheres = [(self.sphere_point[g], float(m.geom_size[g][0])) for g in self.spheres]
        for k, radius in spheres + ends:
            parts.append((self.points[k].position, 0.4 * radius**2 * np.eye(3)))
        prior += [f.geom_mass[g] for g in self.spheres] + [0.0] * len(ends)
        x = self._fit(mass, com, inertia, parts, np.asarray(prior, float))
        x[x < 1e-9 * mass] = 0.0
        for (g, name, a, c), share in zip(pieces, x[:len(pieces)], strict=True):
            if share <= 0:
                raise f.refuse(self.item, f"rod {name!r} gets no mass from the body's mass and "
                               "inertia; give its geoms masses (tensim's rods need one)")
            length = float(np.linalg.norm(self.points[c].position - self.points[a].position))
            sliding, restitution = self.contact[g]
            self.out.rods.append(Rod(name, (names[a], names[c]), float(m.geom_size[g][0]),
                                     linear_density=share / length, friction=sliding,
                                     restitution=restitution, tags=(self.name,)))
        masses: dict[int, tuple[float, float]] = {}  # point -> (mass, radius): spheres summed
        for (k, radius), share in zip(spheres + ends, x[len(pieces):], strict=True):
            before = masses.get(k, (0.0, 0.0))
            masses[k] = (before[0] + float(share), max(before[1], radius))
        self.out.point_masses += [PointMass(names[k], mass, radius)
                                  for k, (mass, radius) in masses.items() if mass > 0]
        self._note_fit(mass, com, inertia, parts, x)

    def _bare_ends(self, pieces: list[tuple[int, str, int, int]]) -> list[tuple[int, float]]:
        """The rod ends that no sphere sits on, each with the radius of its thickest rod: they
        may carry mass the rods cannot (a capsule's rounded ends, an ``inertial`` heavier at
        the ends); such a point mass lies within its rod, so it adds no contact."""
        spheres = set(self.sphere_point.values())
        radius: dict[int, float] = {}
        for g, _, a, c in pieces:
            for k in (a, c):
                if k not in spheres:
                    radius[k] = max(radius.get(k, 0.0), float(self.f.model.geom_size[g][0]))
        return sorted(radius.items())

    def _fit(self, mass: float, com: np.ndarray, inertia: np.ndarray,
             parts: list[tuple[np.ndarray, np.ndarray]], prior: np.ndarray) -> np.ndarray:
        """Masses >= 0 of the parts whose sum is the body's mass and whose centre of mass and
        inertia are the body's as nearly as the shapes allow (thin axes aside), nearest the
        geoms' own share where that leaves freedom."""
        if prior.sum() <= 0:
            prior = np.ones(len(parts))
        prior = prior * mass / prior.sum()
        if self._moments_match(mass, com, inertia, parts, prior):
            return prior  # the file's inertia is its geoms': keep their masses
        from scipy.optimize import lsq_linear  # on first use: scipy is slow to import
        size = max(float(np.ptp([p.position for p in self.points], axis=0).max()), TOL)
        moments, axes = np.linalg.eigh(inertia)
        rows, rhs = [np.ones(len(parts)) / mass * 1e3], [1e3]
        for k in range(3):
            rows.append(np.array([c[k] - com[k] for c, _ in parts]) / (mass * size))
            rhs.append(0.0)
        for i in range(3):
            for j in range(i, 3):
                if i == j and moments[i] < THIN * moments[-1]:
                    continue
                rows.append(np.array([axes[:, i] @ _shift(unit, 1.0, c - com) @ axes[:, j]
                                      for c, unit in parts]) / (mass * size**2))
                rhs.append(moments[i] / (mass * size**2) if i == j else 0.0)
        a = np.vstack([*rows, _PULL * np.eye(len(parts)) / mass])
        b = np.concatenate([rhs, _PULL * prior / mass])
        x = lsq_linear(a, b, bounds=(0.0, np.inf)).x
        return x * mass / x.sum()

    @staticmethod
    def _props(parts: list[tuple[np.ndarray, np.ndarray]],
               x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        com = sum(xi * c for xi, (c, _) in zip(x, parts, strict=True)) / x.sum()
        inertia = sum(_shift(xi * unit, xi, c - com) for xi, (c, unit) in
                      zip(x, parts, strict=True))
        return np.asarray(com), np.asarray(inertia)

    def _moments_match(self, mass: float, com: np.ndarray, inertia: np.ndarray,
                       parts: list[tuple[np.ndarray, np.ndarray]], x: np.ndarray) -> bool:
        got_com, got = self._props(parts, x)
        scale = np.linalg.eigvalsh(inertia)[-1]
        return bool(np.linalg.norm(got_com - com) <= 1e-6 + 1e-3 * np.sqrt(scale / mass) and
                    self._off(inertia, got) <= _NOTE_SHARE)

    @staticmethod
    def _off(inertia: np.ndarray, got: np.ndarray) -> float:
        """Largest difference of the non-thin principal moments, as a share of the largest."""
        want, have = np.linalg.eigvalsh(inertia), np.linalg.eigvalsh(got)
        keep = want >= THIN * want[-1]
        return float(np.max(np.abs(want - have)[keep]) / want[-1])

    def _note_fit(self, mass: float, com: np.ndarray, inertia: np.ndarray,
                  parts: list[tuple[np.ndarray, np.ndarray]], x: np.ndarray) -> None:
        got_com, got = self._props(parts, x)
        off, shift = self._off(inertia, got), float(np.linalg.norm(got_com - com))
        if off > _NOTE_SHARE or shift > 1e-3:
            want, have = np.linalg.eigvalsh(inertia), np.linalg.eigvalsh(got)
            self.out.notes.append(
                f"{self.item}: rods and spheres carry its {mass:.6g} kg but cannot hold its "
                f"inertia exactly: principal moments {np.round(want, 6).tolist()} kg m^2 in the "
                f"file, {np.round(have, 6).tolist()} in tensim; centre of mass {shift:.3g} m "
                "apart")
