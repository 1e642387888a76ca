"""Imitating the statics rolling gait: the expert's actions in the env's units, the shadow
expert's labels, the fit, and the exported policy it writes (``tensim rl imitate``), on the
``six_bar`` preset (a rest-length robot the gait rolls, its plans cached through its
symmetry) with tiny budgets."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("gymnasium", reason="the rl extra (gymnasium) is not installed")
torch = pytest.importorskip("torch", reason="the rl extra (torch) is not installed")

from tensim import InputError  # noqa: E402
from tensim.rl import policy as numpy_policy  # noqa: E402
from tensim.rl.env import TensegrityEnv  # noqa: E402
from tensim.rl.expert import Expert, expert_action  # noqa: E402
from tensim.rl.imitate import (  # noqa: E402
    ImitationSettings,
    episode,
    fit,
    imitate,
    network,
)
from tensim.rl.train import TrainSettings  # noqa: E402
from tensim.sim import compiled_available  # noqa: E402

pytestmark = pytest.mark.skipif(not compiled_available(),
                                reason="the environments step on the compiled cable law")

SETTINGS = TrainSettings(model="six_bar", episode_s=1.0, timestep=0.005, seed=5)


@pytest.fixture(scope="module")
def env():
    made = TensegrityEnv(SETTINGS.env_config())
    yield made
    made.close()


@pytest.fixture(scope="module")
def imitated(tmp_path_factory):
    """A two-iteration run of one 1 s episode each (the second with the policy driving)."""
    out = tmp_path_factory.mktemp("imitate") / "run"
    record = imitate(SETTINGS, ImitationSettings(iterations=2, episodes=1, epochs=2), out)
    return out, record


def test_the_expert_action_commands_the_gaits_rest_lengths_exactly(env, imitated):
    robot = env.robot
    runner = numpy_policy.load(imitated[0] / "policy.json")
    rng = np.random.default_rng(0)
    for _ in range(20):  # rest lengths anywhere within the motors' limits
        command = robot.rest0.copy()
        command[robot.motors] = rng.uniform(robot.low, robot.high)
        action = expert_action(robot, command)
        # (exact but for rounding: l0 (1 + ((c / l0 - 1) / span) span))
        np.testing.assert_allclose(runner.command(action), command[robot.motors],
                                   rtol=1e-14, atol=0)
        np.testing.assert_allclose(robot.command(action[None])[0][0], command, rtol=1e-14)


def test_a_shadow_expert_labels_what_the_expert_in_control_does(env):
    expert = Expert(env.robot)
    driving = episode(env, expert, seed=11)
    np.testing.assert_array_equal(driving["actions"], driving["labels"])
    assert np.ptp(driving["labels"]) > 0.1  # the gait planned and pushed within the episode
    # the same actions, replayed by another driver: the shadow (its own state machine and
    # command array, fed only the robot) labels every state as the expert did
    replay = iter(driving["actions"])
    shadow = episode(env, Expert(env.robot, plans=expert.plans), seed=11,
                     control=lambda obs, label: next(replay))
    np.testing.assert_array_equal(shadow["labels"], driving["labels"])
    np.testing.assert_array_equal(shadow["observations"], driving["observations"])
    # a driver that holds the build rest lengths: the robot stays, the labels differ
    still = episode(env, Expert(env.robot, plans=expert.plans), seed=11,
                    control=lambda obs, label: np.zeros_like(label))
    assert abs(still["body_lengths_per_s"]) < abs(driving["body_lengths_per_s"])


def test_the_fit_recovers_a_known_linear_map():
    rng = np.random.default_rng(1)
    a, b = rng.uniform(-0.2, 0.2, (3, 5)), rng.uniform(-0.1, 0.1, 3)
    x = rng.normal(0.0, 1.0, (4000, 5))
    net = network(5, 3, seed=2)
    loss = fit(net, x, x @ a.T + b, epochs=60, learning_rate=3e-3, seed=3)
    assert loss < 1e-4  # targets of about 0.3 rms: a fit within 1 % of their scale
    with torch.no_grad():  # the map's slope and offset, from the network at the origin
        origin = torch.zeros(1, 5, dtype=torch.float64, requires_grad=False)
        slope = torch.autograd.functional.jacobian(net, origin)[0, :, 0]
        offset = net(origin)[0].numpy()
    np.testing.assert_allclose(slope.numpy(), a, atol=0.02)  # 10 % of the slopes' range
    np.testing.assert_allclose(offset, b, atol=0.01)


def test_the_run_writes_a_policy_that_loads_and_starts_a_ppo_run(imitated, tmp_path):
    from tensim.cli import main
    from tensim.rl.export import _layers, load_learner

    out, record = imitated
    assert [r["driver"] for r in record["iterations"]] == ["expert", "policy"]
    assert record["env_steps"] == 2 * 50  # two episodes of 1 s at 20 ms
    runner = numpy_policy.load(out / "policy.json")
    assert runner.meta["training"]["imitation"]["iterations"] == 2
    # each iteration's policy is kept; the last is the run's
    assert (out / "iterations" / "0" / "policy.npz").is_file()
    assert json.loads((out / "iterations" / "1" / "policy.json").read_text()) == runner.meta
    data = np.load(out / "data.npz")
    assert data["observations"].shape == (100, runner.mean.size)
    np.testing.assert_allclose(runner.mean, data["observations"].mean(axis=0))
    # `rl evaluate` takes it, and a PPO run starts from its actor
    assert main(["--quiet", "rl", "evaluate", str(out / "policy.json"), "--duration", "0.2",
                 "--out", str(tmp_path / "eval")]) == 0
    assert main(["--quiet", "rl", "train", "six_bar", "--envs", "2", "--episode", "1",
                 "--dt", "0.005", "--steps", "64", "--init", str(out / "policy.json"),
                 "--init-std", "0.1", "--out", str(tmp_path / "ppo")]) == 0
    for got, want in zip(_layers(load_learner(tmp_path / "ppo"))[0], runner.weights,
                         strict=True):
        np.testing.assert_array_equal(got.weight.detach().numpy(), want.astype(np.float32))


def test_a_run_resumes_at_its_next_iteration_and_refuses_other_settings(imitated, tmp_path):
    import shutil

    out = tmp_path / "run"
    shutil.copytree(imitated[0], out)
    with pytest.raises(InputError, match="add --resume"):
        imitate(SETTINGS, ImitationSettings(iterations=3, episodes=1, epochs=2), out)
    with pytest.raises(InputError, match=r"changed: imitation\.noise"):
        imitate(SETTINGS, ImitationSettings(iterations=3, episodes=1, epochs=2, noise=0.3),
                out, resume=True)
    record = imitate(SETTINGS, ImitationSettings(iterations=3, episodes=1, epochs=2), out,
                     resume=True)
    assert [r["iteration"] for r in record["iterations"]] == [0, 1, 2]
    assert record["iterations"][:2] == imitated[1]["iterations"][:2]
    assert np.load(out / "data.npz")["labels"].shape[0] == 150
    # as if it had not stopped: the same policy as three iterations run at once
    whole = tmp_path / "whole"
    again = imitate(SETTINGS, ImitationSettings(iterations=3, episodes=1, epochs=2), whole)
    for a, b in zip(again["iterations"], record["iterations"], strict=True):
        assert {**a, "cpu_s": 0} == {**b, "cpu_s": 0}
    for name in ("policy.npz", "network.npz", "data.npz"):
        with np.load(whole / name) as want, np.load(out / name) as got:
            for key in want.files:
                np.testing.assert_array_equal(got[key], want[key])


def test_bad_input_is_refused_naming_why(tmp_path, capsys):
    from tensim.cli import main

    tetraspine = TrainSettings(model="tetraspine3", episode_s=1.0)
    with pytest.raises(InputError, match="its actions are 'vstar'"):
        imitate(tetraspine, ImitationSettings(), tmp_path / "a")
    with pytest.raises(InputError, match="--task roll"):
        imitate(TrainSettings(model="three_bar", task="turn"), ImitationSettings(),
                tmp_path / "b")
    with pytest.raises(InputError, match="use --algo ppo"):
        imitate(TrainSettings(model="three_bar", algo="sac"), ImitationSettings(),
                tmp_path / "c")
    with pytest.raises(InputError, match="--beta must be a probability"):
        ImitationSettings(beta=1.5)
    with pytest.raises(InputError, match="--episodes must be an integer >= 1"):
        ImitationSettings(episodes=0)
    with pytest.raises(SystemExit):
        main(["rl", "imitate", "three_bar", "--task", "turn"])
    assert "invalid choice: 'turn'" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())  # nothing written for a refused run


def test_the_expert_refuses_to_act_before_an_episode(env):
    with pytest.raises(RuntimeError, match="start"):
        Expert(env.robot).act(env.worlds, 0)


def test_the_record_names_each_iterations_figures(imitated):
    record = json.loads((imitated[0] / "record.json").read_text())
    first = record["iterations"][0]
    assert set(first) >= {"driver", "body_lengths_per_s", "expert_agreement_mse", "fit_mse",
                          "samples", "env_steps", "cpu_s"}
    assert first["expert_agreement_mse"] == pytest.approx(0.1 ** 2, rel=0.5)  # its noise


def test_the_expert_rolls_the_env_robot_as_the_roll_experiment_does():
    # `tensim experiment roll six_bar --dt 0.005 --cable-law implicitfast --cached-plans`
    # rolls 0.38 body lengths/s over 30 s; in the env (its own looks every 20 ms, a random
    # heading and 2 mm of pose noise) the same gait makes well over 0.2 in 6 s
    settings = TrainSettings(model="six_bar", episode_s=6.0, timestep=0.005)
    made = TensegrityEnv(settings.env_config())
    run = episode(made, Expert(made.robot), seed=3)
    made.close()
    assert run["body_lengths_per_s"] > 0.25
    assert not run["unstable"]


def test_a_robot_with_no_solid_hull_is_refused():
    from types import SimpleNamespace

    from tensim.rl.expert import check_rolling

    flat = [SimpleNamespace(position=(x, y, 0.1)) for x, y in ((0, 0), (1, 0), (0, 1), (1, 1))]
    robot = SimpleNamespace(config=SimpleNamespace(task="direction", model="flat"),
                            action="rest_length",
                            compiled=SimpleNamespace(structure=SimpleNamespace(nodes=flat)))
    with pytest.raises(InputError, match="no solid convex hull"):
        check_rolling(robot)  # type: ignore[arg-type]


def test_an_imitated_policy_exports_to_onnx_acting_as_the_numpy_runner(tmp_path) -> None:
    """`rl export` takes a folder that holds an exported policy (an imitation's): the ONNX
    graph gives the NumPy runner's actions to 1e-5 (float32 against float64)."""
    from pathlib import Path

    from tensim.cli import main

    shipped = Path(__file__).resolve().parent.parent / "examples" / "rl" / "six_bar_roll" \
        / "imitate_seed1"
    assert main(["--quiet", "rl", "export", str(shipped), "--onnx",
                 str(tmp_path / "policy.onnx")]) == 0
    runner = numpy_policy.load(tmp_path / "policy.json")
    assert numpy_policy.load(shipped / "policy.json").meta == {
        k: v for k, v in runner.meta.items() if k != "network"} | {
        "network": {k: v for k, v in runner.meta["network"].items() if k != "onnx"}}
    observations = np.random.default_rng(0).normal(
        runner.mean, np.sqrt(runner.var), (64, runner.mean.size))
    want = runner(observations)
    assert np.abs(want).max() > 1e-2  # it acts
    ort = pytest.importorskip("onnxruntime")
    session = ort.InferenceSession(str(tmp_path / "policy.onnx"))
    got = session.run(["action"], {"observation": observations.astype(np.float32)})[0]
    np.testing.assert_allclose(got, want, atol=1e-5)


def test_a_structure_file_learns_rest_length_actions_when_asked(tmp_path) -> None:
    """A robot file acts by V* by default (the laws that hold its build pose); with
    --action rest_length it acts by rest lengths, as a lab's actuators, so the statics gait
    can teach it; the default keeps the fingerprint of runs from before the option."""
    import dataclasses

    from tensim.models import three_bar
    from tensim.rl._robot import Robot
    from tensim.rl.expert import Expert
    from tensim.rl.train import fingerprint
    from tensim.structure import save_structure

    path = tmp_path / "prism.yaml"
    save_structure(dataclasses.replace(three_bar(), name="prism"), path)
    plain = TrainSettings(model=str(path), episode_s=1.0)
    assert Robot(plain.env_config()).action == "vstar"
    with pytest.raises(InputError, match="give --action rest_length"):
        Expert(Robot(plain.env_config()))
    lengths = dataclasses.replace(plain, action="rest_length")
    robot = Robot(lengths.env_config())
    assert robot.action == "rest_length"
    Expert(robot)  # the gait may teach it
    assert fingerprint(lengths) != fingerprint(plain)  # (the default's: test_rl_roll_reward)
    with pytest.raises(InputError, match="--action must be one of"):
        TrainSettings(model="three_bar", action="torque")
