"""Gymnasium environments: one tensegrity robot, or many on the batch engine.

An action sets every cable's command for one control period: its target velocity V* [m/s]
under the robot's impedance laws (``action="vstar"``), or its commanded rest length [m]
(``action="rest_length"``). The observation is one flat vector (float64), in this order:
cable lengths [m] (n_cables), load-cell tensions [N] (n_cables), rest lengths [m]
(n_cables), then per rigid body its position [m] (3) and orientation quaternion w, x, y, z (4).
The reward of a step is the whole robot's centre-of-mass displacement along ``direction``
[m] (a unit vector in the ground plane), so an episode's return is the distance walked that
way. An unstable simulation ends the episode (terminated); the time limit truncates it.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from mujoco import batch as mjbatch

from tensim.model import CompiledModel, WorldOptions, compile_structure
from tensim.models import preset
from tensim.sim import (
    MODE_IMPEDANCE,
    MODE_REST,
    Simulation,
    SimulationError,
    StabilityLimits,
    load_cell_tension,
)


@dataclasses.dataclass(frozen=True)
class EnvConfig:
    """What an environment simulates.

    Attributes:
        model: the preset (its impedance controller sets the gains in ``vstar`` mode).
        action: ``"vstar"`` or ``"rest_length"``.
        control_dt: control period: physics steps per action x dt [s].
        episode_s: episode length [s].
        direction: (2,) the rewarded direction in the ground plane.
        world: physics step, gravity, ground.
    """

    model: str = "tetraspine3"
    action: str = "vstar"
    control_dt: float = 0.01
    episode_s: float = 10.0
    direction: tuple[float, float] = (0.0, 1.0)
    world: WorldOptions = dataclasses.field(default_factory=WorldOptions)

    def __post_init__(self) -> None:
        if self.action not in ("vstar", "rest_length"):
            raise ValueError(f"action must be 'vstar' or 'rest_length', got {self.action!r}")
        steps = round(self.control_dt / self.world.timestep)
        if steps < 1 or abs(steps * self.world.timestep - self.control_dt) > 1e-12:
            raise ValueError(f"control_dt = {self.control_dt} s must be a whole number of "
                             f"physics steps ({self.world.timestep} s)")
        if not self.episode_s >= self.control_dt:
            raise ValueError(f"episode_s must be >= control_dt, got {self.episode_s}")
        norm = float(np.hypot(*self.direction))
        if not norm > 0:
            raise ValueError("direction must be a non-zero vector in the ground plane")


class _Robot:
    """What both environments share: the compiled robot, its spaces, the initial state."""

    def __init__(self, config: EnvConfig):
        self.config = config
        p = preset(config.model)
        self.compiled: CompiledModel = compile_structure(p.build(), config.world)
        self.controller = p.controller() if config.action == "vstar" else None
        c = self.compiled
        self.n, self.n_bodies = c.n_cables, len(c.index.bodies)
        self.control_steps = round(config.control_dt / config.world.timestep)
        self.max_steps = round(config.episode_s / config.control_dt)
        self.direction = np.asarray(config.direction, dtype=float) / np.hypot(*config.direction)
        if config.action == "vstar":
            speed = c.law().max_speed.astype(np.float64)
            self.action_space = gym.spaces.Box(-speed, speed, dtype=np.float64)
        else:
            self.action_space = gym.spaces.Box(c.law().min_rest.astype(np.float64),
                                               1.5 * c.rest_length, dtype=np.float64)
        size = 3 * self.n + 7 * self.n_bodies
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (size,), dtype=np.float64)
        with Simulation(c, controller=_Configure(self)) as sim:
            self.model = sim.model  # with the controller's gains and modes
            self.initial_state = sim.get_state()

    def configure(self, setup: Any) -> None:
        if self.controller is not None:
            self.controller.configure(setup)
        setup.drive.mode[:] = MODE_IMPEDANCE if self.config.action == "vstar" else MODE_REST

    def observe(self, length: np.ndarray, velocity: np.ndarray, rest: np.ndarray,
                stiffness: np.ndarray, xpos: np.ndarray, xquat: np.ndarray) -> np.ndarray:
        """(..., size) observations from (..., ntendon) lengths and (..., nbody, k) poses."""
        idx = self.compiled.index
        x = length[..., idx.tendon]
        tension = load_cell_tension(x, rest, stiffness)
        poses = np.concatenate([xpos[..., idx.body, :], xquat[..., idx.body, :]], axis=-1)
        return np.concatenate([x, tension, rest, poses.reshape(*poses.shape[:-2], -1)],
                              axis=-1)


class TensegrityEnv(gym.Env):
    """One robot (see the module docstring for actions, observations and reward)."""

    metadata: dict[str, Any] = {"render_modes": []}  # noqa: RUF012 - Gymnasium's attribute

    def __init__(self, config: EnvConfig | None = None):
        self.robot = _Robot(config or EnvConfig())
        self.action_space = self.robot.action_space
        self.observation_space = self.robot.observation_space
        self.sim = Simulation(self.robot.compiled, controller=_Configure(self.robot))
        self._steps = 0

    def _obs(self) -> np.ndarray:
        d, drive = self.sim.data, self.sim.drive
        return self.robot.observe(d.ten_length, d.ten_velocity, drive.rest.copy(),
                                  drive.stiffness, d.xpos, d.xquat)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        """Back to the settled build pose (the state after the motor update at t = 0)."""
        super().reset(seed=seed)
        mujoco.mj_resetData(self.sim.model, self.sim.data)  # clears the warnings too
        self.sim.set_state(self.robot.initial_state)
        self._steps = 0
        return self._obs(), {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Applies ``action`` for one control period."""
        box = self.robot.action_space
        action = np.clip(np.asarray(action, dtype=float), box.low, box.high)
        drive = self.sim.drive
        if self.robot.config.action == "vstar":
            drive.set_target_velocity(action[None, :], 1e9)
        else:
            drive.rest_command[:] = action
        before = self.sim.data.subtree_com[0, :2].copy()
        self._steps += 1
        truncated = self._steps >= self.robot.max_steps
        try:
            self.sim.step(self.robot.control_steps)
        except SimulationError as err:
            return self._obs(), 0.0, True, truncated, {"error": str(err)}
        reward = float((self.sim.data.subtree_com[0, :2] - before) @ self.robot.direction)
        return self._obs(), reward, False, truncated, {}


