"""Gymnasium environments: the API contract, the vector env equal to the single one, and
rewards and actions that mean what the docs say."""

from __future__ import annotations

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium", reason="the rl extra (gymnasium) is not installed")

from gymnasium.utils.env_checker import check_env  # noqa: E402

from tensim.rl import EnvConfig, TensegrityEnv, TensegrityVectorEnv  # noqa: E402
from tensim.sim import compiled_available  # noqa: E402

SHORT = EnvConfig(episode_s=0.3)


def test_the_env_passes_gymnasiums_checker():
    check_env(TensegrityEnv(SHORT), skip_render_check=True)


@pytest.mark.skipif(not compiled_available(), reason="the vector env needs the compiled law")
def test_the_vector_env_steps_each_robot_as_the_single_env():
    single, vector = TensegrityEnv(SHORT), TensegrityVectorEnv(3, SHORT, threads=2)
    obs, _ = vector.reset()
    first, _ = single.reset()
    np.testing.assert_array_equal(obs[0], first)
    rng = np.random.default_rng(0)
    for _ in range(45):  # past the 30-step episode: the autoreset is covered too
        actions = rng.uniform(-0.07, 0.07, (3, single.action_space.shape[0]))
        obs, reward, terminated, truncated, info = vector.step(actions)
        o, r, t, tr, _ = single.step(actions[0])
        np.testing.assert_array_equal(info["final_obs"][0] if truncated[0] else obs[0], o)
        assert (reward[0], terminated[0], truncated[0]) == (r, t, tr)
        if tr:
            single.reset()
    assert not np.array_equal(obs[0], obs[1])  # the robots got different actions


def test_the_return_is_the_distance_walked_along_the_direction():
    env = TensegrityEnv(EnvConfig(episode_s=1.0, direction=(1.0, 1.0)))
    env.reset()
    start = env.sim.data.subtree_com[0, :2].copy()
    total, rng = 0.0, np.random.default_rng(1)
    for _ in range(100):
        total += env.step(rng.uniform(-0.07, 0.07, env.action_space.shape))[1]
    moved = env.sim.data.subtree_com[0, :2] - start
    assert abs(total) > 1e-5
    assert total == pytest.approx(moved @ np.array([1.0, 1.0]) / np.sqrt(2.0), rel=1e-9)


def test_rest_length_actions_command_the_motors():
    def final(reel: float) -> np.ndarray:
        env = TensegrityEnv(EnvConfig(action="rest_length", episode_s=1.0))
        obs, _ = env.reset()
        target = obs[2 * env.robot.n:3 * env.robot.n].copy()
        target[0] -= reel  # reel cable 0 in, hold the others
        for _ in range(30):  # 0.3 s at the motors' 0.07 m/s covers 1 cm
            obs = env.step(target)[0]
        np.testing.assert_allclose(obs[2 * env.robot.n:3 * env.robot.n], target, atol=1e-9)
        return obs

    n = TensegrityEnv(SHORT).robot.n
    held, reeled = final(0.0), final(0.01)
    assert reeled[n] > held[n] + 0.1  # the reeled-in cable pulls harder than when held
