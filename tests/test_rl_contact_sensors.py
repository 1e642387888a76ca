"""The environments' ground contacts read for all robots at once from MuJoCo contact sensors
against a per-contact Python loop over each robot's contact list, and whole rolling episodes with
and without the sensors (tests/test_rl_fast_paths.py holds the other fast paths)."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

pytest.importorskip("gymnasium", reason="the rl extra (gymnasium) is not installed")

from tensim.rl import EnvConfig, Randomization, TensegrityVectorEnv, _contacts, _robot
from tensim.rl.train import TrainSettings
from tensim.sim import compiled_available

pytestmark = pytest.mark.skipif(not compiled_available(),
                                reason="the environments step on the compiled cable law")


def _rolling(episode_s: float = 0.6, **kw):
    """The roll task as `tensim rl train` trains the three_bar preset (2 ms implicitfast,
    heading frame, +-60 % rest lengths), in short episodes."""
    config = TrainSettings("three_bar", heading_deg=-30.0, rest_span=0.6).env_config(episode_s)
    return dataclasses.replace(config, **kw)


def _reference_contacts(env: TensegrityVectorEnv) -> tuple[np.ndarray, np.ndarray]:
    """Contact flags from each robot's whole MjData, one contact at a time: a rigid body
    touches the ground when a contact pairs one of its geoms with a world geom, and the end of
    that body's rod nearest the contact point is flagged."""
    w = env.worlds
    bodies = [int(b) for b in env.robot.compiled.index.body]
    end_body = w._end_body.tolist()
    touch = np.zeros((env.num_envs, len(bodies)))
    ends = np.zeros((env.num_envs, len(end_body)))
    for i in range(env.num_envs):
        m, d = w.models[i], w.data(i)
        for c in d.contact:
            pair = sorted(int(m.geom_bodyid[g]) for g in c.geom)
            if pair[0] != 0 or pair[1] not in bodies:
                continue
            touch[i, bodies.index(pair[1])] = 1.0
            best, nearest = math.inf, None
            for e, b in enumerate(end_body):
                if b != pair[1]:
                    continue
                end = d.xpos[b] + d.xmat[b].reshape(3, 3) @ w._end_local[e]
                if math.dist(end, c.pos) < best:
                    best, nearest = math.dist(end, c.pos), e
            if nearest is not None:
                ends[i, nearest] = 1.0
    return touch, ends


@pytest.mark.parametrize("model, slots", [("three_bar", _contacts.SLOTS), ("tetraspine3", 1)])
def test_contact_flags_from_the_sensors_equal_a_loop_over_each_contact(monkeypatch, model,
                                                                       slots):
    # tetraspine3 with one slot per sensor: its vertebrae stand on several feet, so a body's
    # contacts overflow its sensor, and that robot's flags come from its contact list instead
    monkeypatch.setattr(_contacts, "SLOTS", slots)
    config = _rolling(observation=("contact", "end_contact"))
    if model != "three_bar":
        config = EnvConfig(model=model, observation=("contact", "end_contact"))
    env = TensegrityVectorEnv(4, config)
    assert env.worlds._ground.ready
    n_bodies = len(env.robot.compiled.index.body)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    seen, changed, overflowed = set(), 0, 0
    for _ in range(40):
        obs = env.step(rng.uniform(-1, 1, env.action_space.shape))[0]
        touch, ends = _reference_contacts(env)
        np.testing.assert_array_equal(obs[:, :n_bodies], touch)
        np.testing.assert_array_equal(obs[:, n_bodies:], ends)
        key = tuple(ends.ravel())
        changed += key not in seen
        seen.add(key)
        found = env.worlds.f["sensordata"][:, env.worlds._ground.index[:, 0, 0]]
        overflowed += int((found > slots).any())
    assert changed > 3  # the robots move: end caps touch and leave the ground
    assert (overflowed > 0) == (slots == 1)  # the fallback ran where (and only where) asked


def _episode(config, seed: int = 3, n: int = 3, periods: int = 80) -> list:
    from tensim.rl.sb3 import SB3VecEnv

    env = SB3VecEnv(n, config)
    env.seed(seed)
    out = [env.reset()]
    rng = np.random.default_rng(seed)
    for _ in range(periods):
        out.append(env.step(rng.uniform(-1.2, 1.2, (n, 6)).astype(np.float32)))
    return out


def test_rolling_episodes_with_and_without_the_contact_sensors_are_the_same(monkeypatch):
    # the sensors change no force, and their flags equal the contact list's: observations,
    # rewards, ends and infos agree bit for bit, through episode ends and resets, with noise,
    # randomised physics, history and both cost terms
    config = _rolling(control_cost=0.5, bar_contact_cost=1.0, history=1,
                      randomization=Randomization.standard())
    fast = _episode(config)
    monkeypatch.setattr(_robot, "with_contact_sensors", lambda compiled: compiled)
    monkeypatch.setattr(_robot, "with_bar_sensors", lambda compiled: compiled)
    slow = _episode(config)
    assert len(fast) == len(slow)
    np.testing.assert_array_equal(fast[0], slow[0])
    ends = 0
    for (obs, reward, done, infos), (obs2, reward2, done2, infos2) in zip(
            fast[1:], slow[1:], strict=True):
        np.testing.assert_array_equal(obs, obs2)
        np.testing.assert_array_equal(reward, reward2)
        np.testing.assert_array_equal(done, done2)
        for a, b in zip(infos, infos2, strict=True):
            assert a.keys() == b.keys()
            for key in a:
                np.testing.assert_array_equal(a[key], b[key])
        ends += int(done.sum())
    assert ends >= 3  # every robot's 0.6 s episode ended at least once
    assert any(i["reward_control"] < 0 for step in fast[1:] for i in step[3])


def test_the_control_term_is_the_mean_squared_action_per_second():
    # the reward's control term, computed here with np.mean as docs/rl.md states it
    config = _rolling(control_cost=0.5, observation=("height",))
    env = TensegrityVectorEnv(2, config)
    env.reset(seed=0)
    actions = np.array([[0.5, -1.0, 0.25, 0.0, 1.0, -0.75], [2.0, 0.0, 0.0, 0.0, 0.0, 0.0]])
    info = env.step(actions)[4]
    applied = np.clip(actions, -1.0, 1.0)
    expected = -0.5 * np.mean(applied ** 2, axis=1) * config.control_dt
    np.testing.assert_array_equal(info["reward_control"], expected)
    np.testing.assert_array_equal(info["action_clipped"], [False, True])


def test_the_sensors_leave_the_model_as_it_was():
    # only sensor fields differ: the physics a policy was trained on is untouched
    env = TensegrityVectorEnv(1, _rolling())
    plain = TensegrityVectorEnv(1, _rolling(observation=("height", "velocity")))
    with_sensors, without = env.robot.model, plain.robot.model
    assert with_sensors.nsensor == without.nsensor + len(env.robot.compiled.index.body)
    for name in ("body_mass", "geom_size", "geom_friction", "tendon_stiffness",
                 "actuator_gainprm", "actuator_biasprm", "key_qpos", "key_act", "key_ctrl"):
        np.testing.assert_array_equal(getattr(with_sensors, name), getattr(without, name))
    assert with_sensors.opt.timestep == without.opt.timestep
    assert mujoco.mj_stateSize(with_sensors, mujoco.mjtState.mjSTATE_INTEGRATION) == \
        mujoco.mj_stateSize(without, mujoco.mjtState.mjSTATE_INTEGRATION)
    np.testing.assert_array_equal(env.robot.initial_state, plain.robot.initial_state)
