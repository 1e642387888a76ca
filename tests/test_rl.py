"""Gymnasium environments: the API contract (Gymnasium's checker, both autoreset modes,
wrappers, registration), determinism, the vector env equal to the single env and to a plain
Simulation loop, and rewards, actions and observations that mean what the docs say."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium", reason="the rl extra (gymnasium) is not installed")

from gymnasium.utils.env_checker import check_env  # noqa: E402
from gymnasium.vector import AutoresetMode  # noqa: E402

from tensim import InputError  # noqa: E402
from tensim.models import PRESETS, preset  # noqa: E402
from tensim.rl import (  # noqa: E402
    ENV_ID,
    EnvConfig,
    Randomization,
    TensegrityEnv,
    TensegrityVectorEnv,
)
from tensim.rl._robot import _Configure  # noqa: E402
from tensim.sim import MODE_IMPEDANCE, Simulation, compiled_available  # noqa: E402

pytestmark = pytest.mark.skipif(not compiled_available(),
                                reason="the environments step on the compiled cable law")

SHORT = EnvConfig(episode_s=0.3)  # 30 control periods
NOISY = dataclasses.replace(SHORT, randomization=Randomization.standard())


@pytest.mark.parametrize("config", [SHORT, NOISY, EnvConfig(model="six_bar", episode_s=0.1)],
                         ids=["tetraspine3", "randomized", "six_bar"])
def test_the_env_passes_gymnasiums_checker(config):
    check_env(TensegrityEnv(config), skip_render_check=True)


def test_the_default_action_of_a_passive_robot_is_rest_length():
    assert TensegrityEnv(EnvConfig(model="six_bar", episode_s=0.1)).robot.action == "rest_length"


def _rollout(env, seed, steps=12):
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(7)
    out = [obs]
    for _ in range(steps):
        out.append(env.step(rng.uniform(-1, 1, env.action_space.shape))[0])
    return np.array(out)


def test_the_same_seed_repeats_a_rollout_and_other_seeds_start_elsewhere():
    env = TensegrityEnv(NOISY)
    first, again = _rollout(env, 3), _rollout(env, 3)
    np.testing.assert_array_equal(first, again)
    other = _rollout(env, 4)
    assert not np.allclose(first[0], other[0])  # another start (pose noise, sensor noise)
    starts = {tuple(np.round(env.worlds.state(0)[1:4], 6))
              for _ in range(3) if env.reset() is not None}
    assert len(starts) == 3  # unseeded resets draw new starts


@pytest.mark.parametrize("mode", ["next_step", "same_step"])
def test_the_vector_env_steps_as_gymnasiums_sync_vector_env_of_single_envs(mode):
    """Gymnasium's reference vector env, stepping single envs one by one with the same seeds
    (seed + i) and autoreset mode, is the slow path the batch-engine vector env must equal."""
    config = dataclasses.replace(NOISY, episode_s=0.05, threads=2)  # 5-period episodes
    vector = TensegrityVectorEnv(3, config, autoreset_mode=mode)
    reference = gym.vector.SyncVectorEnv([lambda: TensegrityEnv(config)] * 3,
                                         autoreset_mode=AutoresetMode(vector.metadata[
                                             "autoreset_mode"]))
    np.testing.assert_array_equal(vector.reset(seed=10)[0], reference.reset(seed=10)[0])
    rng = np.random.default_rng(0)
    for k in range(13):  # two episodes and their resets; robot 1 restarts early once
        actions = rng.uniform(-1, 1, (3, 12))
        if k == 3:
            mask = np.array([False, True, False])
            np.testing.assert_array_equal(vector.reset(options={"reset_mask": mask})[0],
                                          reference.reset(options={"reset_mask": mask})[0])
        got, want = vector.step(actions), reference.step(actions)
        for a, b in zip(got[:4], want[:4], strict=True):
            np.testing.assert_array_equal(a, b)
        assert ("final_obs" in got[4]) == ("final_obs" in want[4])
        if "final_obs" in want[4]:
            np.testing.assert_array_equal(got[4]["_final_obs"], want[4]["_final_obs"])
            np.testing.assert_array_equal(got[4]["_final_info"], want[4]["_final_info"])
            for i in np.flatnonzero(want[4]["_final_obs"]):
                np.testing.assert_array_equal(got[4]["final_obs"][i], want[4]["final_obs"][i])


def test_the_env_steps_as_a_plain_simulation_loop():
    env = TensegrityEnv(EnvConfig(episode_s=1.0, randomization=Randomization()))  # build pose
    env.reset(seed=0)
    controller = _Configure(preset("tetraspine3").controller(), MODE_IMPEDANCE)
    rng = np.random.default_rng(1)
    with Simulation(env.robot.compiled, controller=controller) as sim:
        for _ in range(20):
            a = rng.uniform(-1, 1, 12)
            env.step(a)
            sim.drive.set_target_velocity(a * 0.07, 1e9)  # 0.07 m/s: Tetraspine3's motors
            sim.step(10)
        np.testing.assert_array_equal(env.worlds.state(0), sim.get_state())


def test_next_step_autoreset_ignores_the_action_after_an_episode_ends():
    # 5 periods, from the build pose (so a fresh start equals the seed's first)
    vector = TensegrityVectorEnv(2, EnvConfig(episode_s=0.05, randomization=Randomization()))
    assert vector.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    vector.reset(seed=0)
    for _ in range(5):
        obs, _, _, truncated, info = vector.step(np.ones((2, 12)))
    assert truncated.all() and "final_obs" not in info
    obs, reward, terminated, truncated, _ = vector.step(np.ones((2, 12)))
    np.testing.assert_array_equal(obs, vector.reset(seed=0)[0])  # the seed's next start: fresh
    assert not reward.any() and not terminated.any() and not truncated.any()


def test_same_step_autoreset_returns_the_final_obs_with_its_masks():
    vector = TensegrityVectorEnv(2, EnvConfig(episode_s=0.05), autoreset_mode="same_step")
    assert vector.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    vector.reset(seed=0)
    last = None
    for k in range(5):
        obs, _, _, truncated, info = vector.step(np.ones((2, 12)))
        if k < 4:
            assert "final_obs" not in info
            last = obs
    assert truncated.all()
    np.testing.assert_array_equal(info["_final_obs"], [True, True])
    np.testing.assert_array_equal(info["_final_info"], [True, True])
    assert info["final_obs"].dtype == object and info["final_obs"][0].shape == obs[0].shape
    assert not np.array_equal(info["final_obs"][0], last[0])  # one period after `last`
    assert "reward_progress" in info["final_info"]
    np.testing.assert_array_equal(vector.worlds.steps, [0, 0])  # both already restarted


def test_reset_mask_resets_only_the_masked_robots():
    vector = TensegrityVectorEnv(2, SHORT)
    start, _ = vector.reset(seed=0)
    stepped = vector.step(np.ones((2, 12)))[0]
    obs, _ = vector.reset(seed=0, options={"reset_mask": np.array([False, True])})
    np.testing.assert_array_equal(vector.worlds.steps, [1, 0])
    np.testing.assert_array_equal(obs[0], stepped[0])  # robot 0 goes on
    np.testing.assert_array_equal(obs[1], start[1])  # robot 1 starts again from seed 0 + 1
    with pytest.raises(InputError, match="reset_mask"):
        vector.reset(options={"reset_mask": np.array([1, 0])})


def test_gymnasiums_observation_wrappers_and_episode_statistics_run_on_the_default_mode():
    from gymnasium.wrappers.vector import (
        NormalizeObservation,
        RecordEpisodeStatistics,
        TransformObservation,
    )

    vector = TensegrityVectorEnv(2, EnvConfig(episode_s=0.05))  # next-step: what they require
    env = RecordEpisodeStatistics(NormalizeObservation(TransformObservation(
        vector, lambda o: 2.0 * o, vector.observation_space)))
    env.reset(seed=0)
    for _ in range(7):
        obs, *_ = env.step(np.zeros((2, 12)))
    assert np.isfinite(obs).all() and abs(obs.mean()) < 5  # normalised
    assert len(env.return_queue) == 2  # one finished episode per robot
    with pytest.raises(ValueError, match="NEXT_STEP or DISABLED"):  # Gymnasium's own rule
        NormalizeObservation(TensegrityVectorEnv(2, SHORT, autoreset_mode="same_step"))


def test_gym_make_and_make_vec_build_the_registered_envs():
    env = gym.make(ENV_ID, config=SHORT)
    assert env.spec.id == ENV_ID and env.reset(seed=0)[0].shape == env.observation_space.shape
    vec = gym.make_vec(ENV_ID, num_envs=3, vectorization_mode="vector_entry_point", config=SHORT)
    assert isinstance(vec.unwrapped, TensegrityVectorEnv) and vec.num_envs == 3
    vec.close()
    env.close()


def test_the_return_is_the_distance_walked_along_the_direction():
    env = TensegrityEnv(EnvConfig(episode_s=1.0, direction=(1.0, 1.0),
                                  randomization=Randomization()))  # the world frame's heading
    env.reset(seed=0)
    start = env.worlds.f["subtree_com"][0, 0, :2].copy()
    total, rng = 0.0, np.random.default_rng(1)
    for _ in range(100):
        total += env.step(rng.uniform(-1, 1, env.action_space.shape))[1]
    moved = env.worlds.f["subtree_com"][0, 0, :2] - start
    assert abs(total) > 1e-5
    assert total == pytest.approx(moved @ np.array([1.0, 1.0]) / np.sqrt(2.0), rel=1e-9)


def test_rest_length_actions_command_the_motors():
    env = TensegrityEnv(EnvConfig(action="rest_length", episode_s=1.0))
    rest = slice(*env.robot.layout["rest_length"])
    obs, _ = env.reset(seed=0)
    action = np.zeros(12)
    action[0] = -0.05  # cable 0 to 1 - 0.05 x 0.2 of its build rest length, the others held
    for _ in range(30):  # 0.3 s at the motors' 0.07 m/s covers well over the change
        obs = env.step(action)[0]
    target = env.robot.rest0 * (1 + action * 0.2)
    np.testing.assert_allclose(obs[rest], target, atol=1e-12)


def test_body_frame_observations_do_not_depend_on_the_start_heading():
    config = dataclasses.replace(SHORT, randomization=Randomization(yaw=True))
    env = TensegrityEnv(config)
    a, _ = env.reset(seed=1)
    com_a = env.worlds.f["subtree_com"][0, 0].copy()
    target_a = env.worlds.target[0].copy()
    b, _ = env.reset(seed=2)
    com_b = env.worlds.f["subtree_com"][0, 0].copy()
    np.testing.assert_allclose(a, b, atol=1e-9)  # only round-off of the turned state
    np.testing.assert_allclose(com_a, com_b, atol=1e-12)  # turned about its centre of mass
    # the rewarded direction turns with the robot (it is given in the robot's start frame)
    assert not np.allclose(target_a, env.worlds.target[0])
    np.testing.assert_allclose(np.hypot(*env.worlds.target[0]), 1.0)


def test_physics_randomization_draws_each_robots_model_within_its_ranges():
    config = dataclasses.replace(SHORT, randomization=Randomization(stiffness=(0.5, 2.0)))
    vector = TensegrityVectorEnv(4, config)
    vector.reset(seed=0)
    k0 = vector.robot.compiled.law().stiffness  # the compiled (nominal) model's
    ratios = np.array([m.actuator_gainprm[:12, 1] / k0 for m in vector.worlds.models])
    assert np.all((ratios >= 0.5) & (ratios <= 2.0))
    np.testing.assert_allclose(ratios, ratios[:, :1] * np.ones((1, 12)))  # one draw per robot
    assert len(np.unique(ratios[:, 0])) == 4


def test_an_action_delay_holds_the_first_action_back_one_period():
    def state_after(delay, first):
        config = dataclasses.replace(SHORT, randomization=Randomization(action_delay=delay))
        env = TensegrityEnv(config)
        env.reset(seed=0)
        env.step(first)
        return env.worlds.state(0)

    zero, push = np.zeros(12), np.ones(12)
    np.testing.assert_array_equal(state_after(1, push), state_after(0, zero))
    assert not np.array_equal(state_after(0, push), state_after(0, zero))


def test_the_previous_action_and_clipping_are_reported():
    env = TensegrityEnv(SHORT)
    obs, _ = env.reset(seed=0)
    obs, _, _, _, info = env.step(np.full(12, 1.5))
    prev = slice(*env.robot.layout["previous_action"])
    np.testing.assert_array_equal(obs[prev], np.ones(12))
    assert info["action_clipped"]
    strict = TensegrityEnv(dataclasses.replace(SHORT, clip_actions=False))
    strict.reset(seed=0)
    with pytest.raises(InputError, match="outside the box"):
        strict.step(np.full(12, 1.5))


def test_stepping_before_the_first_reset_is_refused():
    with pytest.raises(gym.error.ResetNeeded):
        TensegrityEnv(SHORT).step(np.zeros(12))
    with pytest.raises(gym.error.ResetNeeded):
        TensegrityVectorEnv(2, SHORT).step(np.zeros((2, 12)))


@pytest.mark.parametrize("action", ["vstar", "rest_length"])
def test_nan_actions_are_refused(action):
    env = TensegrityEnv(dataclasses.replace(SHORT, action=action))
    env.reset(seed=0)
    with pytest.raises(InputError, match="NaN"):
        env.step(np.full(12, np.nan))
    vector = TensegrityVectorEnv(2, dataclasses.replace(SHORT, action=action))
    vector.reset(seed=0)
    actions = np.zeros((2, 12))
    actions[1, 3] = np.nan
    with pytest.raises(InputError, match="robot 1"):
        vector.step(actions)


@pytest.mark.parametrize(("change", "message"), [
    ({"direction": (float("inf"), 0.0)}, "direction"),
    ({"direction": (0.0, 0.0)}, "direction"),
    ({"goal_m": (float("nan"), 1.0)}, "goal_m"),
    ({"action": "torque"}, "action"),
    ({"observation": ("pose", "colour")}, "observation"),
    ({"control_dt": 0.0105}, "control_dt"),
    ({"model": "six_bar", "action": "vstar"}, "no impedance controller"),
    ({"model": "no_such_robot"}, "neither a preset"),
])
def test_bad_configurations_are_refused(change, message):
    with pytest.raises(InputError, match=message):
        TensegrityEnv(dataclasses.replace(SHORT, **change))


@pytest.mark.parametrize("model", sorted(set(PRESETS) - {"tetraspine"}))  # 66 cables: slow
def test_every_preset_steps_with_its_default_action(model):
    env = TensegrityEnv(EnvConfig(model=model, episode_s=0.03))
    obs, _ = env.reset(seed=0)
    assert env.robot.action == ("vstar" if preset(model).controller() else "rest_length")
    for _ in range(3):
        obs, reward, terminated, *_ = env.step(env.action_space.sample())
    assert env.observation_space.contains(obs) and np.isfinite(reward) and not terminated


def test_a_structure_file_is_a_model_and_one_whose_cables_cannot_move_is_refused(tmp_path):
    from tensim.structure import save_structure

    save_structure(preset("prism3").build(), tmp_path / "prism.yaml")
    env = TensegrityEnv(EnvConfig(model=str(tmp_path / "prism.yaml"), episode_s=0.03))
    assert env.reset(seed=0)[0].shape == TensegrityEnv(
        EnvConfig(model="prism3")).observation_space.shape

    frozen = dataclasses.replace(preset("prism3").build(), cables=())  # rods alone
    path = tmp_path / "frozen.yaml"
    save_structure(frozen, path)
    with pytest.raises(InputError, match="has no motorised cable"):
        TensegrityEnv(EnvConfig(model=str(path)))


def test_a_structure_file_is_driven_by_the_laws_that_hold_its_build_pose(tmp_path):
    from tensim.control import default_impedance
    from tensim.sim import CableDrive
    from tensim.structure import save_structure

    # prism3 as a preset has no controller (rest-length actions); as a file it gets
    # default_impedance: T0 = build pretension, L* = build length, K = k, B = 0.2 s x K
    structure = preset("prism3").build()
    save_structure(structure, tmp_path / "prism.yaml")
    env = TensegrityEnv(EnvConfig(model=str(tmp_path / "prism.yaml"), episode_s=0.03))
    assert env.robot.action == "vstar"
    drive = CableDrive(env.robot.compiled, env.robot.model)
    laws = default_impedance(structure).gains
    names = env.robot.compiled.index.cables
    for field, got in (("offset_tension", drive.offset_tension), ("stiffness_gain", drive.gain_k),
                       ("damping_gain", drive.gain_b), ("target_length", drive.target_length)):
        want = [getattr(laws[name], field) for name in names]
        np.testing.assert_allclose(got, want, rtol=1e-12, err_msg=field)


def test_goal_and_hold_tasks_reward_what_they_say():
    goal = TensegrityEnv(dataclasses.replace(SHORT, task="goal", goal_m=(0.0, 0.5)))
    obs, _ = goal.reset(seed=0)
    task = slice(*goal.robot.layout["task"])
    assert np.hypot(*obs[task]) == pytest.approx(0.5, abs=1e-12)  # the goal, 0.5 m away
    before = np.hypot(*obs[task])
    obs, reward, *_ = goal.step(np.ones(12))
    assert reward == pytest.approx(before - np.hypot(*obs[task]), abs=1e-12)
    hold = TensegrityEnv(dataclasses.replace(SHORT, task="hold"))
    hold.reset(seed=0)
    rewards = [hold.step(np.ones(12))[1] for _ in range(10)]
    assert max(rewards) <= 0 and min(rewards) < 0  # moving away from the start shape costs


def test_observed_velocities_are_mujocos_in_the_robot_frame():
    import mujoco

    env = TensegrityEnv(dataclasses.replace(SHORT, observation=("velocity",)))
    env.reset(seed=0)
    for _ in range(5):
        obs = env.step(np.ones(12))[0]  # moving: every velocity non-zero
    m, d = env.robot.model, env.worlds.data(0)
    mujoco.mj_forward(m, d)
    mujoco.mj_subtreeVel(m, d)
    bodies = env.robot.compiled.index.body
    ahead = d.xipos[bodies[0], :2] - d.subtree_com[0, :2]
    c, s = ahead / np.hypot(*ahead)
    frame = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # world -> robot frame
    expected = [frame @ d.subtree_linvel[0]]  # the whole robot's centre of mass
    velocity = np.zeros((len(bodies), 6))
    for row, b in enumerate(bodies):
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, b, velocity[row], 0)
    expected += [frame @ v for v in velocity[:, 3:]] + [frame @ w for w in velocity[:, :3]]
    assert np.abs(obs[:3]).max() > 1e-4
    np.testing.assert_allclose(obs, np.concatenate(expected), atol=1e-12)
