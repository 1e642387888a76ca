"""Loads an MJCF file through MuJoCo and refuses what is not a tensegrity.

MuJoCo parses the file (includes, defaults, ``fromto``, ``settotalmass``, ``inertiafromgeom``)
and compiles it; the importer reads the compiled model at its reference pose. What cannot be a
rod, end cap, point mass, site-routed cable or tendon actuator is refused here, naming the file
and the element.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import mujoco
import numpy as np

from tensim.structure import StructureError

GEOM = mujoco.mjtGeom
ROD_GEOMS = (GEOM.mjGEOM_CAPSULE, GEOM.mjGEOM_CYLINDER)
SHAPES = (*ROD_GEOMS, GEOM.mjGEOM_SPHERE)
_GROUND = (GEOM.mjGEOM_PLANE, GEOM.mjGEOM_HFIELD)


def kind_name(value: object) -> str:
    """A MuJoCo enum value's name without its prefix: ``mjGEOM_MESH`` -> ``mesh``."""
    return str(getattr(value, "name", value)).split("_", 1)[-1].lower()


@dataclasses.dataclass(frozen=True)
class Loaded:
    """A compiled MJCF model at its reference pose.

    Attributes:
        source: the file (or ``"<string>"``), as named in messages.
        spec: MuJoCo's parsed spec.
        model: the compiled model.
        data: its data after forward kinematics at ``qpos0``.
        geom_mass: (ngeom,) each geom's own mass, as MuJoCo computes it [kg].
    """

    source: str
    spec: mujoco.MjSpec
    model: mujoco.MjModel
    data: mujoco.MjData
    geom_mass: np.ndarray

    def refuse(self, item: str, message: str) -> StructureError:
        """The error for ``item`` (``"body 'rod0'"``) of this file."""
        return StructureError(message, item=item, source=self.source)

    def name(self, kind: mujoco.mjtObj, i: int, fallback: str) -> str:
        """The element's name, or ``fallback`` when it has none."""
        return mujoco.mj_id2name(self.model, kind, i) or fallback

    def geom_item(self, g: int) -> str:
        """``geom 'name'`` (or ``geom #k of body 'b'``) for messages."""
        name = mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_GEOM, g)
        body = self.name(mujoco.mjtObj.mjOBJ_BODY, int(self.model.geom_bodyid[g]),
                         f"#{self.model.geom_bodyid[g]}")
        return f"geom {name!r}" if name else f"geom #{g} of body {body!r}"


def load(path: str | os.PathLike[str] | None = None, xml: str | None = None) -> Loaded:
    """Parses and compiles an MJCF file (or ``xml`` text) with MuJoCo, then checks its tree.

    Raises:
        StructureError: MuJoCo cannot read it, or it holds something tensim refuses.
        FileNotFoundError: no such file.
    """
    source = str(path) if path is not None else "<string>"
    if path is not None and not Path(path).is_file():
        raise FileNotFoundError(f"{path}: no such MJCF file")
    try:
        spec = mujoco.MjSpec.from_file(str(path)) if path is not None else \
            mujoco.MjSpec.from_string(xml or "")
        # actuator length ranges (muscles') are not needed, and a free robot's may not converge
        spec.compiler.LRopt.mode = mujoco.mjtLRMode.mjLRMODE_NONE
        model = spec.compile()
    except ValueError as err:
        raise StructureError(f"MuJoCo cannot read it: {err}".strip(), source=source) from None
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_tendon(model, data)
    loaded = Loaded(source, spec, model, data, np.zeros(model.ngeom))
    _check_tree(loaded)
    return dataclasses.replace(loaded, geom_mass=_geom_masses(loaded))


