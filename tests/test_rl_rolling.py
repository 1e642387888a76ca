"""Environments, training, evaluation and export for a rolling robot: a 3-bar written here
(rods 1.4 m, 4 kg; 6 motorised cables and 3 passive ones)."""

from __future__ import annotations

import copy
import dataclasses
import pickle

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium", reason="the rl extra (gymnasium) is not installed")

from tensim import InputError  # noqa: E402
from tensim.rl import ENV_ID, EnvConfig, Randomization, TensegrityEnv, TensegrityVectorEnv  # noqa: E402
from tensim.sim import compiled_available, load_cell_tension  # noqa: E402

pytestmark = pytest.mark.skipif(not compiled_available(),
                                reason="the environments step on the compiled cable law")

SCALE = 2.86  # the prism of examples/tensegrity_prism.yaml (0.49 m rods) scaled to 1.4 m rods
BOTTOM = [(0.2, 0.0), (-0.1, 0.173205), (-0.1, -0.173205)]
TOP = [(-0.173205, 0.1), (0.0, -0.2), (0.173205, 0.1)]


def three_bar(motor_top_bottom: bool = True) -> str:
    """The 3-bar's structure YAML: stiff cables, the triangles motorised, the verticals not."""
    nodes = [f"  - {{name: b{i}, position: [{x * SCALE:.6f}, {y * SCALE:.6f}, 0.05]}}"
             for i, (x, y) in enumerate(BOTTOM)]
    nodes += [f"  - {{name: t{i}, position: [{x * SCALE:.6f}, {y * SCALE:.6f}, "
              f"{0.3 * SCALE + 0.05:.6f}]}}" for i, (x, y) in enumerate(TOP)]
    motor = "motor: {max_speed: 0.2, max_tension: 2000.0, min_rest_length: 0.1, min_length: 0.1}"
    moving = f", {motor}" if motor_top_bottom else ""
    cables = [f"  - {{name: bottom_{i}, nodes: [b{i}, b{(i + 1) % 3}], pretension: 120{moving}}}"
              for i in range(3)]
    cables += [f"  - {{name: top_{i}, nodes: [t{i}, t{(i + 1) % 3}], pretension: 120{moving}}}"
               for i in range(3)]
    cables += [f"  - {{name: vertical_{i}, nodes: [b{i}, t{(i + 2) % 3}], pretension: 190}}"
               for i in range(3)]
    return "\n".join([
        "name: three_bar_test",
        "defaults:",
        "  rod: {radius: 0.02, linear_density: 2.857, friction: 0.8}",  # 4 kg rods
        "  cable: {stiffness: 3000.0, damping: 20.0}",
        "nodes:", *nodes,
        "rods:", *[f"  - {{name: rod_{i}, nodes: [b{i}, t{i}]}}" for i in range(3)],
        "cables:", *cables, ""])


@pytest.fixture(scope="module")
def robot_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("robot") / "three_bar.yaml"
    path.write_text(three_bar())
    return str(path)


def _config(robot_file, **kw):
    return EnvConfig(model=robot_file, control_dt=0.02, episode_s=0.4, **kw)


def test_the_action_space_holds_the_motorised_cables_only(robot_file):
    env = TensegrityEnv(_config(robot_file, randomization=Randomization()))
    assert env.action_space.shape == (6,)
    assert env.robot.cables == tuple(f"{k}_{i}" for k in ("bottom", "top") for i in range(3))
    env.reset(seed=0)
    rest0 = env.robot.compiled.index.cable_act(env.worlds.f["act"][0]).copy()
    for _ in range(5):
        env.step(np.ones(6, dtype=np.float32))
    rest = env.robot.compiled.index.cable_act(env.worlds.f["act"][0])
    passive = [env.robot.compiled.index.cable_id(f"vertical_{i}") for i in range(3)]
    np.testing.assert_array_equal(rest[passive], rest0[passive])  # no motor: never moves
    assert np.all(np.abs(rest[env.robot.motors] - rest0[env.robot.motors]) > 1e-3)