@dataclasses.dataclass
class _Configure:
    robot: _Robot

    def configure(self, sim: Any) -> None:
        self.robot.configure(sim)


class TensegrityVectorEnv(VectorEnv):
    """``num_envs`` robots stepped together on the batch engine's threads.

    Each robot steps exactly as a :class:`TensegrityEnv` given the same actions. Finished
    episodes reset in the same step (``AutoresetMode.SAME_STEP``): the returned observation
    is the new episode's, and ``info["final_obs"]`` holds the last one.
    """

    metadata: dict[str, Any] = {  # noqa: RUF012 - Gymnasium's attribute
        "autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(self, num_envs: int, config: EnvConfig | None = None, threads: int = 1):
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        self.robot = robot = _Robot(config or EnvConfig())
        self.num_envs = num_envs
        self.single_action_space = robot.action_space
        self.single_observation_space = robot.observation_space
        self.action_space = gym.vector.utils.batch_space(robot.action_space, num_envs)
        self.observation_space = gym.vector.utils.batch_space(robot.observation_space,
                                                              num_envs)
        self.batch = mjbatch.Batch(robot.model, num_envs, nthread=threads)
        self._fields = {k: self.batch.bind(k) for k in
                        ("ten_length", "ten_velocity", "xpos", "xquat", "subtree_com", "qvel",
                         "actuator_force")}
        self._act = self.batch.bind("act")
        self._ctrl = self.batch.bind("ctrl")
        self._stiffness = robot.compiled.law(robot.model).stiffness
        self._steps = np.zeros(num_envs, dtype=int)
        self._limits = StabilityLimits()

    def _reset_ids(self, ids: np.ndarray) -> None:
        self.batch.reset(ids, stage=mujoco.mjtStage.mjSTAGE_NONE)  # clears the warnings too
        self.batch.state[ids] = self.robot.initial_state
        self.batch.forward(ids)
        self._steps[ids] = 0

    def _obs(self) -> np.ndarray:
        f, rest = self._fields, self.robot.compiled.index.cable_act(self._act)
        return self.robot.observe(f["ten_length"], f["ten_velocity"], rest, self._stiffness,
                                  f["xpos"], f["xquat"])

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        """Every robot back to the settled build pose."""
        self._reset_ids(np.arange(self.num_envs, dtype=np.int32))
        return self._obs(), {}

    def step(self, actions: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Applies each robot's action for one control period."""
        box = self.robot.action_space
        actions = np.clip(np.asarray(actions, dtype=float), box.low, box.high)
        n = self.robot.n
        self._ctrl[:, :n] = actions
        before = self._fields["subtree_com"][:, 0, :2].copy()
        everyone = np.arange(self.num_envs, dtype=np.int32)
        try:
            self.batch.step(nstep=self.robot.control_steps)
            failed = np.zeros(self.num_envs, dtype=bool)
        except mjbatch.SimulationError as err:
            failed = np.isin(everyone, err.ids)
        self._steps += 1
        f = self._fields
        speed = np.abs(f["qvel"]).max(axis=1)
        force = -f["actuator_force"][:, :n].min(axis=1)
        bad = self.batch.warning[:, mujoco.mjtWarning.mjWARN_BADQACC, 1] > 0
        terminated = failed | ~(speed < self._limits.max_speed) | \
            ~(force < self._limits.max_tension) | bad
        truncated = (self._steps >= self.robot.max_steps) & ~terminated
        reward = np.where(terminated, 0.0,
                          (f["subtree_com"][:, 0, :2] - before) @ self.robot.direction)
        obs = self._obs()
        info: dict[str, Any] = {}
        done = terminated | truncated
        if done.any():
            info["final_obs"] = obs.copy()
            self._reset_ids(everyone[done])
            obs = self._obs()
        return obs, reward, terminated, truncated, info