def _check_tree(f: Loaded) -> None:
    """Refuses joints other than one free joint per body, nested bodies, shapes that are not
    capsules, cylinders or spheres, tendons other than site-routed spatial ones, and actuators
    on anything but a tendon."""
    m, obj = f.model, mujoco.mjtObj
    for b in range(1, m.nbody):
        item = f"body {f.name(obj.mjOBJ_BODY, b, f'#{b}')!r}"
        if m.body_parentid[b] != 0:
            parent = f.name(obj.mjOBJ_BODY, int(m.body_parentid[b]), "")
            raise f.refuse(item, f"nested in body {parent!r}: a tensegrity's rods are free "
                           "bodies of their own (children of the worldbody), joined only by "
                           "cables; kinematic trees (hinge chains, arms) are not imported")
        for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
            if m.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE or m.body_jntnum[b] > 1:
                kind = kind_name(mujoco.mjtJoint(m.jnt_type[j]))
                raise f.refuse(item, f"has a {kind} joint "
                               f"{f.name(obj.mjOBJ_JOINT, j, '')!r}: a tensegrity's bodies "
                               "move freely (one free joint) or not at all (none); hinge "
                               "chains and other joints are not imported")
    by_id = {g.id: g for g in f.spec.geoms}
    for g in range(m.ngeom):
        kind = GEOM(m.geom_type[g])
        if m.geom_bodyid[g] == 0 or kind in SHAPES or visual(m, by_id[g], g):
            continue  # the world's geoms (tensim builds its ground) and looks: noted later
        raise f.refuse(f.geom_item(g), f"is a {kind_name(kind)}: tensim imports rods "
                       "(capsule, cylinder), end caps and point masses (sphere); meshes, "
                       "boxes and other shapes with mass or contact are not imported")
    _check_tendons(f)
    for a in range(m.nu):
        if m.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_TENDON:
            kind = kind_name(mujoco.mjtTrn(m.actuator_trntype[a]))
            raise f.refuse(f"actuator {f.name(obj.mjOBJ_ACTUATOR, a, f'#{a}')!r}",
                           f"acts on a {kind}: tensim imports actuators on tendons (cable "
                           "motors) only")
    if m.neq:
        raise f.refuse(f"equality {f.name(obj.mjOBJ_EQUALITY, 0, '#0')!r}",
                       "equality constraints (welds, connects) are not imported: rods share "
                       "nodes by their ends meeting in the file's pose")


def visual(m: mujoco.MjModel, geom: mujoco.MjsGeom, g: int) -> bool:
    """Whether geom ``g`` is for looks only: no contact and no mass of its own."""
    massless = geom.mass == 0 or (np.isnan(geom.mass) and geom.density == 0)
    return bool(massless and not m.geom_contype[g] and not m.geom_conaffinity[g])


def _check_tendons(f: Loaded) -> None:
    m = f.model
    for t in range(m.ntendon):
        item = f"tendon {f.name(mujoco.mjtObj.mjOBJ_TENDON, t, f'#{t}')!r}"
        kinds = m.wrap_type[m.tendon_adr[t]:m.tendon_adr[t] + m.tendon_num[t]]
        if np.any(kinds == mujoco.mjtWrap.mjWRAP_JOINT):
            raise f.refuse(item, "is a fixed tendon (it couples joints): tensim imports spatial "
                           "tendons between sites (cables)")
        bad = [kind_name(mujoco.mjtWrap(k)) for k in kinds
               if k != mujoco.mjtWrap.mjWRAP_SITE]
        if bad:
            raise f.refuse(item, f"wraps a {bad[0]}: tensim imports spatial tendons routed "
                           "through sites only (a site between the ends becomes a via node)")


def _geom_masses(f: Loaded) -> np.ndarray:
    """Each geom's own mass: MuJoCo compiles each shape (type, size, mass or density, volume or
    shell inertia) alone in a body of a scratch model."""
    m = f.model
    scratch = mujoco.MjSpec()
    by_id = {g.id: g for g in f.spec.geoms}
    for g in range(m.ngeom):
        body = scratch.worldbody.add_body(pos=[0, 0, 10.0 * g])
        source = by_id[g]
        if GEOM(m.geom_type[g]) not in SHAPES:
            body.add_site()  # a ground plane has no mass; keep the ids in step
            continue
        if visual(m, source, g):
            body.add_site()  # looks only: no mass
            continue
        geom = body.add_geom(type=GEOM(m.geom_type[g]), size=m.geom_size[g].tolist(),
                             density=source.density, typeinertia=source.typeinertia)
        if np.isfinite(source.mass):
            geom.mass = source.mass
    return np.asarray(scratch.compile().body_mass[1:], dtype=float)


def body_inertia(f: Loaded, b: int) -> tuple[float, np.ndarray, np.ndarray]:
    """Body ``b``'s mass [kg], centre of mass (3,) [m] and inertia tensor (3, 3) about it in the
    world frame [kg m^2], as MuJoCo compiled them (explicit ``inertial`` or from the geoms)."""
    m, d = f.model, f.data
    rot = d.ximat[b].reshape(3, 3)
    return float(m.body_mass[b]), d.xipos[b].copy(), rot @ np.diag(m.body_inertia[b]) @ rot.T