def test_a_robot_without_motors_is_refused(tmp_path):
    path = tmp_path / "passive.yaml"
    path.write_text(three_bar(motor_top_bottom=False))
    with pytest.raises(InputError, match="has no motorised cable"):
        TensegrityEnv(EnvConfig(model=str(path)))


def test_seeds_differ_by_default_and_one_seed_repeats_its_episode(robot_file):
    env = TensegrityEnv(_config(robot_file))
    assert env.robot.config.randomization == Randomization.start()

    def episode(seed):
        obs, _ = env.reset(seed=seed)
        start = env.worlds.state(0)
        rng = np.random.default_rng(5)
        out = [obs] + [env.step(rng.uniform(-1, 1, 6).astype(np.float32))[0] for _ in range(8)]
        return start, np.array(out)

    (s1, e1), (s1b, e1b), (s2, _) = episode(1), episode(1), episode(2)
    np.testing.assert_array_equal(s1, s1b)
    np.testing.assert_array_equal(e1, e1b)
    assert np.abs(s1 - s2).max() > 1e-3  # another heading and pose noise
    assert gym.spec(ENV_ID).max_episode_steps == EnvConfig().max_steps


def _stepped_with_stiffness_doubled(robot_file):
    """An env whose stiffness is drawn x2 exactly, and its observation (cable length, rest
    length, tension) after three zero-action steps."""
    config = _config(robot_file, randomization=Randomization(stiffness=(2.0, 2.0)),
                     observation=("cable_length", "rest_length", "tension"))
    env = TensegrityEnv(config)
    env.reset(seed=0)
    for _ in range(3):
        obs = env.step(np.zeros(6, dtype=np.float32))[0]
    return env, obs


def test_observed_tensions_use_each_robots_randomised_stiffness(robot_file):
    # stiffness drawn x2 exactly: the load cells must read 2 k max(0, x - l) with k the file's
    env, obs = _stepped_with_stiffness_doubled(robot_file)
    n = env.robot.n
    length, rest, tension = obs[:n], obs[n:2 * n], obs[2 * n:]
    k = np.array([3000.0] * n)  # the structure file's stiffness [N/m]
    want = np.where(length > rest, 2.0 * k * (length - rest), 0.0)
    assert want.min() > 10.0  # every cable taut: the check sees the stiffness
    np.testing.assert_allclose(tension, want, rtol=1e-12)
    np.testing.assert_allclose(tension, load_cell_tension(length, rest, 2.0 * k), rtol=1e-12)


def test_observed_tensions_include_a_pd_motors_pull(tmp_path):
    """Triangle cables with a PD motor (Motor.pd_stiffness): the actions are the servos'
    targets (around their build length), and the load cell reads the spring's k max(0, x - l)
    plus the servo's min(max(0, kp (x - L)), max_tension), L the command; V* actions, which
    would replace the servos by the impedance law, are refused."""
    path = tmp_path / "servo.yaml"
    path.write_text(three_bar().replace("min_length: 0.1}", "min_length: 0.1, "
                                        "pd_stiffness: 800.0}"))
    config = _config(str(path), randomization=Randomization(),
                     observation=("cable_length", "rest_length", "tension"))
    env = TensegrityEnv(config)
    env.reset(seed=0)
    for _ in range(3):
        obs = env.step(np.full(6, -1.0, dtype=np.float32))[0]  # pull the servos in
    n = env.robot.n
    length, rest, tension = obs[:n], obs[n:2 * n], obs[2 * n:]
    target = env.worlds.f["ctrl"][0, :n]
    servo = np.clip(800.0 * (length - target), 0.0, 2000.0)
    servo[6:] = 0.0  # the verticals have no motor
    assert servo.max() > 10.0  # the servos pull: the check sees them
    np.testing.assert_allclose(target[:6], env.robot.low)  # the action -1: the box's floor
    np.testing.assert_allclose(tension, load_cell_tension(length, rest, 3000.0) + servo,
                               rtol=1e-12, atol=1e-9)
    with pytest.raises(InputError, match="cable 'bottom_0' has a PD motor"):
        TensegrityEnv(_config(str(path), action="vstar"))


