"""Reinforcement learning: Gymnasium environments of tensegrity robots (optional extra
``tensim[rl]``)."""

from tensim.rl.env import EnvConfig, TensegrityEnv, TensegrityVectorEnv

__all__ = ["EnvConfig", "TensegrityEnv", "TensegrityVectorEnv"]
