"""The reinforcement-learning loop on tensegrity robots, without training anything heavy.

Eight Tetraspine3 robots step together on the batch engine; a random-search "policy" (one
constant normalised V* per cable, perturbed each episode) keeps the best it has seen. Swap the
policy for any Gymnasium-compatible learner (examples/train_ppo.py trains PPO).
Run: python examples/rl_loop.py
"""

import numpy as np

from tensim.rl import EnvConfig, TensegrityVectorEnv

config = EnvConfig(episode_s=2.0, direction=(0.0, 1.0), threads=2)
envs = TensegrityVectorEnv(8, config)
rng = np.random.default_rng(0)
best, best_return = np.zeros(envs.single_action_space.shape), -np.inf
for episode in range(3):
    # each robot tries the best policy so far plus its own perturbation, within [-1, 1]
    policies = np.clip(best + rng.normal(0.0, 0.4, (envs.num_envs, best.size)), -1.0, 1.0)
    envs.reset(seed=episode * envs.num_envs)
    returns = np.zeros(envs.num_envs)
    for _ in range(config.max_steps):
        _, reward, terminated, truncated, _ = envs.step(policies)
        returns += reward
    if returns.max() > best_return:
        best, best_return = policies[returns.argmax()], returns.max()
    print(f"episode {episode}: best return {returns.max() * 100:.2f} cm "
          f"(mean {returns.mean() * 100:.2f} cm)")
envs.close()
