"""The shipped policies of docs/rl.md (examples/rl: the 3-bar rolling seeds, the 3-bar
turning in place and trained on randomised physics, the 6-bar rolling): each, re-run from its
exported NumPy policy, does what the page says."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("gymnasium", reason="the rl extra (gymnasium) is not installed")

from tensim.rl.evaluate import body_length, load_policy, run_policy
from tensim.sim import compiled_available

pytestmark = pytest.mark.skipif(not compiled_available(),
                                reason="the environments step on the compiled cable law")

SHIPPED = sorted((Path(__file__).parent.parent / "examples" / "rl" / "three_bar_roll")
                 .glob("seed*/policy.json"))


def test_the_shipped_policies_move_the_3_bar_a_quarter_body_length_per_second():
    # the goal: >= 0.25 body lengths/s over 30 s from MjData on two of the three seeds,
    # each trained within a million env steps
    assert len(SHIPPED) == 3
    speeds = []
    for path in SHIPPED:
        settings, policy = load_policy(path)
        assert settings.model == "three_bar" and policy.meta["training"]["env_steps"] <= 10**6
        run = run_policy(settings, policy, 30.0, seed=0)
        assert not run["unstable"]
        along = (run["com"][-1, :2] - run["com"][0, :2]) @ run["heading"]
        speeds.append(along / run["time"][-1] / body_length("three_bar"))
    assert sum(s >= 0.25 for s in speeds) >= 2, np.round(speeds, 3)


EXAMPLES = Path(__file__).parent.parent / "examples" / "rl"


def test_the_policies_rewarded_for_rolling_roll_the_3_bar_through_its_faces():
    # the goal, rolling: >= 0.25 body lengths/s over 30 s from MjData on two of the three
    # seeds within a million env steps, standing on many faces of the rod ends' hull in turn
    # with all six ends taking turns on the ground (docs/rl.md: the policies trained without
    # the roll term keep to one or two faces and three or four ends)
    from tensim.rl.evaluate import support_faces

    shipped = sorted((EXAMPLES / "three_bar_rolling").glob("seed*/policy.json"))
    assert len(shipped) == 3
    rolled = []
    for path in shipped:
        settings, policy = load_policy(path)
        assert settings.model == "three_bar" and settings.roll_reward > 0
        assert policy.meta["training"]["env_steps"] <= 10**6
        run = run_policy(settings, policy, 30.0, seed=0)
        assert not run["unstable"]
        along = (run["com"][-1, :2] - run["com"][0, :2]) @ run["heading"]
        faces = support_faces(run["points"])
        rolled.append((along / run["time"][-1] / body_length("three_bar"), len(set(faces)),
                       len(set().union(*faces))))
    assert sum(v >= 0.25 and n >= 6 and ends == 6 for v, n, ends in rolled) >= 2, rolled


def test_the_shipped_turn_policy_turns_the_3_bar_in_place():
    # docs/rl.md: about 44 deg/s counter-clockwise over 30 s from the start of seed 0, the
    # centre of mass moving about a fifth of a body length
    settings, policy = load_policy(EXAMPLES / "three_bar_turn" / "seed0" / "policy.json")
    assert settings.task == "turn" and policy.meta["training"]["env_steps"] <= 10**6
    run = run_policy(settings, policy, 30.0, seed=0)
    assert not run["unstable"]
    assert np.degrees(run["yaw"][-1]) / run["time"][-1] > 30.0
    moved = np.hypot(*(run["com"][-1, :2] - run["com"][0, :2])) / body_length("three_bar")
    assert moved < 0.5


def test_the_shipped_randomised_policy_rolls_on_nominal_and_heavier_physics():
    # docs/rl.md: trained on Randomization.standard(); 0.26 body lengths/s on the nominal
    # physics and 0.35 with 1.3 times the mass (outside its training range)
    settings, policy = load_policy(EXAMPLES / "three_bar_dr" / "seed0" / "policy.json")
    assert settings.randomization == "standard"
    for physics, least in (({}, 0.25), ({"mass": 1.3}, 0.3)):
        run = run_policy(settings, policy, 30.0, seed=0, physics=physics)
        along = (run["com"][-1, :2] - run["com"][0, :2]) @ run["heading"]
        assert not run["unstable"]
        assert along / run["time"][-1] / body_length("three_bar") >= least, physics


def test_the_shipped_6_bar_policies_run_as_docs_rl_md_says():
    # docs/rl.md: trained on 10 s episodes, the policy rolls about 6 m along its heading in 30 s
    # from the start of seed 0 (0.1998 body lengths/s), stably, and stalls from others; trained
    # on from it with 30 s episodes, 0.207, 0.203 and 0.247 from starts 0, 1 and 2 (the starts
    # that checkpoint was chosen on: these figures hold for them only)
    first, policy = load_policy(EXAMPLES / "six_bar_roll" / "seed0" / "policy.json")
    assert first.model == "six_bar" and first.timestep == 0.005
    assert policy.meta["training"]["env_steps"] == 3_596_288
    run = run_policy(first, policy, 30.0, seed=0)
    assert not run["unstable"]
    along = (run["com"][-1, :2] - run["com"][0, :2]) @ run["heading"]
    assert along / run["time"][-1] / body_length("six_bar") >= 0.15
    settings, policy = load_policy(EXAMPLES / "six_bar_roll" / "seed0_episode30" / "policy.json")
    assert settings.episode_s == 30.0 and settings.timestep == 0.005
    assert policy.meta["training"]["env_steps"] == 2_990_080
    assert policy.meta["training"]["init"]["env_steps"] == 3_596_288
    for seed in (0, 1, 2):
        run = run_policy(settings, policy, 30.0, seed=seed)
        assert not run["unstable"]
        along = (run["com"][-1, :2] - run["com"][0, :2]) @ run["heading"]
        assert along / run["time"][-1] / body_length("six_bar") >= 0.18, seed


def test_the_fine_tuned_6_bar_policies_roll_from_starts_that_did_not_choose_them():
    # docs/rl.md: each seed's checkpoint was chosen on starts 10-29; from starts 30-33, which
    # played no part, they roll 0.140, 0.116, 0.157, 0.163 (seed 1), 0.087, 0.252, 0.108,
    # 0.227 (seed 2), 0.091, 0.186, 0.296, 0.156 (seed 4, trained on from seed 1) and 0.237,
    # 0.199, 0.230, 0.236 (seed 8, trained on from seed 4) body lengths/s: means 0.144, 0.168,
    # 0.182 and 0.226 (over 200 other starts seed 8 rolls 0.193, short of the goal of 0.2)
    for name, steps, init, least in (("finetune_seed1", 1_384_448, 2_990_080, 0.12),
                                     ("finetune_seed2", 1_581_056, 2_990_080, 0.14),
                                     ("finetune_seed4", 1_196_032, 1_384_448, 0.15),
                                     ("finetune_seed8", 798_720, 1_196_032, 0.19)):
        settings, policy = load_policy(EXAMPLES / "six_bar_roll" / name / "policy.json")
        assert settings.episode_s == 30.0 and policy.meta["training"]["env_steps"] == steps
        assert policy.meta["training"]["init"]["env_steps"] == init
        speeds = []
        for seed in (30, 31, 32, 33):
            run = run_policy(settings, policy, 30.0, seed=seed)
            assert not run["unstable"]
            along = (run["com"][-1, :2] - run["com"][0, :2]) @ run["heading"]
            speeds.append(along / run["time"][-1] / body_length("six_bar"))
        assert np.mean(speeds) >= least, (name, np.round(speeds, 4))


def test_the_imitated_6_bar_policy_rolls_past_the_goal_from_fresh_starts():
    # docs/rl.md: learnt by `tensim rl imitate` (DAgger on the statics gait, 192,000 env
    # steps); from starts 1000-1003, none of which trained or chose it, 0.243, 0.316, 0.459
    # and 0.302 body lengths/s (mean 0.330; over 1000-1199, 0.315 +- 0.005)
    settings, policy = load_policy(EXAMPLES / "six_bar_roll" / "imitate_seed1" / "policy.json")
    assert settings.model == "six_bar" and settings.timestep == 0.005
    assert policy.meta["training"]["env_steps"] == 192_000
    assert policy.meta["training"]["imitation"]["iterations"] == 8
    speeds = []
    for seed in (1000, 1001, 1002, 1003):
        run = run_policy(settings, policy, 30.0, seed=seed)
        assert not run["unstable"]
        along = (run["com"][-1, :2] - run["com"][0, :2]) @ run["heading"]
        speeds.append(along / run["time"][-1] / body_length("six_bar"))
    assert np.mean(speeds) >= 0.25, np.round(speeds, 4)
