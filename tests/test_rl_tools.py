"""The community's tools on the environments: Gymnasium's RecordVideo (offscreen images) and
a short Stable-Baselines3 PPO run on the batch engine through tensim.rl.sb3."""

from __future__ import annotations

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium", reason="the rl extra (gymnasium) is not installed")

from tensim.rl import EnvConfig, TensegrityEnv, TensegrityVectorEnv  # noqa: E402
from tensim.sim import compiled_available  # noqa: E402
from tensim.viz import _gl  # noqa: E402

pytestmark = pytest.mark.skipif(not compiled_available(),
                                reason="the environments step on the compiled cable law")

SHORT = EnvConfig(episode_s=0.1, control_dt=0.02)  # 5 control periods


def _backend() -> str:
    try:
        return _gl.select_backend()
    except _gl.OffscreenUnavailable as err:
        pytest.skip(f"no offscreen OpenGL backend on this machine ({err}); to run these "
                    "tests: sudo apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri libosmesa6")


def test_rgb_array_renders_the_robot_as_it_moves():
    _backend()
    env = TensegrityEnv(SHORT, render_mode="rgb_array")
    env.reset(seed=0)
    first = env.render()
    for _ in range(5):
        env.step(np.ones(12))
    assert first.shape == (360, 480, 3) and first.dtype == np.uint8
    assert not np.array_equal(first, env.render())  # the time label and the robot changed
    env.close()


def test_record_video_runs_on_the_vector_env(tmp_path):
    _backend()
    pytest.importorskip("moviepy", reason="Gymnasium's RecordVideo needs moviepy (rl extra)")
    from gymnasium.wrappers.vector import RecordVideo

    vector = TensegrityVectorEnv(2, SHORT, render_mode="rgb_array")
    env = RecordVideo(vector, str(tmp_path), episode_trigger=lambda k: k == 0)
    env.reset(seed=0)
    for _ in range(6):  # one whole episode and the next-step reset
        env.step(np.zeros((2, 12)))
    env.close()
    videos = list(tmp_path.glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000


def test_a_short_ppo_run_trains_on_the_batch_engine():
    pytest.importorskip("stable_baselines3",
                        reason="stable-baselines3 (rl extra) is not installed")
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_checker import check_env
    from stable_baselines3.common.vec_env import VecNormalize

    from tensim.rl.sb3 import SB3VecEnv

    check_env(TensegrityEnv(SHORT))  # SB3's own checker on the single env
    venv = SB3VecEnv(4, SHORT)
    venv.seed(0)
    model = PPO("MlpPolicy", VecNormalize(venv), n_steps=64, batch_size=64, n_epochs=1,
                seed=0, device="cpu")
    model.learn(256)
    assert model.num_timesteps == 256
    obs = venv.reset()
    for _ in range(5):  # the 5th period ends the episodes: SB3's same-step convention
        obs, _, done, infos = venv.step(np.zeros((4, 12)))
    assert done.all() and obs.shape == (4, venv.observation_space.shape[0])
    assert all(info["TimeLimit.truncated"] for info in infos)
    assert not np.array_equal(infos[0]["terminal_observation"], obs[0])  # obs: a new start
