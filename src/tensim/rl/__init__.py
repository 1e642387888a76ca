"""Reinforcement learning: Gymnasium environments of tensegrity robots (optional extra
``tensim[rl]``), registered as ``tensim/Tensegrity-v1`` for ``gym.make`` and
``gym.make_vec`` (whose vector entry point steps all robots on the batch engine)."""

import gymnasium as gym

from tensim.rl.config import DEFAULT_OBSERVATION, OBSERVATIONS, EnvConfig, Randomization
from tensim.rl.env import TensegrityEnv
from tensim.rl.vector import TensegrityVectorEnv

ENV_ID = "tensim/Tensegrity-v1"

if ENV_ID not in gym.registry:
    gym.register(ENV_ID, entry_point="tensim.rl.env:TensegrityEnv",
                 vector_entry_point="tensim.rl.vector:TensegrityVectorEnv")

__all__ = ["DEFAULT_OBSERVATION", "ENV_ID", "OBSERVATIONS", "EnvConfig", "Randomization",
           "TensegrityEnv", "TensegrityVectorEnv"]
