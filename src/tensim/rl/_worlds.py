"""Many copies of one robot on MuJoCo's batch engine: episodes start, step and are observed
here; the Gymnasium classes add only their API (autoreset, info layout)."""

from __future__ import annotations

import copy
from typing import Any

import mujoco
import numpy as np
from mujoco import batch as mjbatch

from tensim.rl._contacts import GroundContacts, bar_sensor_rows
from tensim.rl._observe_native import Kernel, kernel
from tensim.rl._robot import Robot
from tensim.sim import MODE_PD, PhysicsScale, StabilityLimits, Trial, load_cell_reading
from tensim.sim._batch import setup_trial
from tensim.sim._loop import (
    RING_EVERY,
    Energy,
    EnergyHistory,
    ForceHistory,
    prestress_band,
    split_steps,
)
from tensim.sim.motion import roll_change, yaw_change

_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
any_true = np.logical_or.reduce  # a bool array's .any(), without its Python wrapper
_BADQACC = int(mujoco.mjtWarning.mjWARN_BADQACC)
_VEL, _NONE = int(mujoco.mjtStage.mjSTAGE_VEL), int(mujoco.mjtStage.mjSTAGE_NONE)
_SCALED = ("friction", "stiffness", "damping", "mass", "motor_speed")
_FIELDS = ("ten_length", "xpos", "xmat", "xipos", "xquat", "subtree_com", "cvel", "qvel",
           "actuator_force", "act", "ctrl", "ncon")


