"""The stability check of contact cables: beads that sank into, or spans that pass through,
the ground and obstacles (docs/cables.md)."""

from __future__ import annotations

import mujoco
import numpy as np

from tensim.model import CompiledModel

SINK_SHARE = 1.0  # a bead whose centre is this many radii inside an obstacle has gone through
CROSS_SHARE = 0.75  # a span with this share of its length inside an obstacle passes through it


class ContactCheck:
    """Finds contact cables that tunnelled; ``None``-free only for models with contact cables.

    Args:
        compiled: the compiled model (bead bodies ``<cable>_bead<k>``, spans ``<cable>_span<k>``).
    """

    def __init__(self, compiled: CompiledModel):
        m = compiled.model
        self.cables, bead_geoms, spans = [], [], []
        for cable in compiled.structure.cables:
            if cable.contact is None:
                continue
            k = 0
            while mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TENDON, f"{cable.name}_span{k}") >= 0:
                spans.append((cable.name, k, mujoco.mj_name2id(
                    m, mujoco.mjtObj.mjOBJ_TENDON, f"{cable.name}_span{k}")))
                k += 1
            self.cables.append(cable.name)
        for g in range(m.ngeom):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
            if "_bead" in name and m.geom_bodyid[g] != 0:
                bead_geoms.append(g)
        self.bead_geom = np.zeros(m.ngeom, dtype=bool)
        self.bead_geom[bead_geoms] = True
        self.spans = spans
        # rays see the world's geoms only (group 0: ground, terrain), not beads or the robot
        self.world_geoms = np.array([m.geom_bodyid[g] == 0 for g in range(m.ngeom)])

    def problem(self, m: mujoco.MjModel, d: mujoco.MjData) -> str | None:
        """What went wrong, or None."""
        for i in range(d.ncon):
            contact = d.contact[i]
            g = contact.geom[0] if self.bead_geom[contact.geom[0]] else contact.geom[1]
            if self.bead_geom[g] and -contact.dist > SINK_SHARE * m.geom_size[g, 0]:
                other = contact.geom[1] if g == contact.geom[0] else contact.geom[0]
                return (f"bead {_name(m, g)!r} is {-contact.dist * 1e3:.3g} mm inside "
                        f"{_name(m, other)!r}")
        for cable, k, tendon in self.spans:
            inside = self._inside(m, d, tendon)
            if inside is not None:
                return (f"span {k} of contact cable {cable!r} passes through "
                        f"{_name(m, inside[0])!r} ({inside[1] * 1e3:.3g} mm of it inside)")
        return None

    def _inside(self, m: mujoco.MjModel, d: mujoco.MjData, tendon: int
                ) -> tuple[int, float] | None:
        """(geom, length inside [m]) where a span runs through a world geom, else None."""
        adr = m.tendon_adr[tendon]
        a, b = (d.site_xpos[m.wrap_objid[adr + j]] for j in (0, 1))
        span = float(np.linalg.norm(b - a))
        if span < 1e-9:
            return None
        geomid = np.array([-1], dtype=np.int32)
        group = np.array([1, 0, 0, 0, 0, 0], dtype=np.uint8)  # world geoms are in group 0
        ahead = mujoco.mj_ray(m, d, a, (b - a) / span, group, 1, -1, geomid)
        if ahead < 0 or ahead >= span or not self.world_geoms[geomid[0]]:
            return None
        back = mujoco.mj_ray(m, d, b, (a - b) / span, group, 1, -1, geomid)
        inside = span - ahead - max(back, 0.0)
        return (int(geomid[0]), inside) if inside > CROSS_SHARE * span else None


def _name(m: mujoco.MjModel, geom: int) -> str:
    return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, geom) or f"geom {geom}"
