"""Ground contacts of many robots at once, from MuJoCo contact sensors.

A contact sensor per rigid body (``<contact body1=... body2="world" data="found pos">``)
copies that body's contacts with the world's geoms out of ``MjData.contact`` at the position
stage, so the batch engine returns them in ``sensordata`` for every robot in one array: no
robot's whole ``MjData`` is copied to read its contact list.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from tensim.model import CompiledModel
from tensim.model._compile import _compile_spec

SLOTS = 4  # contacts each sensor reports (a capsule on a plane makes at most 2)
_FOUND, _POS = 1, 16  # mjtConDataField bits: the number of matches, the contact position
_NAME = "tensim_ground_contact_"
_PAIR = "tensim_bar_contact_"
any_true = np.logical_or.reduce  # a bool array's .any(), without its Python wrapper


def with_contact_sensors(compiled: CompiledModel) -> CompiledModel:
    """``compiled`` with a ground contact sensor on each rigid body (the same physics: a
    sensor changes no force). Without its ``MjSpec`` (an unpickled model), unchanged."""
    if compiled.spec is None:
        return compiled
    spec = compiled.spec.copy()
    for body in compiled.index.bodies:
        spec.add_sensor(name=_NAME + body, type=mujoco.mjtSensor.mjSENS_CONTACT,
                        objtype=mujoco.mjtObj.mjOBJ_BODY, objname=body,
                        reftype=mujoco.mjtObj.mjOBJ_BODY, refname="world",
                        intprm=[_FOUND | _POS, 0, SLOTS])
    return _recompiled(compiled, spec)


def with_bar_sensors(compiled: CompiledModel) -> CompiledModel:
    """``compiled`` with a contact sensor on each pair of rigid bodies, counting their contacts
    (``data="found"``); unchanged without its ``MjSpec``."""
    if compiled.spec is None:
        return compiled
    spec = compiled.spec.copy()
    bodies = compiled.index.bodies
    for i, a in enumerate(bodies):
        for b in bodies[i + 1:]:
            spec.add_sensor(name=f"{_PAIR}{a}_{b}", type=mujoco.mjtSensor.mjSENS_CONTACT,
                            objtype=mujoco.mjtObj.mjOBJ_BODY, objname=a,
                            reftype=mujoco.mjtObj.mjOBJ_BODY, refname=b,
                            intprm=[_FOUND, 0, 1])
    return _recompiled(compiled, spec)


def _recompiled(compiled: CompiledModel, spec: mujoco.MjSpec) -> CompiledModel:
    model = _compile_spec(spec)
    model.key_ctrl[:] = compiled.model.key_ctrl  # (edited after compiling, as the spec's)
    return dataclasses.replace(compiled, model=model, spec=spec)


def bar_sensor_rows(model: mujoco.MjModel, bodies: list[str]) -> np.ndarray | None:
    """The ``sensordata`` rows of :func:`with_bar_sensors`' counts, or None where the model
    has not every pair's sensor."""
    ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, f"{_PAIR}{a}_{b}")
           for i, a in enumerate(bodies) for b in bodies[i + 1:]]
    if not ids or min(ids) < 0:
        return None
    return model.sensor_adr[ids]


class GroundContacts:
    """Reads the sensors of :func:`with_contact_sensors` from a batch's ``sensordata``.

    Args:
        model: the model with the sensors.
        bodies: (n_bodies,) MuJoCo body ids of the rigid bodies.
        end_body: (n_ends,) the body of each rod end.
    """

    def __init__(self, model: mujoco.MjModel, bodies: np.ndarray, end_body: np.ndarray):
        names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in bodies]
        ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, _NAME + str(n))
               for n in names]
        self.ready = bool(ids) and min(ids) >= 0
        adr = model.sensor_adr[ids] if self.ready else np.zeros(0, dtype=int)
        # (n_bodies, SLOTS, 4) indices into a robot's sensordata: found, x, y, z per slot
        self.index = adr[:, None, None] + np.arange(SLOTS * 4).reshape(SLOTS, 4)
        flat = self.index.ravel()  # (where the sensors lie one after another: a slice, a view)
        self._rows: np.ndarray | slice = self.index
        if flat.size and (np.diff(flat) == 1).all():
            self._rows = slice(int(flat[0]), int(flat[-1]) + 1)
        # each body's rod ends, in order, padded to (n_bodies, most ends on a body); the
        # padding is never the nearest end (its distance is inf)
        own = [np.flatnonzero(end_body == b) for b in bodies]
        most = max((o.size for o in own), default=0)
        self.ends = np.zeros((len(own), most), dtype=int)
        self.pad = np.full((len(own), most), np.inf)
        for i, o in enumerate(own):
            self.ends[i, :o.size], self.pad[i, :o.size] = o, 0.0
        self.n_ends = end_body.size

    def read(self, sensordata: np.ndarray, ends: np.ndarray | None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """From (k, nsensordata): (k, n_bodies) 1 where a body touches the world, (k, n_ends)
        1 at the nearest end of its body to each contact (``ends``: (k, n_ends, 3) rod end
        positions [m], or None for no ends), and (k,) robots with more contacts on a body
        than the sensors hold (their flags must come from the contact list)."""
        data = sensordata[:, self._rows].reshape(-1, *self.index.shape)  # (k, n_bodies, SLOTS, 4)
        found = data[:, :, 0, 0]
        touch = (found > 0).astype(float)
        over = any_true(found > SLOTS, axis=1)
        out = np.zeros((data.shape[0], self.n_ends))
        if ends is None or not self.ends.size:
            return touch, out, over
        robot, body, slot = np.nonzero(data[..., 0])  # the slots holding a contact
        if not robot.size:
            return touch, out, over
        # (c, most) each contact's distance to each end of its body: np.linalg.norm without
        # its overhead (the same sum)
        own = self.ends[body]
        gap = ends[robot[:, None], own] - data[robot, body, slot, 1:][:, None]
        far = np.sqrt(np.add.reduce(gap * gap, axis=2)) + self.pad[body]
        nearest = far.argmin(axis=1)  # (the first of equals: the lowest end, as before)
        hit = np.minimum.reduce(far, axis=1) < np.inf  # (its distance is the least)
        if np.logical_and.reduce(hit):  # (the common case: every body touching has an end)
            out[robot, own[np.arange(own.shape[0]), nearest]] = 1.0
        else:
            out[robot[hit], own[hit, nearest[hit]]] = 1.0
        return touch, out, over
