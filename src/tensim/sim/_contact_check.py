"""The stability check of contact cables: beads that sank into, or spans that pass through,
the ground and obstacles (docs/cables.md)."""

from __future__ import annotations

import itertools

import mujoco
import numpy as np

from tensim.model import CompiledModel

SINK_SHARE = 1.0  # a bead whose centre is this many radii inside an obstacle has gone through
# a span passes through an obstacle when it enters and leaves it through opposite faces
# (normals more than 120 deg apart; cutting a corner or a bump enters and leaves through
# faces at an angle) and runs inside it for more than a bead radius
OPPOSITE = -0.5


class ContactCheck:
    """Finds the beads and spans of contact cables that went through the world's geoms.

    Args:
        compiled: a compiled model with contact cables (bead bodies ``<cable>_bead<k>``, span
            tendons ``<cable>_span<k>``; see ``tensim.model._beads``).
    """

    def __init__(self, compiled: CompiledModel):
        m = compiled.model
        self.spans: list[tuple[str, int, int, float]] = []  # cable, k, tendon id, bead radius
        self.bead_geom = np.zeros(m.ngeom, dtype=bool)
        for cable in compiled.structure.cables:
            if cable.contact is None:
                continue
            for k in itertools.count():
                body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"{cable.name}_bead{k}")
                if body < 0:
                    break
                self.bead_geom[m.body_geomadr[body]] = True
            for k in itertools.count():
                tendon = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TENDON, f"{cable.name}_span{k}")
                if tendon < 0:
                    break
                self.spans.append((cable.name, k, tendon, cable.contact.radius))
        self.world_geoms = m.geom_bodyid == 0  # ground and terrain
        self._span_sites = np.array([[m.wrap_objid[m.tendon_adr[t] + j] for j in (0, 1)]
                                     for _, _, t, _ in self.spans], dtype=int).reshape(-1, 2)
        self._radius = np.array([r for *_, r in self.spans])[:, None]
        self._boxes: tuple[np.ndarray, np.ndarray] | None = None

    def problem(self, m: mujoco.MjModel, d: mujoco.MjData) -> str | None:
        """What went wrong, or None."""
        sunk = self._sunk(m, d)
        if sunk is not None:
            return sunk
        for cable, k, tendon, radius in self._near_obstacles(m, d):
            inside = self._inside(m, d, tendon, radius)
            if inside is not None:
                return (f"span {k} of contact cable {cable!r} passes through "
                        f"{_name(m, inside[0])!r} ({inside[1] * 1e3:.3g} mm of it inside)")
        return None

    def _sunk(self, m: mujoco.MjModel, d: mujoco.MjData) -> str | None:
        """A bead whose centre went into what it touches, or None."""
        if not d.ncon:
            return None
        geoms, depth = d.contact.geom, -d.contact.dist
        bead = np.where(self.bead_geom[geoms[:, 0]], geoms[:, 0], geoms[:, 1])
        sunk = np.flatnonzero(self.bead_geom[bead] & (depth > SINK_SHARE * m.geom_size[bead, 0]))
        if not sunk.size:
            return None
        i = int(sunk[0])
        other = geoms[i, 1] if bead[i] == geoms[i, 0] else geoms[i, 0]
        return (f"bead {_name(m, bead[i])!r} is {depth[i] * 1e3:.3g} mm inside "
                f"{_name(m, other)!r}")

    def _near_obstacles(self, m: mujoco.MjModel, d: mujoco.MjData
                        ) -> list[tuple[str, int, int, float]]:
        """The spans whose bounding boxes meet a world geom's (planes aside: a bead below
        the ground is found sunk), the only ones a ray needs to test."""
        if self._boxes is None:  # the world's geoms do not move: their boxes once
            self._boxes = _world_boxes(m, d)
        if not self._boxes[0].size or not self.spans:
            return []
        ends = d.site_xpos[self._span_sites]  # (n_spans, 2, 3)
        low, high = ends.min(axis=1) - self._radius, ends.max(axis=1) + self._radius
        meet = np.all((low[:, None] < self._boxes[1]) & (high[:, None] > self._boxes[0]),
                      axis=2).any(axis=1)
        return [self.spans[i] for i in np.flatnonzero(meet)]

    def _inside(self, m: mujoco.MjModel, d: mujoco.MjData, tendon: int, radius: float
                ) -> tuple[int, float] | None:
        """(geom, length inside [m]) where a span runs through a world geom, else None."""
        adr = m.tendon_adr[tendon]
        a, b = (d.site_xpos[m.wrap_objid[adr + j]] for j in (0, 1))
        span = float(np.linalg.norm(b - a))
        if span < 1e-9:
            return None
        hits = []
        for start, direction in ((a, (b - a) / span), (b, (a - b) / span)):
            geom, normal = np.array([-1], dtype=np.int32), np.zeros(3)
            distance = mujoco.mj_ray(m, d, start, direction, _WORLD_GROUP, 1, -1, geom, normal)
            if not 0 <= distance < span or not self.world_geoms[geom[0]]:
                return None
            hits.append((int(geom[0]), distance, normal))
        (g1, d1, n1), (g2, d2, n2) = hits
        inside = span - d1 - d2
        if g1 == g2 and inside > radius and float(n1 @ n2) < OPPOSITE:
            return g1, inside
        return None


_WORLD_GROUP = np.array([1, 0, 0, 0, 0, 0], dtype=np.uint8)  # world geoms are in group 0


def _world_boxes(m: mujoco.MjModel, d: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) world-frame bounding boxes of the world's geoms other than planes, (n, 3)."""
    geoms = np.flatnonzero((m.geom_bodyid == 0) & (m.geom_type != mujoco.mjtGeom.mjGEOM_PLANE))
    rot = d.geom_xmat[geoms].reshape(-1, 3, 3)
    centre = d.geom_xpos[geoms] + np.einsum("nij,nj->ni", rot, m.geom_aabb[geoms, :3])
    half = np.einsum("nij,nj->ni", np.abs(rot), m.geom_aabb[geoms, 3:])
    return centre - half, centre + half


def _name(m: mujoco.MjModel, geom: int) -> str:
    return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, geom) or f"geom {geom}"
