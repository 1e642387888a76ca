"""The compiled observation (``tensim/rl/_observe.c``) against the NumPy path it replaces
(``Worlds.observe_numpy``, the reference): bit for bit on recorded states of rolling robots,
for every term it writes, each task and frame, some robots or all, and through whole episodes
(noise, history, randomised physics, resets, copies)."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest

pytest.importorskip("gymnasium", reason="the rl extra (gymnasium) is not installed")

from tensim.rl import EnvConfig, Randomization, TensegrityVectorEnv, _contacts, _worlds
from tensim.rl._observe_native import TERMS, available
from tensim.rl.config import ROLLING_OBSERVATION
from tensim.sim import compiled_available
from test_rl_rolling import three_bar

pytestmark = pytest.mark.skipif(not (compiled_available() and available()),
                                reason="needs the compiled cable law and observation")

_ALL = ("height", "velocity", "rod_axis", "cable_length", "contact", "end_contact", "task",
        "previous_action", "position")


def _config(path, **kw) -> EnvConfig:
    """The test's 3-bar, tumbling from noisy starts (rods onto the ground and each other)."""
    base = EnvConfig(model=str(path), control_dt=0.02, observation=_ALL, frame="heading",
                     randomization=Randomization(yaw=True, pose_noise_m=0.1))
    return dataclasses.replace(base, **kw)


def _recorded(env: TensegrityVectorEnv, periods: int, seed: int):
    """Steps ``env`` on random actions, yielding after each period (a recorded state)."""
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    for _ in range(periods):
        env.step(rng.uniform(-1, 1, env.action_space.shape))
        yield rng


@pytest.mark.parametrize("task, frame", [("direction", "heading"), ("goal", "heading"),
                                         ("turn", "heading"), ("direction", "robot")])
def test_the_compiled_observation_equals_numpy_bit_for_bit(tmp_path, task, frame):
    path = tmp_path / "three_bar.yaml"
    path.write_text(three_bar())
    assert set(_ALL) == set(TERMS)  # every term the kernel writes, in a shuffled order
    order = tuple(np.random.default_rng(1).permutation(_ALL))
    env = TensegrityVectorEnv(5, _config(path, task=task, frame=frame, observation=order))
    w = env.worlds
    assert w._kernel is not None
    touched = 0
    for rng in _recorded(env, 60, seed=2):
        for ids in (np.arange(5, dtype=np.int32),
                    np.sort(rng.choice(5, rng.integers(1, 5), replace=False)).astype(np.int32)):
            fast, slow = w._clean(ids), w.observe_numpy(ids)
            assert fast.tobytes() == slow.tobytes()  # (the same bits, signed zeros included)
            touched += int(slow[:, slice(*w.robot.layout["end_contact"])].sum())
    assert touched > 0  # end caps met the ground


def test_a_sensor_that_overflows_takes_the_contact_list_in_the_compiled_path(monkeypatch):
    # one contact slot per sensor: tetraspine3's vertebrae stand on several feet, so their
    # sensors overflow and those robots' flags come from their contact lists
    monkeypatch.setattr(_contacts, "SLOTS", 1)
    env = TensegrityVectorEnv(3, EnvConfig(model="tetraspine3",
                                           observation=("end_contact", "height", "contact")))
    w = env.worlds
    assert w._kernel is not None
    overflowed = 0
    for _ in _recorded(env, 20, seed=0):
        ids = np.arange(3, dtype=np.int32)
        np.testing.assert_array_equal(w._clean(ids), w.observe_numpy(ids))
        over = w._kernel.observe(ids, w._cos, w._sin, np.empty((3, w._kernel.size)))
        overflowed += 0 if over is None else int(over.sum())
    assert overflowed > 0  # the fallback ran


def _episode(env, seed: int = 5, periods: int = 70) -> list:
    out = [env.reset(seed=seed)[0]]
    rng = np.random.default_rng(seed)
    for _ in range(periods):
        obs, reward, terminated, truncated, info = env.step(
            rng.uniform(-1, 1, env.action_space.shape))
        out += [obs, reward, terminated, truncated, info.get("final_obs")]
    return out


def test_whole_episodes_are_the_same_with_and_without_the_compiled_observation(monkeypatch,
                                                                                tmp_path):
    # the roll task's observation, with sensor noise, history, randomised physics and episode
    # ends (same-step resets of some robots)
    path = tmp_path / "three_bar.yaml"
    path.write_text(three_bar())
    config = _config(path, observation=ROLLING_OBSERVATION, history=2, episode_s=0.5,
                     randomization=Randomization.standard())
    fast_env = TensegrityVectorEnv(3, config, autoreset_mode="same_step")
    assert fast_env.worlds._kernel is not None
    fast = _episode(fast_env)
    monkeypatch.setattr(_worlds, "kernel", lambda *args: None)
    slow_env = TensegrityVectorEnv(3, config, autoreset_mode="same_step")
    assert slow_env.worlds._kernel is None
    slow = _episode(slow_env)
    for a, b in zip(fast, slow, strict=True):
        if isinstance(a, np.ndarray) and a.dtype == object:
            a, b = [x for x in a if x is not None], [x for x in b if x is not None]
            assert len(a) == len(b)
            a, b = np.array(a), np.array(b)
        np.testing.assert_array_equal(a, b)


def test_a_copied_env_observes_its_own_robots(tmp_path):
    # the kernel points at the engine's arrays: a copy gets its own kernel, over its own
    path = tmp_path / "three_bar.yaml"
    path.write_text(three_bar())
    env = TensegrityVectorEnv(2, _config(path, observation=ROLLING_OBSERVATION))
    env.reset(seed=0)
    twin = copy.deepcopy(env)
    assert twin.worlds._kernel is not None and twin.worlds._kernel is not env.worlds._kernel
    action = np.full(env.action_space.shape, 0.5)
    env.step(-action)  # the original moves elsewhere
    obs = twin.step(action)[0]
    ids = np.arange(2, dtype=np.int32)
    np.testing.assert_array_equal(obs, twin.worlds.observe_numpy(ids))
    assert not np.array_equal(obs, env.worlds.observe_numpy(ids))


def test_terms_the_kernel_does_not_write_are_observed_with_numpy(tmp_path):
    path = tmp_path / "three_bar.yaml"
    path.write_text(three_bar())
    env = TensegrityVectorEnv(2, _config(path, observation=("height", "pose")))
    assert env.worlds._kernel is None
    env.reset(seed=0)  # (and still observes)
    assert env.step(np.zeros(env.action_space.shape))[0].shape == (2, 1 + 7 * 3)
