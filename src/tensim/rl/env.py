"""The single-robot Gymnasium environment (one world of the batch engine).

Actions, observations and rewards are described in docs/rl.md and :class:`EnvConfig`.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from tensim.rl._render import Renders
from tensim.rl._robot import Robot
from tensim.rl._worlds import Worlds
from tensim.rl.config import EnvConfig
from tensim.rl.vector import _render_mode, _with_steps


class TensegrityEnv(gym.Env):
    """One tensegrity robot.

    Args:
        config: what it simulates.
        render_mode: None or ``"rgb_array"`` (offscreen images, as ``tensim render`` makes).
        max_episode_steps: overrides ``config.episode_s`` (Gymnasium's registration passes it).

    Raises:
        InputError: a bad configuration, or a robot that cannot be driven.
    """

    metadata: dict[str, Any] = {  # noqa: RUF012 - Gymnasium's attribute
        "render_modes": ["rgb_array"], "render_fps": 30}

    def __init__(self, config: EnvConfig | None = None, *, render_mode: str | None = None,
                 max_episode_steps: int | None = None):
        config = _with_steps(config or EnvConfig(), max_episode_steps)
        self.robot = Robot(config)
        self.worlds = Worlds(self.robot, 1)
        self.metadata = {**self.metadata, "render_fps": round(1.0 / config.control_dt)}
        self.render_mode = _render_mode(render_mode)
        self.action_space = self.robot.action_space
        self.observation_space = self.robot.observation_space
        self._renders: Renders | None = None
        self._one = np.zeros(1, dtype=np.int32)
        self._started = False

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        """Starts an episode: physics, start pose and task drawn from the robot's generator
        (seeded by ``seed``)."""
        super().reset(seed=seed)
        if seed is not None:
            self.worlds.seed(self._one, [seed])
        self.worlds.reset(self._one)
        self._started = True
        return self.worlds.observe(self._one)[0], {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Applies ``action`` for one control period.

        Raises:
            InputError: a NaN action, or one out of range with ``clip_actions=False``.
            gymnasium.error.ResetNeeded: before the first reset.
        """
        if not self._started:
            raise gym.error.ResetNeeded("call reset() before step()")
        commands, applied, clipped = self.robot.command(np.asarray(action)[None])
        reward, done, terms = self.worlds.step(self._one, commands, applied)
        terminated = bool(done[0])
        truncated = bool(self.worlds.steps[0] >= self.robot.config.max_steps) and not terminated
        info = {"reward_progress": float(terms["progress"][0]),
                "reward_control": float(terms["control"][0]),
                "reward_contact": float(terms["contact"][0]),
                "reward_roll": float(terms["roll"][0]), "reward_slip": float(terms["slip"][0]),
                "unstable": bool(terms["unstable"][0]), "action_clipped": bool(clipped[0])}
        return self.worlds.observe(self._one)[0], float(reward[0]), terminated, truncated, info

    def render(self) -> np.ndarray | None:
        """The (height, width, 3) uint8 image of the robot (``render_mode="rgb_array"``)."""
        if self.render_mode is None:
            return None
        if self._renders is None:
            self._renders = Renders(self.robot.compiled)
        return self._renders.image(self.worlds.models[0], self.worlds.data(0))

    def close(self) -> None:
        """Frees the offscreen renderer."""
        if self._renders is not None:
            self._renders.close()
            self._renders = None