def test_rod_axes_and_end_caps_on_the_ground_match_the_build_pose(robot_file):
    config = _config(robot_file, randomization=Randomization(),
                     observation=("rod_axis", "end_contact"))
    env = TensegrityEnv(config)
    env.reset(seed=0)
    for _ in range(15):  # 0.3 s: the robot has fallen the 3 cm onto its bottom ends
        obs = env.step(np.zeros(6, dtype=np.float32))[0]
    axes = obs[:9].reshape(3, 3)
    np.testing.assert_allclose(np.linalg.norm(axes, axis=1), 1.0, rtol=1e-12)
    rod = np.array([TOP[0][0] - BOTTOM[0][0], TOP[0][1] - BOTTOM[0][1], 0.3]) * SCALE
    assert axes[:, 2] == pytest.approx(rod[2] / np.linalg.norm(rod), abs=0.02)  # settled
    np.testing.assert_array_equal(obs[9:], [1, 0, 1, 0, 1, 0])  # the bottom ends touch


def test_heading_frame_observations_are_world_vectors_turned_onto_the_heading(robot_file):
    # x along the rewarded heading, whichever way the robot lies or tumbles: the task reads
    # (1, 0) and the centre of mass's velocity is MuJoCo's, turned by the heading's angle
    config = _config(robot_file, frame="heading", direction=(1.0, 1.0),
                     observation=("velocity", "rod_axis", "task"))
    env = TensegrityEnv(config)
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(10):
        obs = env.step(rng.uniform(-1, 1, 6).astype(np.float32))[0]
    h = env.worlds.target[0]
    np.testing.assert_allclose(np.hypot(*h), 1.0, rtol=1e-12)
    layout, w = env.robot.layout, env.worlds
    np.testing.assert_allclose(obs[slice(*layout["task"])], [1.0, 0.0], atol=1e-12)
    model, data, bodies = w.models[0], w.data(0), env.robot.compiled.index.body
    mass = model.body_mass[bodies]
    velocity = np.array([_body_velocity(model, data, b) for b in bodies])
    com_velocity = mass @ velocity / mass.sum()
    side = np.array([-h[1], h[0]])
    got = obs[slice(*layout["velocity"])][:3]
    assert np.hypot(*com_velocity[:2]) > 1e-3  # it moves: the check sees the turn
    np.testing.assert_allclose(got, [com_velocity[:2] @ h, com_velocity[:2] @ side,
                                     com_velocity[2]], atol=1e-9)
    # the same start turned about the vertical: the same observation in the heading frame
    quiet = TensegrityEnv(dataclasses.replace(config, randomization=Randomization(yaw=True)))
    a, _ = quiet.reset(seed=1)
    b, _ = quiet.reset(seed=2)
    np.testing.assert_allclose(a, b, atol=1e-9)  # only round-off of the turned state


def _body_velocity(model, data, body):
    """A body's centre-of-mass velocity in the world [m/s], from MuJoCo's own function."""
    import mujoco

    out = np.zeros(6)  # (angular, linear) at the body's centre of mass, world frame
    mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, body, out, 0)
    return out[3:]


def test_a_live_env_survives_pickle_and_deepcopy(robot_file):
    env = TensegrityEnv(_config(robot_file, randomization=Randomization.standard(), history=2))
    env.reset(seed=3)
    for _ in range(3):
        env.step(np.full(6, 0.5, dtype=np.float32))
    for make in (lambda e: pickle.loads(pickle.dumps(e)), copy.deepcopy):
        twin = make(env)
        a = np.linspace(-1, 1, 6).astype(np.float32)
        out, out_twin = env.step(a), twin.step(a)
        np.testing.assert_array_equal(out[0], out_twin[0])
        assert out[1] == out_twin[1]
        env = twin


def test_disabled_autoreset_waits_for_a_masked_reset(robot_file):
    vector = TensegrityVectorEnv(2, dataclasses.replace(_config(robot_file), episode_s=0.04),
                                 autoreset_mode="disabled")
    vector.reset(seed=0)
    vector.step(np.zeros((2, 6)))
    truncated = vector.step(np.zeros((2, 6)))[3]
    assert truncated.all()
    with pytest.raises(gym.error.ResetNeeded, match="reset_mask"):
        vector.step(np.zeros((2, 6)))
    vector.reset(options={"reset_mask": np.array([True, True])})
    assert not vector.step(np.zeros((2, 6)))[3].any()


