"""Stable-Baselines3 on the batch engine: :class:`SB3VecEnv` is an SB3 ``VecEnv`` over a
same-step :class:`~tensim.rl.TensegrityVectorEnv`, so ``PPO("MlpPolicy", SB3VecEnv(...))``
trains every robot at once with no user code (needs ``stable-baselines3``)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

from tensim.rl.config import EnvConfig
from tensim.rl.vector import TensegrityVectorEnv

_TERMS = ("reward_progress", "reward_control", "reward_contact", "reward_roll", "reward_slip",
          "unstable")


class SB3VecEnv(VecEnv):
    """``num_envs`` robots as one Stable-Baselines3 vector env.

    Each robot's info holds its reward terms (``reward_progress``, ``reward_control``,
    ``reward_contact``, ``reward_roll``, ``reward_slip``) and ``unstable``. An episode's last
    observation is in ``infos[i]["terminal_observation"]`` and a time-limit end sets
    ``infos[i]["TimeLimit.truncated"]``, as SB3's own vector envs do.

    Args:
        num_envs: robots.
        config: what they simulate (``config.threads`` worker threads).
        render_mode: None or ``"rgb_array"``.
    """

    def __init__(self, num_envs: int, config: EnvConfig | None = None,
                 render_mode: str | None = None):
        self.env = TensegrityVectorEnv(num_envs, config, autoreset_mode="same_step",
                                       render_mode=render_mode)
        super().__init__(num_envs, self.env.single_observation_space,
                         self.env.single_action_space)
        self.render_mode = render_mode
        self._actions: np.ndarray = np.zeros((num_envs, self.env.robot.n))

    def reset(self) -> np.ndarray:
        """Every robot starts an episode (with the seeds given to :meth:`seed`, once)."""
        seeds = None if all(s is None for s in self._seeds) else list(self._seeds)
        obs, _ = self.env.reset(seed=seeds)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        obs, reward, terminated, truncated, info = self.env.step(self._actions)
        done = terminated | truncated
        columns = [info[k].tolist() for k in _TERMS]  # Python floats and bools, as .item()
        infos: list[dict[str, Any]] = [dict(zip(_TERMS, values, strict=True))
                                       for values in zip(*columns, strict=True)]
        for i in done.nonzero()[0]:
            infos[i]["terminal_observation"] = info["final_obs"][i]
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return obs, reward.astype(np.float32), done, infos

    def close(self) -> None:
        self.env.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        images = self.env.render()
        return list(images) if images is not None else [None] * self.num_envs

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        return [getattr(self.env, attr_name) for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        setattr(self.env, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: Any = None,
                   **method_kwargs: Any) -> list[Any]:
        method = getattr(self.env, method_name)
        return [method(*method_args, **method_kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def _get_indices(self, indices: Any) -> Iterable[int]:
        if indices is None:
            return range(self.num_envs)
        return [indices] if isinstance(indices, int) else indices
