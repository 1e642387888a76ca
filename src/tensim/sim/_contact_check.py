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

    def problem(self, m: mujoco.MjModel, d: mujoco.MjData) -> str | None:
        """What went wrong, or None."""
        for i in range(d.ncon):
            contact = d.contact[i]
            g = contact.geom[0] if self.bead_geom[contact.geom[0]] else contact.geom[1]
            if self.bead_geom[g] and -contact.dist > SINK_SHARE * m.geom_size[g, 0]:
                other = contact.geom[1] if g == contact.geom[0] else contact.geom[0]
                return (f"bead {_name(m, g)!r} is {-contact.dist * 1e3:.3g} mm inside "
                        f"{_name(m, other)!r}")
        for cable, k, tendon, radius in self.spans:
            inside = self._inside(m, d, tendon, radius)
            if inside is not None:
                return (f"span {k} of contact cable {cable!r} passes through "
                        f"{_name(m, inside[0])!r} ({inside[1] * 1e3:.3g} mm of it inside)")
        return None

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


def _name(m: mujoco.MjModel, geom: int) -> str:
    return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, geom) or f"geom {geom}"