def test_sb3_infos_carry_the_reward_terms(robot_file):
    pytest.importorskip("stable_baselines3")
    from tensim.rl.sb3 import SB3VecEnv

    venv = SB3VecEnv(2, _config(robot_file, control_cost=0.5, bar_contact_cost=1.0))
    venv.reset()
    _, reward, _, infos = venv.step(np.full((2, 6), 0.8))
    for r, info in zip(reward, infos, strict=True):
        total = info["reward_progress"] + info["reward_control"] + info["reward_contact"]
        assert r == pytest.approx(total, rel=1e-6)
        assert info["reward_control"] == pytest.approx(-0.5 * 0.64 * 0.02, rel=1e-6)


def test_the_turn_task_rewards_the_angle_turned_about_the_vertical():
    from tensim.sim.motion import yaw_change

    rng = np.random.default_rng(0)
    before = rng.normal(size=(1, 6, 3))
    c, s = np.cos(0.3), np.sin(0.3)
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    after = before @ turn.T + [2.0, -1.0, 0.5]  # each point turned +0.3 rad, and moved
    assert yaw_change(before, after)[0] == pytest.approx(0.3, abs=1e-12)
    assert yaw_change(after, before)[0] == pytest.approx(-0.3, abs=1e-12)


def test_a_wobble_that_circles_the_points_without_turning_the_body_is_little_turn():
    # a rigid body tilted by theta toward an azimuth phi that goes round once, without spin,
    # R(phi) = Rz(phi) Rx(theta) Rz(-phi): its top circles the centre through 2 pi, but its
    # angular velocity about the vertical is phi' (1 - cos theta), so it turns by
    # 2 pi (1 - cos theta) about the vertical
    from tensim.sim.motion import yaw_change

    def rz(a):
        return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0],
                         [0.0, 0.0, 1.0]])

    theta = 0.3
    rx = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(theta), -np.sin(theta)],
                   [0.0, np.sin(theta), np.cos(theta)]])
    body = np.random.default_rng(1).normal(size=(6, 3))
    body[0] = [0.0, 0.0, 1.0]  # a point on the axis: its top
    phases = np.linspace(0.0, 2 * np.pi, 401)
    points = np.stack([body @ (rz(f) @ rx @ rz(-f)).T for f in phases])
    circled = np.unwrap(np.arctan2(points[:, 0, 1], points[:, 0, 0]))
    assert circled[-1] - circled[0] == pytest.approx(2 * np.pi)  # the top circles once
    turned = yaw_change(points[:-1], points[1:]).sum()
    assert turned == pytest.approx(2 * np.pi * (1 - np.cos(theta)), rel=1e-3)


