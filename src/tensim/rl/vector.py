"""The vector environment: ``num_envs`` robots stepped together on the batch engine."""

from __future__ import annotations

import dataclasses
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv

from tensim._input import InputError
from tensim.rl._render import Renders
from tensim.rl._robot import Robot
from tensim.rl._worlds import Worlds, any_true
from tensim.rl.config import EnvConfig

_MODES = {"next_step": AutoresetMode.NEXT_STEP, "same_step": AutoresetMode.SAME_STEP,
          "disabled": AutoresetMode.DISABLED, AutoresetMode.NEXT_STEP: AutoresetMode.NEXT_STEP,
          AutoresetMode.SAME_STEP: AutoresetMode.SAME_STEP,
          AutoresetMode.DISABLED: AutoresetMode.DISABLED}


class TensegrityVectorEnv(VectorEnv):
    """``num_envs`` robots on the batch engine's threads, each stepping exactly as a
    :class:`~tensim.rl.TensegrityEnv` given the same seed and actions.

    Args:
        num_envs: robots.
        config: what they simulate (``config.threads`` worker threads).
        autoreset_mode: ``"next_step"`` (Gymnasium's default: the step after an episode ends
            resets that robot, ignores its action and returns reward 0) or ``"same_step"``
            (the ending step already returns the new episode's observation, with the last
            one in ``info["final_obs"]`` and its info in ``info["final_info"]``, masked by
            ``info["_final_obs"]`` / ``info["_final_info"]``) or ``"disabled"`` (no
            autoreset: reset ended robots with ``reset(options={"reset_mask": ...})``;
            stepping a robot whose episode ended is refused).
        render_mode: None or ``"rgb_array"`` (one offscreen image per robot).
        max_episode_steps: overrides ``config.episode_s`` (Gymnasium's registration passes it).

    Raises:
        InputError: bad arguments or a robot that cannot be driven.
    """

    metadata: dict[str, Any] = {  # noqa: RUF012 - Gymnasium's attribute
        "autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": ["rgb_array"],
        "render_fps": 30}

    def __init__(self, num_envs: int = 1, config: EnvConfig | None = None, *,
                 autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
                 render_mode: str | None = None, max_episode_steps: int | None = None):
        if not (isinstance(num_envs, int) and num_envs >= 1):
            raise InputError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        mode = _MODES.get(autoreset_mode)
        if mode is None:
            raise InputError(f"autoreset_mode must be 'next_step', 'same_step' or 'disabled' "
                             f"(or an AutoresetMode of those), got {autoreset_mode!r}")
        config = _with_steps(config or EnvConfig(), max_episode_steps)
        self.robot = Robot(config)
        self.worlds = Worlds(self.robot, num_envs, config.threads)
        self.num_envs = num_envs
        self.metadata = {**self.metadata, "autoreset_mode": mode,
                         "render_fps": round(1.0 / config.control_dt)}
        self.autoreset_mode = mode
        self.render_mode = _render_mode(render_mode)
        self.single_action_space = self.robot.action_space
        self.single_observation_space = self.robot.observation_space
        self.action_space = gym.vector.utils.batch_space(self.robot.action_space, num_envs)
        self.observation_space = gym.vector.utils.batch_space(self.robot.observation_space,
                                                              num_envs)
        self._all = np.arange(num_envs, dtype=np.int32)
        self._autoreset = np.zeros(num_envs, dtype=bool)
        self._ended = np.zeros(num_envs, dtype=bool)
        self._renders: Renders | None = None
        self._obs = np.zeros((num_envs, *self.robot.observation_space.shape))
        self._started = False

    def reset(self, *, seed: int | list[int | None] | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """Starts new episodes: every robot, or those of ``options["reset_mask"]``.

        ``seed``: an int seeds robot i with seed + i (as Gymnasium's vector envs do); a list
        gives one seed per robot.
        """
        mask = np.ones(self.num_envs, dtype=bool)
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"])
            if mask.shape != (self.num_envs,) or mask.dtype != np.bool_ or not mask.any():
                raise InputError(f"options['reset_mask'] must be a bool array of shape "
                                 f"({self.num_envs},) with a True, got {mask!r}")
        ids = self._all[mask]
        if seed is not None:
            seeds = [seed + i for i in range(self.num_envs)] if isinstance(seed, int) \
                else list(seed)
            if len(seeds) != self.num_envs:
                raise InputError(f"seed must be an int or {self.num_envs} seeds, got {seed!r}")
            self.worlds.seed(ids, [seeds[i] for i in ids])
        self.worlds.reset(ids)
        self._started = True
        self._autoreset[ids] = False
        self._ended[ids] = False
        self._obs[ids] = self.worlds.observe(ids)
        return self._obs.copy(), {}

    def step(self, actions: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Applies each robot's action for one control period (see the class for resets).

        Raises:
            InputError: a NaN action, or one out of range with ``clip_actions=False``.
            gymnasium.error.ResetNeeded: before the first reset.
        """
        if not self._started:
            raise gym.error.ResetNeeded("call reset() before step()")
        if any_true(self._ended):
            raise gym.error.ResetNeeded(
                f"robots {self._all[self._ended].tolist()} ended their episodes "
                "(autoreset_mode='disabled'): reset them with "
                "reset(options={'reset_mask': mask}) before stepping")
        commands, applied, clipped = self.robot.command(actions)
        n = self.num_envs
        info: dict[str, Any] = {}
        if not any_true(self._autoreset):  # (the common case: every robot steps, no copies)
            reward, terminated, terms = self.worlds.step(self._all, commands, applied)
            truncated = (self.worlds.steps >= self.robot.config.max_steps) & ~terminated
            self.worlds.observe(self._all, out=self._obs)
            info = _step_info(n, self._all, terms, clipped)
        else:
            reward, terminated, truncated = np.zeros(n), np.zeros(n, bool), np.zeros(n, bool)
            live = self._all[~self._autoreset]
            fresh = self._all[self._autoreset]
            # next-step autoreset: these robots start over, their action unused
            self.worlds.reset(fresh)
            self._obs[fresh] = self.worlds.observe(fresh)
            if live.size:
                r, done, terms = self.worlds.step(live, commands[live], applied[live])
                reward[live] = r
                terminated[live] = done
                truncated[live] = (self.worlds.steps[live] >= self.robot.config.max_steps) \
                    & ~done
                self._obs[live] = self.worlds.observe(live)
                info = _step_info(n, live, terms, clipped)
        ended = terminated | truncated
        if self.autoreset_mode == AutoresetMode.SAME_STEP and any_true(ended):
            info["final_obs"] = np.full(n, None, dtype=object)
            info["final_info"] = {k: v.copy() for k, v in info.items() if k != "final_obs"}
            for i in self._all[ended]:
                info["final_obs"][i] = self._obs[i].copy()
            info["_final_obs"] = info["_final_info"] = ended.copy()
            self.worlds.reset(self._all[ended])
            self._obs[ended] = self.worlds.observe(self._all[ended])
        elif self.autoreset_mode == AutoresetMode.DISABLED:
            self._ended = ended
        else:
            self._autoreset = ended
        return self._obs.copy(), reward, terminated, truncated, info

    def render(self) -> tuple[np.ndarray, ...] | None:
        """One (height, width, 3) uint8 image per robot (``render_mode="rgb_array"``)."""
        if self.render_mode is None:
            return None
        if self._renders is None:
            self._renders = Renders(self.robot.compiled)
        return tuple(self._renders.image(self.worlds.models[i], self.worlds.data(i))
                     for i in range(self.num_envs))

    def close_extras(self, **kwargs: Any) -> None:
        """Frees the offscreen renderer."""
        if self._renders is not None:
            self._renders.close()
            self._renders = None


def _step_info(n: int, live: np.ndarray, terms: dict[str, np.ndarray], clipped: np.ndarray
               ) -> dict[str, Any]:
    """Gymnasium's vector info: each key with its ``_key`` mask of the robots that have it."""
    every = live.size == n  # every robot stepped: the (new) term arrays are the columns
    mask = np.ones(n, dtype=bool)
    if not every:
        mask[:] = False
        mask[live] = True
    info: dict[str, Any] = {}
    for key, values in (("reward_progress", terms["progress"]),
                        ("reward_control", terms["control"]),
                        ("reward_contact", terms["contact"]), ("reward_roll", terms["roll"]),
                        ("reward_slip", terms["slip"]), ("unstable", terms["unstable"]),
                        ("action_clipped", clipped if every else clipped[live])):
        full = values
        if not every:
            full = np.zeros(n, dtype=values.dtype)
            full[live] = values
        info[key], info[f"_{key}"] = full, mask.copy()
    return info


def _with_steps(config: EnvConfig, max_episode_steps: int | None) -> EnvConfig:
    if max_episode_steps is None:
        return config
    if not (isinstance(max_episode_steps, int) and max_episode_steps >= 1):
        raise InputError(f"max_episode_steps must be an integer >= 1, got {max_episode_steps!r}")
    return dataclasses.replace(config, episode_s=max_episode_steps * config.control_dt)


def _render_mode(mode: str | None) -> str | None:
    if mode not in (None, "rgb_array"):
        raise InputError(f"render_mode must be None or 'rgb_array', got {mode!r}")
    return mode
