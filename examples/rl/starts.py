"""A rolling policy's speed from many starts: what `tensim rl evaluate POLICY --duration 30
--seed S` prints as body lengths/s (the centre of mass's displacement along the heading from
MjData, per second, over the longest rod), for each start S, then their mean and spread.
With --expert, the statics rolling gait (tensim.rl.expert) drives the policy's env instead
of the policy, from the same starts.

Run: python examples/rl/starts.py POLICY START-END[,START-END...] [--duration S]
e.g. python examples/rl/starts.py examples/rl/six_bar_roll/seed0_episode30/policy.json 10-19
"""

import argparse

import numpy as np

from tensim.rl.evaluate import body_length, load_policy, run_policy


def starts(text: str) -> list[int]:
    """``0-2,20-29`` -> [0, 1, 2, 20, ..., 29]."""
    seeds: list[int] = []
    for part in text.split(","):
        first, _, last = part.partition("-")
        seeds += range(int(first), int(last or first) + 1)
    return seeds


parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("policy", help="an exported policy.json or a training run folder")
parser.add_argument("starts", type=starts, help="start seeds, e.g. 0-2,20-29")
parser.add_argument("--duration", type=float, default=30.0, help="simulated time [s]")
parser.add_argument("--expert", action="store_true",
                    help="the statics rolling gait drives, in the policy's env")
args = parser.parse_args()
settings, policy = load_policy(args.policy)
if args.expert:
    from tensim.rl.env import TensegrityEnv
    from tensim.rl.evaluate import evaluation_randomization
    from tensim.rl.expert import Expert
    from tensim.rl.imitate import episode

    env = TensegrityEnv(settings.env_config(episode_s=args.duration,
                                            randomization=evaluation_randomization()))
    expert = Expert(env.robot)
speeds = []
for seed in args.starts:
    if args.expert:
        run = episode(env, expert, seed)
        speeds.append(run["body_lengths_per_s"])
    else:
        run = run_policy(settings, policy, args.duration, seed)
        along = (run["com"][-1, :2] - run["com"][0, :2]) @ run["heading"]
        speeds.append(along / run["time"][-1] / body_length(settings.model))
    print(f"start {seed}: {speeds[-1]:+.4f} body lengths/s"
          + (" (unstable: stopped)" if run["unstable"] else ""))
s = np.array(speeds)
spread = s.std(ddof=1) if s.size > 1 else 0.0
print(f"{s.size} starts: mean {s.mean():.3f}, standard deviation {spread:.3f}, "
      f"min {s.min():.3f}, max {s.max():.3f} body lengths/s; {np.sum(s >= 0.2)} of {s.size} "
      ">= 0.2")