def _train(robot_file, out, algo, steps):
    from tensim.cli import main

    return main(["--quiet", "rl", "train", robot_file, "--algo", algo, "--steps", str(steps),
                 "--envs", "2", "--checkpoint", str(steps // 2), "--episode", "1",
                 "--out", str(out)])


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_rl_train_evaluate_and_export_end_to_end(robot_file, tmp_path, algo, capsys):
    pytest.importorskip("stable_baselines3")
    import json

    from tensim.cli import main

    out = tmp_path / algo
    assert _train(robot_file, out, algo, 512 if algo == "ppo" else 100) == 0  # seconds
    progress = json.loads((out / "progress.json").read_text())
    assert progress["steps_done"] == (512 if algo == "ppo" else 100)  # never past --steps
    assert (out / "learning_curve.png").is_file() and (out / "robot.yaml").is_file()
    assert _train(robot_file, out, algo, 1024) == 2  # no silent restart over a run
    assert "add --resume" in capsys.readouterr().err
    budget = 1024 if algo == "ppo" else 200
    assert main(["--quiet", "rl", "train", robot_file, "--algo", algo, "--steps", str(budget),
                 "--envs", "2", "--episode", "1", "--out", str(out), "--resume"]) == 0
    resumed = json.loads((out / "progress.json").read_text())
    assert resumed["steps_done"] == budget and len(resumed["curve"]) >= len(progress["curve"])
    assert json.loads((out / "settings.json").read_text())["steps"] == budget  # trained to
    assert main(["--quiet", "rl", "evaluate", str(out), "--duration", "0.4"]) == 0
    summary = json.loads((out / "evaluation" / "summary.json").read_text())
    assert summary["body_length_m"] == pytest.approx(1.4, abs=0.01)  # the longest rod
    speed = summary["displacement_along_heading_m"] / summary["duration_s"] / 1.399
    assert summary["body_lengths_per_s"] == pytest.approx(speed, abs=2e-6)  # 6 digits kept
    assert main(["--quiet", "rl", "export", str(out), "--onnx",
                 str(tmp_path / "robot" / "policy.onnx")]) == 0
    # the exported policy (with the robot file beside it) drives the robot as the run did
    assert main(["--quiet", "rl", "evaluate", str(tmp_path / "robot" / "policy.json"),
                 "--duration", "0.4", "--out", str(tmp_path / "exported")]) == 0
    again = json.loads((tmp_path / "exported" / "summary.json").read_text())
    assert again["displacement_along_heading_m"] == summary["displacement_along_heading_m"]
    assert again["training"] == {"env_steps": budget, "cpu_s": pytest.approx(
        resumed["cpu_s"], abs=0.06)}
    exported = json.loads((tmp_path / "robot" / "policy.json").read_text())
    assert exported["settings"]["steps"] == budget  # the resumed run's, not its first --steps
    # and on other physics than it was trained on: the step and law asked for are used
    assert main(["--quiet", "rl", "evaluate", str(tmp_path / "robot" / "policy.json"),
                 "--duration", "0.4", "--dt", "0.001", "--cable-law", "explicit",
                 "--out", str(tmp_path / "other")]) == 0
    other = json.loads((tmp_path / "other" / "summary.json").read_text())
    assert (other["timestep_s"], other["cable_law"]) == (0.001, "explicit")
    assert other["trained_physics"] == {"timestep": 0.002, "cable_law": "implicitfast"}
    assert other["displacement_along_heading_m"] != again["displacement_along_heading_m"]
    # and with physics multipliers it was not trained on (friction, mass ...)
    assert main(["--quiet", "rl", "evaluate", str(tmp_path / "robot" / "policy.json"),
                 "--duration", "0.4", "--friction", "0.5", "--mass", "1.3",
                 "--out", str(tmp_path / "heavier")]) == 0
    heavier = json.loads((tmp_path / "heavier" / "summary.json").read_text())
    assert heavier["physics"] == {"friction": 0.5, "mass": 1.3}
    assert heavier["displacement_along_heading_m"] != again["displacement_along_heading_m"]


def test_evaluation_physics_are_fixed_multipliers_on_the_training_start():
    from tensim import InputError
    from tensim.rl import Randomization
    from tensim.rl.evaluate import evaluation_randomization

    start = Randomization.start()
    assert evaluation_randomization() == start
    fixed = evaluation_randomization({"friction": 0.5, "motor_speed": 0.6})
    assert (fixed.friction, fixed.motor_speed, fixed.mass) == ((0.5, 0.5), (0.6, 0.6),
                                                                (1.0, 1.0))
    assert (fixed.yaw, fixed.pose_noise_m, fixed.velocity_noise) == (True, 0.002, 0.0)
    with pytest.raises(InputError, match="unknown gravity"):
        evaluation_randomization({"gravity": 2.0})


def test_training_randomisation_is_a_setting_that_keeps_old_fingerprints():
    import dataclasses
    import hashlib
    import json

    from tensim import InputError
    from tensim.rl import Randomization
    from tensim.rl.train import TrainSettings, fingerprint

    plain = TrainSettings(model="three_bar")
    assert plain.env_config().randomization == Randomization.start()
    standard = dataclasses.replace(plain, randomization="standard")
    assert standard.env_config().randomization == Randomization.standard()
    # a run trained before the setting existed hashed its settings without it
    record = dataclasses.asdict(plain) | {"steps": 0}
    later = ("randomization", "roll_reward", "slip_cost", "rollout_steps", "action")  # default
    for name in later:
        del record[name]
    old = hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest()[:16]
    assert fingerprint(plain) == old != fingerprint(standard)
    with pytest.raises(InputError, match="--randomize must be one of start, standard"):
        TrainSettings(model="three_bar", randomization="wild")


def test_ppo_takes_its_rollout_size_per_update_from_rollout_steps(robot_file, tmp_path,
                                                                   capsys):
    pytest.importorskip("stable_baselines3")
    import json

    from tensim.cli import main
    from tensim.rl.export import load_learner
    from tensim.rl.train import TrainSettings, fingerprint

    def train(out, *extra):
        return main(["--quiet", "rl", "train", robot_file, "--envs", "2", "--episode", "1",
                     "--out", str(tmp_path / out), *extra])

    # 96 env steps per update for the 2 robots: 48 each, minibatches of 24; two updates
    assert train("big", "--steps", "200", "--checkpoint", "96", "--rollout-steps", "96") == 0
    learner = load_learner(tmp_path / "big")
    assert (learner.n_steps * learner.n_envs, learner.batch_size) == (96, 24)
    assert json.loads((tmp_path / "big" / "progress.json").read_text())["steps_done"] == 192
    assert json.loads((tmp_path / "big" / "settings.json").read_text())["rollout_steps"] == 96
    # a resume keeps it: another size is another run
    assert train("big", "--steps", "288", "--resume", "--rollout-steps", "64") == 2
    assert "changed: rollout_steps" in capsys.readouterr().err
    assert train("big", "--steps", "288", "--resume", "--rollout-steps", "96") == 0
    assert load_learner(tmp_path / "big").num_timesteps == 288
    # an odd size rounds down to whole steps per robot
    assert train("odd", "--steps", "64", "--rollout-steps", "33") == 0
    assert load_learner(tmp_path / "odd").n_steps == 16
    # only PPO has a rollout, of at least 16 steps per robot
    assert train("sac", "--algo", "sac", "--steps", "64", "--rollout-steps", "96") == 2
    assert "--rollout-steps 96: PPO's rollout; --algo sac has none" in capsys.readouterr().err
    assert train("short", "--steps", "64", "--rollout-steps", "31") == 2
    assert "--rollout-steps must be at least 16 per robot (32 with --envs 2), got 31" in \
        capsys.readouterr().err
    assert fingerprint(TrainSettings(model="three_bar", rollout_steps=4096)) == \
        fingerprint(TrainSettings(model="three_bar")) != \
        fingerprint(TrainSettings(model="three_bar", rollout_steps=8192))


@pytest.fixture(scope="module")
def trained(robot_file, tmp_path_factory):
    pytest.importorskip("stable_baselines3")
    out = tmp_path_factory.mktemp("run") / "sac"
    assert _train(robot_file, out, "sac", 200) == 0
    return out


def test_the_exported_policy_acts_as_the_trained_one(trained, tmp_path):
    from tensim.rl import policy as numpy_policy
    from tensim.rl.evaluate import run_policy
    from tensim.rl.export import export, load_learner
    from tensim.rl.train import load_settings

    export(trained, tmp_path / "policy.onnx")
    runner = numpy_policy.load(tmp_path / "policy.json")
    recorded = run_policy(load_settings(trained), runner, 1.0, seed=4)["observations"]
    learner = load_learner(trained)
    want = learner.predict(runner.normalize(recorded).astype(np.float32),
                           deterministic=True)[0]
    assert np.abs(want).max() > 1e-3  # a policy that acts
    # float32 network against float64 NumPy: rounding well under 1e-5
    np.testing.assert_allclose(runner(recorded), want, atol=1e-5)
    ort = pytest.importorskip("onnxruntime")
    session = ort.InferenceSession(str(tmp_path / "policy.onnx"))
    got = session.run(["action"], {"observation": recorded.astype(np.float32)})[0]
    np.testing.assert_allclose(got, want, atol=1e-5)


def test_a_replay_buffer_round_trips_as_data(tmp_path):
    # SAC's resume keeps its replay buffer as .npz arrays, not SB3's pickle
    import gymnasium as gym
    from stable_baselines3.common.buffers import ReplayBuffer

    from tensim.rl.train import _load_replay, _save_replay

    spaces = gym.spaces.Box(-1.0, 1.0, (3,)), gym.spaces.Box(-1.0, 1.0, (2,))
    rng = np.random.default_rng(0)
    saved = ReplayBuffer(5, *spaces, device="cpu")
    for _ in range(7):  # past its size: it wrapped, full with pos 2
        saved.add(rng.random((1, 3)), rng.random((1, 3)), rng.random((1, 2)), rng.random(1),
                  np.array([False]), [{}])
    _save_replay(saved, tmp_path / "replay_buffer.npz")
    loaded = ReplayBuffer(5, *spaces, device="cpu")
    _load_replay(loaded, tmp_path / "replay_buffer.npz")
    assert (loaded.pos, loaded.full) == (2, True)
    for name in ("observations", "next_observations", "actions", "rewards", "dones"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(saved, name))
    with np.load(tmp_path / "replay_buffer.npz", allow_pickle=False) as f:  # plain arrays
        assert set(f.files) >= {"observations", "actions", "pos", "full"}


def test_rendered_cable_colours_use_each_robots_randomised_stiffness(robot_file):
    # the colours of env.render() come from the same load cells as the observation: with
    # stiffness drawn x2, the tensions handed to the renderer are 2 k max(0, x - l)
    from tensim.rl._render import Renders

    env, obs = _stepped_with_stiffness_doubled(robot_file)
    n = env.robot.n
    seen = []
    renders = Renders.__new__(Renders)  # no OpenGL: a renderer that keeps what it is given
    renders.compiled = env.robot.compiled
    renders.renderer = type("Keep", (), {"render": lambda self, data, tension, rest, text:
                                         seen.append(np.array(tension))})()
    renders.image(env.worlds.models[0], env.worlds.data(0))
    length, rest = obs[:n], obs[n:2 * n]
    want = np.where(length > rest, 2.0 * 3000.0 * (length - rest), 0.0)
    np.testing.assert_allclose(seen[0], want, rtol=1e-6)


def test_a_ppo_run_starts_from_an_exported_policy(robot_file, tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    import json

    from tensim.cli import main
    from tensim.rl import policy as numpy_policy
    from tensim.rl.export import _layers, export, load_learner
    from tensim.rl.train import VALUE_WARMUP

    first, second = tmp_path / "first", tmp_path / "second"
    assert _train(robot_file, first, "ppo", 64) == 0
    export(first)
    source = numpy_policy.load(first / "policy.json")

    def init(*extra):
        return main(["--quiet", "rl", "train", robot_file, "--envs", "2", "--episode", "1",
                     "--init", str(first / "policy.json"), *extra])

    assert init("--steps", "64", "--out", str(second)) == 0
    progress = json.loads((second / "progress.json").read_text())
    assert progress["init"] == {"policy": "policy.json", "env_steps": 64,
                                "cpu_s": pytest.approx(source.meta["training"]["cpu_s"])}

    def actor(folder):
        return [layer.weight.detach().numpy().copy()
                for layer in _layers(load_learner(folder))[0]]

    # an update within the value function's warm-up leaves the copied actor as it was
    for got, want in zip(actor(second), source.weights, strict=True):
        np.testing.assert_array_equal(got, want.astype(np.float32))
    # past it (one update of 64 env steps each), the actor learns too
    budget = str(64 * (VALUE_WARMUP + 1))
    assert main(["--quiet", "rl", "train", robot_file, "--envs", "2", "--episode", "1",
                 "--steps", budget, "--out", str(second), "--resume"]) == 0
    assert not all(np.array_equal(got, want.astype(np.float32))
                   for got, want in zip(actor(second), source.weights, strict=True))
    assert export(second)["training"]["init"]["env_steps"] == 64
    # a trained run, another task or SAC: refused, naming why
    capsys.readouterr()
    assert init("--steps", budget, "--out", str(second), "--resume") == 2
    assert "--init starts a new run only" in capsys.readouterr().err
    assert init("--task", "turn", "--steps", "64", "--out", str(tmp_path / "turn")) == 2
    assert "differ: task" in capsys.readouterr().err
    assert init("--algo", "sac", "--steps", "64", "--out", str(tmp_path / "sac")) == 2
    assert "differ: algo" in capsys.readouterr().err


def test_a_warm_start_takes_its_own_noise_rate_and_warm_up_and_keeps_each_checkpoint(
        robot_file, tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    import json

    from tensim.cli import main
    from tensim.rl import policy as numpy_policy
    from tensim.rl.export import _layers, export, load_learner

    first, second = tmp_path / "first", tmp_path / "second"
    assert _train(robot_file, first, "ppo", 64) == 0
    export(first)
    source = numpy_policy.load(first / "policy.json")

    def train(steps, *extra):
        return main(["--quiet", "rl", "train", robot_file, "--envs", "2", "--episode", "1",
                     "--steps", str(steps), "--checkpoint", "64", "--out", str(second),
                     *extra])

    # one update of 128 env steps (the run's n_steps), within the value function's warm-up
    assert train(128, "--init", str(first / "policy.json"), "--init-std", "0.2",
                 "--init-lr", "1e-4", "--init-warmup", "2", "--keep") == 0
    init = json.loads((second / "progress.json").read_text())["init"]
    assert init["action_std"] == 0.2 and init["learning_rate"] == 1e-4
    assert init["value_warmup_updates"] == 2

    def check(steps, learnt):
        learner = load_learner(second)
        assert learner.lr_schedule(1.0) == pytest.approx(1e-4)
        std = np.exp(learner.policy.log_std.detach().numpy())
        same = [np.array_equal(got.weight.detach().numpy(), want.astype(np.float32))
                for got, want in zip(_layers(learner)[0], source.weights, strict=True)]
        assert (not np.allclose(std, 0.2) and not all(same)) if learnt else \
            (np.allclose(std, 0.2) and all(same))
        # each checkpoint's policy kept, as `tensim rl export` writes it
        kept = numpy_policy.load(second / "checkpoints" / str(steps) / "policy.json")
        assert kept.meta["training"]["env_steps"] == steps
        assert [list(w.shape) for w in kept.weights] == kept.meta["network"]["layers"]

    check(128, learnt=False)
    # resumed (the warm-up's length and the rate are kept): the second update is the
    # warm-up's last, the third trains the actor too
    assert train(256, "--resume", "--keep") == 0
    check(256, learnt=False)
    assert train(384, "--resume", "--keep") == 0
    check(384, learnt=True)
    assert sorted(int(p.name) for p in (second / "checkpoints").iterdir()) == [128, 256, 384]
    # a warm start's settings without --init: refused, naming the option
    capsys.readouterr()
    assert main(["--quiet", "rl", "train", robot_file, "--envs", "2", "--steps", "64",
                 "--init-lr", "1e-4", "--out", str(tmp_path / "third")]) == 2
    assert "--init-lr 0.0001: applies only to a run started with --init" in \
        capsys.readouterr().err
    assert not (tmp_path / "third").exists()


def test_support_faces_tell_rolling_from_staying_on_one_face():
    """A straight 3-bar prism turned about its long axis by 120 and 240 degrees stands on each
    of its three rectangular sides in turn (4 ends each, all 6 ends on the ground); held in
    one pose it stands on one side, with 4 ends on the ground."""
    from tensim.rl.evaluate import support_faces

    angles = np.radians([90.0, 210.0, 330.0])
    ends = np.array([[x, np.cos(a), np.sin(a)] for x in (0.0, 2.0) for a in angles])

    def turned(deg: float) -> np.ndarray:
        c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
        p = ends @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]]).T
        return p - [0.0, 0.0, p[:, 2].min()]

    rolled = support_faces(np.array([turned(d) for d in (0.0, 120.0, 240.0, 360.0)]))
    assert [len(f) for f in rolled] == [4, 4, 4, 4]
    assert len(set(rolled[:3])) == 3 and rolled[3] == rolled[0]
    assert set().union(*rolled) == {str(i) for i in range(6)}
    still = support_faces(np.array([turned(0.0)] * 3))
    assert len(set(still)) == 1 and len(still[0]) == 4