class Worlds:
    """``n`` robots of one :class:`Robot`, each with its own random generator and episode.

    Derived fields are made current after every control period (a persistent batch stepped to
    the velocity stage), so observations describe the state the next action starts from.
    """

    def __init__(self, robot: Robot, n: int, threads: int = 1):
        self.robot, self.n, self.threads = robot, n, threads
        c = robot.config
        self._open_batch([robot.model] * n)
        self.rngs = [np.random.default_rng() for _ in range(n)]
        self._randomize_physics = any(getattr(c.randomization, k) != (1.0, 1.0)
                                      for k in _SCALED)
        self._scratch = mujoco.MjData(robot.model)
        self._scratch_contacts = mujoco.MjData(robot.model)  # a robot's data, for its contacts
        idx = robot.compiled.index
        self._body = idx.body
        self._bodies = _as_slice(idx.body)  # (a slice where the ids run on: views, no copies)
        self._root = _as_slice(robot.model.body_rootid[idx.body])  # (free bodies: themselves)
        mass = robot.model.body_mass[idx.body]
        self._mass = mass / mass.sum()
        free = robot.model.jnt_type == mujoco.mjtJoint.mjJNT_FREE
        self._free_qpos = robot.model.jnt_qposadr[free]
        self._free_dof = robot.model.jnt_dofadr[free]
        self._body_qpos = np.array([robot.model.jnt_qposadr[robot.model.body_jntadr[b]]
                                    for b in idx.body if robot.model.body_jntadr[b] >= 0
                                    and free[robot.model.body_jntadr[b]]], dtype=int)
        self.hold = robot.hold
        self.pending = np.zeros((n, c.randomization.action_delay, robot.n)) + self.hold
        self.previous = np.zeros((n, robot.motors.size))
        self.steps = np.zeros(n, dtype=int)
        self.start_xipos = np.zeros((n, len(idx.body), 3))
        self.target = np.zeros((n, 2))  # a unit direction or a goal position, world frame
        self.heading = np.zeros((n, 2))  # the start's direction, world frame (unit)
        # a frame that turns only at a reset (the heading's): its yaw, cosine and sine then
        self._fixed_frame = c.frame != "robot" and c.task != "goal"
        self._yaw, self._cos, self._sin = np.zeros(n), np.ones((n, 1)), np.zeros((n, 1))
        base = robot.layout.get("history", (0, 0))[0]
        self.past = np.zeros((n, c.history, base))
        self.limits = StabilityLimits()
        # the cable forces of the last steps, for the ringing check
        self.forces = ForceHistory(n, prestress_band(robot.compiled.structure))
        self.energy = Energy(robot.compiled)  # and the energy at each check, for its growth
        self.energies = EnergyHistory(n, self.energy.scale)
        self._calls = 0
        self._robot_body = np.zeros(robot.model.nbody, dtype=bool)
        self._robot_body[idx.body] = True
        self._slot = np.full(robot.model.nbody, -1)  # MuJoCo body id -> rigid body number
        self._slot[idx.body] = np.arange(idx.body.size)
        self._geom_body = robot.model.geom_bodyid.copy()  # read once: each read copies
        self._end_body = robot.rods["body"].ravel()
        self._end_local = robot.rods["local"].reshape(-1, 3)
        self._ground = GroundContacts(robot.model, idx.body, self._end_body)
        self._bar_rows = bar_sensor_rows(robot.model, list(idx.bodies))
        layout = robot.layout
        self._terms = tuple(t for t in layout if t != "history")
        # the world vectors an observation turns into its frame, (start, stop) rows of a buffer
        rows = {"velocity": 1 + 2 * idx.body.size, "rod_axis": len(robot.rods["body"]),
                "task": 1 if c.task in ("direction", "goal") else 0}
        self._world: dict[str, tuple[int, int]] = {}
        for name in ("velocity", "rod_axis", "task"):
            if rows["task"] if name == "task" else name in layout:
                start = max((b for _, b in self._world.values()), default=0)
                self._world[name] = (start, start + rows[name])
        self._sigma = self._noise_sigma(layout["history"][0] if "history" in layout
                                        else max(b for _, b in layout.values()))
        self._noise = bool(self._sigma.any())  # (whether any is above 0)
        self._kernel = self._compiled()

    def _compiled(self) -> Kernel | None:
        """The compiled observation of these robots (None: observed with NumPy)."""
        idx, ground = self.robot.compiled.index, self._ground
        sensors = None
        if ground.ready:  # each body's sensor: its first slot's "found" value
            sensors = ground.index[:, 0, 0]
        body_ends = np.where(np.isfinite(ground.pad), ground.ends, -1)
        index = {"body": self._body, "root": self.robot.model.body_rootid[self._body],
                 "mass": self._mass, "end_body": self._end_body, "end_local": self._end_local,
                 "tendon": idx.tendon, "sensor_adr": sensors, "body_ends": body_ends,
                 "slots": ground.index.shape[1]}
        # (it reads target and previous where they are: both are only written in place)
        return kernel(self.f, {"target": self.target, "previous": self.previous}, index,
                      self.robot.layout, self.robot.config.task)

    def _open_batch(self, models: list[mujoco.MjModel]) -> None:
        """The batch engine over ``models`` (one per robot) and its field views."""
        self.models = list(models)
        self.batch = mjbatch.Batch(self.models[0], self.n, nthread=self.threads,
                                   persistent=True)
        if any(m is not self.models[0] for m in self.models):
            self.batch.set_models(self.models)
        fields = _FIELDS + (("sensordata",) if self.models[0].nsensordata else ())
        self.f = {k: self.batch.bind(k) for k in fields}

    # -- copies ----------------------------------------------------------------------------

    def __getstate__(self) -> dict[str, Any]:
        """Everything but the batch engine, whose robots' states are saved instead."""
        state = {k: v for k, v in self.__dict__.items() if k not in ("batch", "f", "_kernel")}
        state["_states"] = np.array([self.batch.state[i] for i in range(self.n)])
        state["_warnings"] = np.array(self.batch.warning)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        states, warnings = state.pop("_states"), state.pop("_warnings")
        self.__dict__.update(state)
        self._open_batch(self.models)
        ids = np.arange(self.n, dtype=np.int32)
        self.batch.reset(ids, stage=mujoco.mjtStage.mjSTAGE_NONE)
        for i in range(self.n):
            self.batch.state[i] = states[i]
        self.batch.forward(ids)
        self.batch.warning[:] = warnings
        self._kernel = self._compiled()  # (it points at the new arrays)

    # -- episodes --------------------------------------------------------------------------

    def seed(self, ids: np.ndarray, seeds: list[int | None]) -> None:
        """New generators for robots ``ids`` (None: fresh entropy)."""
        for i, s in zip(ids, seeds, strict=True):
            self.rngs[int(i)] = np.random.default_rng(s)

    def reset(self, ids: np.ndarray) -> None:
        """Starts a new episode for robots ``ids``: physics, start pose, task."""
        ids = np.asarray(ids, dtype=np.int32)
        if self._randomize_physics:
            for i in ids:
                self.models[i] = self._scaled_model(self.rngs[i])
            self.batch.set_models(self.models)
        self.batch.reset(ids, stage=mujoco.mjtStage.mjSTAGE_NONE)  # clears the warnings too
        c = self.robot.config
        for i in ids:
            yaw = self.rngs[i].uniform(-np.pi, np.pi) if c.randomization.yaw else 0.0
            self.batch.state[i] = self._start_state(self.rngs[i], yaw)
            turn = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
            self.heading[i] = turn @ (np.asarray(c.direction) / np.hypot(*c.direction))
            if c.task == "direction":
                self.target[i] = self.heading[i]
            else:
                self.target[i] = turn @ np.asarray(c.goal_m)
        if self._fixed_frame:  # (as _frame_yaw computes it)
            self._yaw[ids] = np.arctan2(self.heading[ids, 1], self.heading[ids, 0])
            self._cos[ids, 0], self._sin[ids, 0] = np.cos(self._yaw[ids]), np.sin(self._yaw[ids])
        self.batch.forward(ids)
        if c.task != "direction":
            self.target[ids] += self.f["subtree_com"][ids, 0, :2]
        self.start_xipos[ids] = self.f["xipos"][ids][:, self._body]
        self.pending[ids] = self.hold
        self.previous[ids] = 0.0
        self.past[ids] = 0.0
        self.steps[ids] = 0
        self.forces.count[ids] = 0
        self.energies.reset(ids)

    def _scaled_model(self, rng: np.random.Generator) -> mujoco.MjModel:
        r = self.robot.config.randomization
        scale = PhysicsScale(**{k: float(rng.uniform(*getattr(r, k))) for k in _SCALED})
        model = copy.copy(self.robot.model)
        setup_trial(self.robot.compiled, model, Trial(physics=scale),
                    float(model.opt.timestep))
        return model

    def _start_state(self, rng: np.random.Generator, yaw: float) -> np.ndarray:
        """The settled build state turned by ``yaw`` about the vertical through its centre of
        mass, each rigid body displaced by the pose noise."""
        m, d = self.robot.model, self._scratch
        mujoco.mj_setState(m, d, self.robot.initial_state, _STATE)
        if yaw != 0.0:
            self._turn(yaw)
        sigma = self.robot.config.randomization.pose_noise_m
        if sigma > 0:
            noise = rng.normal(0.0, sigma, (self._body_qpos.size, 3))
            noise[:, 2] = np.abs(noise[:, 2])  # upward only: no start inside the ground
            d.qpos[self._body_qpos[:, None] + np.arange(3)] += noise
        state = np.empty(mujoco.mj_stateSize(m, _STATE))
        mujoco.mj_getState(m, d, state, _STATE)
        return state

    def _turn(self, yaw: float) -> None:
        """Turns the scratch state by ``yaw`` about the vertical through its centre of mass."""
        m, d = self.robot.model, self._scratch
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        centre = d.subtree_com[0].copy()
        c, s = np.cos(yaw), np.sin(yaw)
        turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        q_yaw = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
        for adr, dof in zip(self._free_qpos, self._free_dof, strict=True):
            d.qpos[adr:adr + 3] = centre + turn @ (d.qpos[adr:adr + 3] - centre)
            quat = np.empty(4)
            mujoco.mju_mulQuat(quat, q_yaw, d.qpos[adr + 3:adr + 7])
            d.qpos[adr + 3:adr + 7] = quat
            d.qvel[dof:dof + 3] = turn @ d.qvel[dof:dof + 3]  # angular velocity is local

    def _rows(self, ids: np.ndarray) -> np.ndarray | slice:
        """``ids`` as an index of the robot axis: a slice (views, no copies) when they are all
        the robots (ids are sorted and unique, so their count says so)."""
        return slice(None) if ids.size == self.n else ids

    # -- stepping --------------------------------------------------------------------------

    def step(self, ids: np.ndarray, commands: np.ndarray, applied: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """One control period of robots ``ids``.

        Args:
            ids: (k,) the robots that step, sorted and unique.
            commands: (k, n_cables) their ``ctrl`` commands [m/s] or [m].
            applied: (k, n_cables) the same actions in the action space's units.

        Returns:
            (k,) rewards, (k,) terminated, and the reward terms and error flags per robot.
        """
        c, n = self.robot.config, self.robot.n
        r = self._rows(ids)
        if c.randomization.action_delay:
            queue = self.pending[r]
            now = queue[:, 0].copy()
            self.pending[r] = np.concatenate([queue[:, 1:], commands[:, None]], axis=1)
            commands = now
        self.f["ctrl"][r, :n] = commands
        before = self.f["subtree_com"][r, 0, :2].copy()
        # the points whose best rigid fit measures a turn, before the period: for the turn
        # task and the rolling reward
        bodies_before = self.turn_points(ids) if c.task == "turn" or c.roll_reward else None
        failed: np.ndarray | bool = False
        self._calls += 1  # every RING_EVERY-th period, its last steps' forces tell ringing
        checked = self._calls % RING_EVERY == 0
        calls = split_steps(c.control_steps) if checked else [(c.control_steps, False)]
        rows = None if isinstance(r, slice) else ids
        stage = _NONE
        try:
            for j, (count, push) in enumerate(calls):
                # the stages at the new state after the last call only (the observation's):
                # the forces pushed are each step's own, from its actuation
                stage = _VEL if j == len(calls) - 1 else _NONE
                self.batch.step(rows, nstep=count, stage=stage)
                if push:
                    self.forces.push(r, self.f["actuator_force"][r, :n])
        except mjbatch.SimulationError as err:
            failed = np.isin(ids, err.ids)
            if stage == _NONE and not failed.all():  # the others' stages, as after the last
                self.batch.forward(ids[~failed], stage=_VEL)
        self.steps[r] += 1
        self.previous[r] = applied
        f, limits = self.f, self.limits
        # every speed and pull below its bound (.max and .min without their Python wrappers;
        # NaN fails both), no bad acceleration
        unstable = ~((np.maximum.reduce(np.abs(f["qvel"][r]), axis=1) < limits.max_speed)
                     & (np.minimum.reduce(f["actuator_force"][r, :n], axis=1)
                        > -limits.max_tension))
        unstable |= self.batch.warning[r, _BADQACC, 1] > 0
        if failed is not False:
            unstable |= failed
        if self.forces.fresh:  # (no forces pushed since the last test: nothing rings)
            unstable |= any_true(self.forces.ringing(r), axis=1)
        if checked:  # the energy on the ringing check's schedule
            unstable |= self.energies.push(r, self.energy.total(
                f["qvel"][r], f["xpos"][r], f["ten_length"][r], f["act"][r]))
        after = f["subtree_com"][r, 0, :2]
        progress, reached = self._progress(ids, before, after, bodies_before)
        # np.mean(applied ** 2, axis=1), without its overhead (the same sum and division)
        mean = np.add.reduce(applied * applied, axis=1) / applied.shape[1]
        control = -c.control_cost * mean * c.control_dt
        contact = np.zeros(ids.size)
        if c.bar_contact_cost:
            contact = -c.bar_contact_cost * self.bar_contacts(ids) * c.control_dt
        roll, slip = np.zeros(ids.size), np.zeros(ids.size)
        if c.roll_reward and bodies_before is not None:  # turning about the rolling axis
            roll = c.roll_reward * roll_change(bodies_before, self.turn_points(ids),
                                                self.target[r])
        if c.slip_cost:  # the metres the feet on the ground slid
            slip = -c.slip_cost * self.slip(ids) * c.control_dt
        terms = {"progress": progress, "control": control, "contact": contact, "roll": roll,
                 "slip": slip}
        if any_true(unstable):  # an unstable robot's terms are 0
            terms = {k: np.where(unstable, 0.0, v) for k, v in terms.items()}
        terms["unstable"] = unstable
        reward = terms["progress"] + terms["control"] + terms["contact"]
        if c.roll_reward or c.slip_cost:
            reward = reward + terms["roll"] + terms["slip"]
        return reward, unstable | reached, terms

    def _progress(self, ids: np.ndarray, before: np.ndarray, after: np.ndarray,
                  bodies_before: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        c, r = self.robot.config, self._rows(ids)
        if c.task == "direction":
            return np.einsum("ij,ij->i", after - before, self.target[r]), np.zeros(
                ids.size, dtype=bool)
        if c.task == "turn" and bodies_before is not None:  # (read before a turn's step)
            turned = yaw_change(bodies_before, self.turn_points(ids))
            drift = np.linalg.norm(after - before, axis=1)
            return (-turned if c.clockwise else turned) - drift, np.zeros(ids.size, bool)
        if c.task == "goal":
            far_before = np.linalg.norm(self.target[r] - before, axis=1)
            far = np.linalg.norm(self.target[r] - after, axis=1)
            return far_before - far, far < c.goal_radius_m
        moved = np.linalg.norm(self.f["xipos"][r][:, self._body] - self.start_xipos[r],
                               axis=2).mean(axis=1)
        return -moved * c.control_dt, np.zeros(ids.size, dtype=bool)

    # -- observing -------------------------------------------------------------------------

    def observe(self, ids: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """(k, size) observations of robots ``ids``, with their sensor noise (written into
        ``out`` where given, a (k, size) array)."""
        c, r, k = self.robot.config, self._rows(ids), ids.size
        if not (self._noise or c.history):
            return self._clean(ids, out)
        obs = self._noisy(ids, self._clean(ids))
        if not c.history:
            if out is None:
                return obs
            out[...] = obs
            return out
        full = np.concatenate([obs, self.past[r].reshape(k, -1)], axis=1, out=out)
        self.past[r] = np.concatenate([obs[:, None], self.past[r][:, :-1]], axis=1)
        return full

    def _clean(self, ids: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """(k, size) observations of robots ``ids`` before noise and history: compiled where
        it can be (the same values as :meth:`observe_numpy`), else with NumPy."""
        if self._kernel is None:
            return self.observe_numpy(ids, out)
        k, r = ids.size, self._rows(ids)
        if ids.dtype != np.intc:
            ids = ids.astype(np.intc)
        rows = out if out is not None and out.flags.c_contiguous else np.empty(
            (k, self._kernel.size))
        if self._fixed_frame:
            turn = (self._cos, self._sin) if isinstance(r, slice) else (self._cos[ids],
                                                                         self._sin[ids])
        else:
            yaw = self._frame_yaw(ids, self.f["subtree_com"][r, 0],
                                  self.f["xipos"][r][:, self._bodies])
            turn = np.cos(yaw), np.sin(yaw)
        over = self._kernel.observe(ids, turn[0], turn[1], rows)
        if over is not None:  # a body with more ground contacts than its sensor holds
            self._contacts_from_lists(ids[over], rows, over)
        if out is not None and rows is not out:
            out[...] = rows
        return rows if out is None else out

    def _contacts_from_lists(self, ids: np.ndarray, rows: np.ndarray, which: np.ndarray
                             ) -> None:
        """Writes the contact terms of ``rows[which]`` (robots ``ids``) from their contact
        lists."""
        touch, at_end = self._contact_list(ids)
        for name, flags in (("contact", touch), ("end_contact", at_end)):
            if name in self.robot.layout:
                start, stop = self.robot.layout[name]
                rows[which, start:stop] = flags

    def observe_numpy(self, ids: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """(k, size) observations of robots ``ids`` before noise and history, with NumPy: the
        reference the compiled observation equals (written into ``out`` where given)."""
        robot, f, r, k = self.robot, self.f, self._rows(ids), ids.size
        layout, c = robot.layout, robot.config
        com = f["subtree_com"][r, 0]
        xipos = f["xipos"][r][:, self._bodies]
        if self._fixed_frame:
            yaw, turn = self._yaw[r], (self._cos[r], self._sin[r])
        else:
            yaw = self._frame_yaw(ids, com, xipos)
            turn = np.cos(yaw)[:, None], np.sin(yaw)[:, None]  # (for every vector turned)
        terms: dict[str, np.ndarray] = {"height": com[:, 2:3]}
        if "pose" in layout:
            rel = _rotate(xipos - com[:, None], turn)
            quat = _quat_to_frame(f["xquat"][r][:, self._bodies], yaw)
            terms["pose"] = np.concatenate([rel, quat], axis=2).reshape(k, -1)
        # world vectors, written into one buffer and turned into the frame together
        world = np.empty((k, max((b for _, b in self._world.values()), default=0), 3))
        part = {name: world[:, a:b] for name, (a, b) in self._world.items()}
        if "velocity" in part:
            self._velocity(ids, xipos, part["velocity"])
        if "cable_length" in layout or "tension" in layout:
            terms["cable_length"] = f["ten_length"][r][:, robot.compiled.index.tendon]
        if "rest_length" in layout or "tension" in layout:
            terms["rest_length"] = robot.compiled.index.cable_act(f["act"][r])
        if "tension" in layout:
            terms["tension"] = self._tension(ids, terms)
        ends = None
        if "rod_axis" in layout or "end_contact" in layout:
            ends = self._end_positions(ids)
        if "rod_axis" in part and ends is not None:
            _rod_axes(ends, part["rod_axis"])
        if "task" in part:  # (x, y, 0): turned with the others
            part["task"][:, 0, :2] = self.target[r] if c.task == "direction" \
                else self.target[r] - com[:, :2]
            part["task"][:, 0, 2] = 0.0
        _turn(world, turn)
        for name, vectors in part.items():
            terms[name] = vectors.reshape(k, -1)
        terms["task"] = terms["task"][:, :2] if "task" in part else np.zeros((k, 2))
        if "contact" in layout or "end_contact" in layout:
            terms["contact"], terms["end_contact"] = self._contact(ids, ends)
        terms["previous_action"] = self.previous[r]
        terms["position"] = com[:, :2]
        parts = [terms[t].reshape(k, -1) for t in self._terms]
        return np.concatenate(parts, axis=1, out=out)

    def _tension(self, ids: np.ndarray, terms: dict[str, np.ndarray]) -> np.ndarray:
        """(k, n_cables) the load cells, with each robot's own law parameters [N]."""
        robot, r = self.robot, self._rows(ids)
        laws = [robot.compiled.law(self.models[i]) for i in ids]

        def each(name: str) -> np.ndarray:
            return np.stack([getattr(law, name) for law in laws])
        n = robot.compiled.n_cables
        return load_cell_reading(
            terms["cable_length"], terms["rest_length"], each("stiffness"),
            each("mode") == MODE_PD, self.f["ctrl"][r][:, :n], each("pd_stiffness"),
            each("max_tension"))

    def _frame_yaw(self, ids: np.ndarray, com: np.ndarray, xipos: np.ndarray) -> np.ndarray:
        """(k,) the observation frame's heading about the vertical [rad]."""
        c, r = self.robot.config, self._rows(ids)
        if c.frame == "robot":  # x toward body 0, seen from above
            ahead = xipos[:, 0, :2] - com[:, :2]
        elif c.task == "goal":
            ahead = self.target[r] - com[:, :2]
        else:
            ahead = self.heading[r]
        return np.arctan2(ahead[:, 1], ahead[:, 0])

    def _velocity(self, ids: np.ndarray, xipos: np.ndarray, out: np.ndarray) -> None:
        """Writes into ``out`` (k, 1 + 2 n_bodies, 3) the velocities observed, in the world
        frame: the centre of mass's, then each body's linear and angular velocity."""
        r, nb = self._rows(ids), self._body.size
        cvel = self.f["cvel"][r][:, self._bodies]  # (rotation, translation) at the root's com
        root_com = self.f["subtree_com"][r][:, self._root]
        linear = np.add(cvel[..., 3:], _cross(cvel[..., :3], xipos - root_com),
                        out=out[:, 1:1 + nb])
        np.einsum("b,kbj->kj", self._mass, linear, out=out[:, 0])
        out[:, 1 + nb:] = cvel[..., :3]

    def _contacts(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """MuJoCo's contact lists of robots ``ids``, stacked: the (c,) row in ``ids`` of each
        contact, its (c, 2) bodies and (c, 3) world position [m]."""
        counts = self.f["ncon"][self._rows(ids)]
        total = int(counts.sum())
        geoms, points = np.empty((total, 2), dtype=int), np.empty((total, 3))
        start = 0
        for i in ids[counts > 0].tolist():
            contact = self.batch.get_data(i, self._scratch_contacts).contact
            stop = start + len(contact)
            geoms[start:stop], points[start:stop] = contact.geom, contact.pos
            start = stop
        return np.repeat(np.arange(ids.size), counts), self._geom_body[geoms], points

    def _contact(self, ids: np.ndarray, ends: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
        """(k, n_bodies) 1 where a rigid body touches the world's geoms (the ground), and
        (k, 2 n_rods) 1 where the ground touches a rod nearer that end than the other;
        ``ends``: the rod ends of :meth:`_end_positions`, if already known.

        From the robots' contact sensors where the model has them (a robot with more contacts
        on a body than they hold: from its contact list), else from the contact lists."""
        if not self._ground.ready:
            return self._contact_list(ids, ends)
        if ends is None and self._end_body.size:
            ends = self._end_positions(ids)
        touch, out, over = self._ground.read(self.f["sensordata"][self._rows(ids)], ends)
        if any_true(over):
            touch[over], out[over] = self._contact_list(
                ids[over], None if ends is None else ends[over])
        return touch, out

    def _contact_list(self, ids: np.ndarray, ends: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`_contact` from MuJoCo's contact list of each robot."""
        at, pair, point = self._contacts(ids)
        ground = (pair == 0).any(axis=1)
        at, body, point = at[ground], pair[ground].max(axis=1), point[ground]
        touch = np.zeros((ids.size, self._body.size))
        out = np.zeros((ids.size, self._end_body.size))
        if not at.size:
            return touch, out
        slot = self._slot[body]
        touch[at[slot >= 0], slot[slot >= 0]] = 1.0
        if out.shape[1]:  # the nearest end of the touching rod's body
            where = (self._end_positions(ids) if ends is None else ends)[at]  # (c, 2 n_rods, 3)
            far = np.linalg.norm(where - point[:, None], axis=2)
            far[self._end_body[None] != body[:, None]] = np.inf
            hit = np.isfinite(far).any(axis=1)
            out[at[hit], np.argmin(far[hit], axis=1)] = 1.0
        return touch, out

    def _end_positions(self, ids: np.ndarray) -> np.ndarray:
        """(k, 2 n_rods, 3) world positions of the rod ends."""
        body = self._end_body
        r = self._rows(ids)
        xmat = self.f["xmat"][r][:, body].reshape(ids.size, -1, 3, 3)
        return self.f["xpos"][r][:, body] + np.einsum("kexy,ey->kex", xmat,
                                                              self._end_local)

    def turn_points(self, ids: np.ndarray) -> np.ndarray:
        """(k, p, 3) the points whose best rigid fit measures a turn (:func:`yaw_change`):
        the rod ends, or the rigid bodies' centres of mass where the robot has no rods [m]."""
        if self._end_body.size:
            return self._end_positions(ids)
        return self.f["xipos"][self._rows(ids)][:, self._body].copy()

    def slip(self, ids: np.ndarray) -> np.ndarray:
        """(k,) the summed horizontal speed of the rod ends on the ground [m/s]: each rod end
        with a ground contact on its end of the rod (the ``end_contact`` flags), at the
        velocity of its body's point there (MuJoCo's ``cvel``); 0 for a robot that rolls
        without slipping."""
        r, body = self._rows(ids), self._end_body
        if not body.size:
            return np.zeros(ids.size)
        ends = self._end_positions(ids)
        _, touching = self._contact(ids, ends)
        cvel = self.f["cvel"][r][:, body]  # (rotation, translation) at the root's com
        root_com = self.f["subtree_com"][r][:, self.robot.model.body_rootid[body]]
        velocity = cvel[..., 3:] + _cross(cvel[..., :3], ends - root_com)
        speed = np.hypot(velocity[..., 0], velocity[..., 1])
        return np.add.reduce(touching * speed, axis=1)

    def bar_contacts(self, ids: np.ndarray) -> np.ndarray:
        """(k,) contacts between two of the robot's rigid bodies, per robot: the sum of the
        pair sensors' counts where the model has them, else from the contact lists."""
        if self._bar_rows is not None:
            return np.add.reduce(self.f["sensordata"][self._rows(ids)][:, self._bar_rows], axis=1)
        at, bodies, _ = self._contacts(ids)
        both = self._robot_body[bodies].all(axis=1) & (bodies[:, 0] != bodies[:, 1])
        return np.bincount(at[both], minlength=ids.size).astype(float)

    def _noisy(self, ids: np.ndarray, obs: np.ndarray) -> np.ndarray:
        if not self._noise:
            return obs
        return obs + np.stack([self.rngs[i].normal(0.0, 1.0, obs.shape[1])
                               for i in ids]) * self._sigma

    def _noise_sigma(self, size: int) -> np.ndarray:
        """(size,) the std of each observed value's sensor noise."""
        r, layout = self.robot.config.randomization, self.robot.layout
        sigma = np.zeros(size)
        for term, std in (("height", r.length_noise_m), ("pose", r.length_noise_m),
                          ("cable_length", r.length_noise_m), ("rest_length", r.length_noise_m),
                          ("tension", r.tension_noise_n), ("velocity", r.velocity_noise),
                          ("position", r.length_noise_m)):
            if term in layout:
                sigma[slice(*layout[term])] = std
        if "pose" in layout:  # the quaternions stay clean: 7 values per body, the last 4
            start, stop = layout["pose"]
            sigma[start:stop] *= np.tile([1, 1, 1, 0, 0, 0, 0], (stop - start) // 7)
        return sigma

    def state(self, i: int) -> np.ndarray:
        """Robot ``i``'s ``mjSTATE_INTEGRATION`` state."""
        return np.array(self.batch.state[i])

    def data(self, i: int) -> Any:
        """Robot ``i``'s whole MjData (for rendering)."""
        return self.batch.get_data(i)


def _rod_axes(ends: np.ndarray, out: np.ndarray) -> None:
    """Writes into ``out`` (k, n_rods, 3) unit vectors from each rod's first end to its second
    (world), from the (k, 2 n_rods, 3) rod ends."""
    ends = ends.reshape(ends.shape[0], -1, 2, 3)
    axis = ends[:, :, 1] - ends[:, :, 0]
    # np.linalg.norm(axis, axis=2, keepdims=True), without its overhead (the same sum)
    np.divide(axis, np.sqrt(np.add.reduce(axis * axis, axis=2, keepdims=True)), out=out)


_NEXT, _AFTER = np.array([1, 2, 0]), np.array([2, 0, 1])  # each component's next two


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis (np.cross's result, component by component, without its
    per-call overhead)."""
    return a[..., _NEXT] * b[..., _AFTER] - a[..., _AFTER] * b[..., _NEXT]


def _as_slice(ids: np.ndarray) -> np.ndarray | slice:
    """``ids`` as a slice where they run on by one (indexing with it makes views), else
    themselves."""
    if ids.size and (np.diff(ids) == 1).all():
        return slice(int(ids[0]), int(ids[-1]) + 1)
    return ids


def _rotate(v: np.ndarray, turn: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """(k, m, 3) world vectors in the robot frames turned by the yaws about z whose (k, 1)
    cosines and sines are ``turn`` (computed once per observation)."""
    c, s = turn
    out = v.copy()
    out[..., 0] = c * v[..., 0] + s * v[..., 1]
    out[..., 1] = -s * v[..., 0] + c * v[..., 1]
    return out


def _turn(v: np.ndarray, turn: tuple[np.ndarray, np.ndarray]) -> None:
    """:func:`_rotate` in place."""
    c, s = turn
    x, y = v[..., 0], v[..., 1]
    first, second = c * x + s * y, -s * x + c * y
    v[..., 0], v[..., 1] = first, second


def _quat_to_frame(q: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """(k, m, 4) orientations relative to the robot frames, w >= 0."""
    aw, az = np.cos(yaw / 2)[:, None], -np.sin(yaw / 2)[:, None]
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.stack([aw * w - az * z, aw * x - az * y, aw * y + az * x, aw * z + az * w], axis=-1)
    return np.where(out[..., :1] < 0, -out, out)
