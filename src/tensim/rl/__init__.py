"""Reinforcement learning: Gymnasium environments of tensegrity robots (optional extra
``tensim[rl]``), registered as ``tensim/Tensegrity-v1`` for ``gym.make`` and
``gym.make_vec`` (whose vector entry point steps all robots on the batch engine)."""

import gymnasium as gym

from tensim.rl.config import (
    DEFAULT_OBSERVATION,
    OBSERVATIONS,
    ROLLING_OBSERVATION,
    EnvConfig,
    Randomization,
)
from tensim.rl.env import TensegrityEnv
from tensim.rl.vector import TensegrityVectorEnv

ENV_ID = "tensim/Tensegrity-v1"

if ENV_ID not in gym.registry:
    # the time limit of the default config (10 s of 10 ms periods); an env built from
    # another config truncates its own episodes at config.episode_s as well
    gym.register(ENV_ID, entry_point="tensim.rl.env:TensegrityEnv",
                 vector_entry_point="tensim.rl.vector:TensegrityVectorEnv",
                 max_episode_steps=EnvConfig().max_steps)

__all__ = ["DEFAULT_OBSERVATION", "ENV_ID", "OBSERVATIONS", "ROLLING_OBSERVATION", "EnvConfig",
           "Randomization",
           "TensegrityEnv", "TensegrityVectorEnv"]
