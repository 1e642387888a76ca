"""Train a walking policy with Stable-Baselines3 PPO on the batch engine, then evaluate it.

    python examples/train_ppo.py train --steps 150000 --seed 0 --out runs/ppo_seed0
    python examples/train_ppo.py evaluate runs/ppo_seed0
    python examples/train_ppo.py report runs/ppo_seed*/results.json --combine all.json \
        --plot curves.png
    python examples/train_ppo.py report examples/rl/ppo_tetraspine3.json
    python examples/train_ppo.py speed --envs 8 --threads 1

``train`` writes into ``--out``: policy.zip (SB3's format), obs_norm.npz (the observation
normaliser's statistics), curve.csv and learning_curve.png (mean return of the last episodes
against env steps), results.json (the evaluation) and video.mp4 (one 30 s evaluation episode,
where offscreen OpenGL works). The evaluation walks the deterministic policy for ``--eval-s``
seconds from several seeded starts and the shipped CPG gait from the build pose, measuring the
centre of mass's displacement along +y; ``evaluate`` repeats that for a saved folder.
``report`` prints the table of one or more results.json files (or a combined list). ``speed``
times env steps: the batch engine alone, the vector env and the SB3 adapter. Needs
``pip install tensim[rl]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

from tensim._files import write_json
from tensim.rl import EnvConfig, Randomization, TensegrityVectorEnv
from tensim.rl._render import Renders

EVAL_SEEDS = (100, 101, 102)


def training_config(args: argparse.Namespace) -> EnvConfig:
    """The environment of the training: +y, mild physics randomisation, 3 mm pose noise."""
    return EnvConfig(model=args.model, control_dt=args.control_dt, episode_s=args.episode_s,
                     direction=(0.0, 1.0), threads=args.threads,
                     randomization=Randomization(friction=(0.9, 1.1), stiffness=(0.9, 1.1),
                                                 mass=(0.95, 1.05), pose_noise_m=0.003))


def train(args: argparse.Namespace) -> None:
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from tensim.rl.sb3 import SB3VecEnv

    torch.set_num_threads(1)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    config = training_config(args)
    venv = SB3VecEnv(args.envs, config)
    venv.seed(args.seed)
    envs = VecNormalize(VecMonitor(venv), norm_obs=True, norm_reward=True, gamma=0.99)
    model = PPO("MlpPolicy", envs, n_steps=256, batch_size=256, n_epochs=5, gamma=0.99,
                learning_rate=3e-4, seed=args.seed, device="cpu", verbose=0)
    curve: list[tuple[int, float, float]] = []
    started = time.process_time()

    class Progress(BaseCallback):
        def _on_step(self) -> bool:
            return True

        def _on_rollout_end(self) -> None:
            returns = [e["r"] for e in self.model.ep_info_buffer]
            if returns:
                curve.append((self.num_timesteps, float(np.mean(returns)),
                              time.process_time() - started))
                print(f"{self.num_timesteps:>8} steps  mean return {curve[-1][1]:+.3f} m  "
                      f"cpu {curve[-1][2]:.0f} s", flush=True)

    model.learn(args.steps, callback=Progress())
    cpu_s = time.process_time() - started
    model.save(out / "policy.zip")
    rms = envs.obs_rms
    np.savez(out / "obs_norm.npz", mean=rms.mean, var=rms.var, clip=envs.clip_obs,
             epsilon=envs.epsilon)
    np.savetxt(out / "curve.csv", np.array(curve), delimiter=",",
               header="env_steps,mean_return_m,cpu_s", comments="")
    plot_curve(np.array(curve), out / "learning_curve.png", args.model)
    results = evaluate(out, args)
    results.update(model=args.model, seed=args.seed, env_steps=args.steps, cpu_s=round(cpu_s),
                   envs=args.envs, control_dt=args.control_dt, episode_s=args.episode_s)
    write_json(out / "results.json", results)
    print(table([results]))


class Policy:
    """A saved policy with its observation normaliser: observations -> actions."""

    def __init__(self, folder: Path):
        from stable_baselines3 import PPO

        self.model = PPO.load(folder / "policy.zip", device="cpu")
        with np.load(folder / "obs_norm.npz", allow_pickle=False) as f:
            self.mean, self.var = f["mean"], f["var"]
            self.clip, self.epsilon = float(f["clip"]), float(f["epsilon"])

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        z = np.clip((obs - self.mean) / np.sqrt(self.var + self.epsilon), -self.clip, self.clip)
        return self.model.predict(z, deterministic=True)[0]


def evaluate(folder: Path, args: argparse.Namespace) -> dict[str, object]:
    """Distance along +y in ``args.eval_s`` seconds: the policy from each evaluation seed,
    and the shipped CPG gait."""
    policy = Policy(folder)
    config = dataclasses.replace(training_config(args), episode_s=args.eval_s)
    env = TensegrityVectorEnv(len(EVAL_SEEDS), config)
    obs, _ = env.reset(seed=list(EVAL_SEEDS))
    start = env.worlds.f["subtree_com"][:, 0, :2].copy()
    frames: list[np.ndarray | None] = []
    every = max(1, round(1.0 / (15 * config.control_dt)))  # about 15 frames per second
    renders = None if args.no_video else _renders(env)
    marks = round(10.0 / config.control_dt)  # the distance every 10 s
    walked = []
    for k in range(config.max_steps):  # the last step ends the episodes (next-step reset)
        if k % every == 0 and renders is not None:
            frames.append(renders.image(env.worlds.models[0], env.worlds.data(0)))  # first start
        obs = env.step(policy(obs))[0]
        if (k + 1) % marks == 0:
            walked.append(float(np.mean(env.worlds.f["subtree_com"][:, 0, 1] - start[:, 1])))
    end = env.worlds.f["subtree_com"][:, 0, :2].copy()
    distances = (end - start)[:, 1]
    if frames:
        from tensim.viz.video import write_video

        write_video(frames, folder / "video.mp4", round(1.0 / (every * config.control_dt)))
    return {"eval_s": args.eval_s, "eval_seeds": list(EVAL_SEEDS),
            "policy_m": [round(float(d), 4) for d in distances],
            "policy_mean_m_every_10s": [round(w, 4) for w in walked],
            "cpg_m": round(cpg_distance(args.eval_s), 4) if args.model == "tetraspine3" else None}


def _renders(env: TensegrityVectorEnv) -> Renders | None:
    from tensim.viz._gl import OffscreenUnavailable

    try:
        return Renders(env.robot.compiled)
    except OffscreenUnavailable as err:
        print(f"no video: {err}", file=sys.stderr)
        return None


def cpg_distance(seconds: float) -> float:
    """The shipped CPG gait's centre-of-mass displacement along +y in ``seconds`` [m]."""
    from tensim.control import load_controller
    from tensim.model import WorldOptions, compile_structure
    from tensim.models import preset
    from tensim.sim import COM, simulate

    structure = preset("tetraspine3").build()
    compiled = compile_structure(structure, WorldOptions())
    controller = load_controller("tetraspine3_cpg", structure).build(compiled.model.opt.timestep)
    run = simulate(compiled, seconds, controller=controller)
    y = run.trajectory[f"pos_y/{COM}"]
    return float(y[-1] - y[0])


def plot_curve(curve: np.ndarray, path: Path, model: str) -> None:
    """The learning curve as a PNG."""
    plot_curves([{"model": model, "seed": "", "env_steps": int(curve[-1, 0]) if curve.size else 0,
                  "curve": curve.tolist()}], path)


def plot_curves(results: list[dict], path: Path) -> None:
    """Learning curves (mean return of the last episodes against env steps) as a PNG, with
    matplotlib's object API (no pyplot)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6, 3.5), layout="constrained")
    ax = fig.add_subplot()
    for r in results:
        curve = np.asarray(r["curve"], dtype=float).reshape(-1, 3)
        ax.plot(curve[:, 0], curve[:, 1],
                label=f"{r['model']} seed {r['seed']}, {r.get('env_steps', '?')} steps")
    ax.set_xlabel("env steps (all robots)")
    ax.set_ylabel("mean episode return [m along +y]")
    ax.set_title("PPO learning curves")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.savefig(path, dpi=120)


def table(results: list[dict]) -> str:
    """The evaluation table of ``results``: distances along +y in ``eval_s`` seconds."""
    lines = ["model        seed  episode [s]  env steps  CPU [s]  walk [s]  "
             "policy from 3 starts [m]  CPG gait [m]"]
    for r in results:
        walked = " ".join(f"{d:+.3f}" for d in r["policy_m"])
        lines.append(f"{r['model']:<12} {r['seed']:>4}  {r['episode_s']:>11g}  "
                     f"{r['env_steps']:>9}  {r['cpu_s']:>7}  "
                     f"{r['eval_s']:>8g}  {walked:<24}  {_signed(r['cpg_m'])}")
        if "policy_mean_m_every_10s" in r:
            lines.append("    policy's mean every 10 s [m]: " + " ".join(
                f"{d:+.3f}" for d in r["policy_mean_m_every_10s"]))
    return "\n".join(lines)


def _signed(value: float | None) -> str:
    return "-" if value is None else f"{value:+.3f}"


def speed(args: argparse.Namespace) -> None:
    """Env steps per second: MuJoCo's batch engine alone, the vector env, and the SB3 adapter,
    on the same robots, threads and control period (interleaved, best of 3)."""
    import mujoco

    from tensim.rl.sb3 import SB3VecEnv

    config = dataclasses.replace(training_config(args), threads=args.threads)
    vector, sb3 = TensegrityVectorEnv(args.envs, config), SB3VecEnv(args.envs, config)
    raw = vector.worlds.batch
    actions = np.random.default_rng(0).uniform(-1, 1, (args.envs, vector.robot.motors.size))
    vector.reset(seed=0)
    sb3.reset()

    def engine() -> None:
        raw.step(nstep=config.control_steps, stage=mujoco.mjtStage.mjSTAGE_VEL)

    runs = {"batch engine": engine, "TensegrityVectorEnv": lambda: vector.step(actions),
            "SB3VecEnv": lambda: sb3.step(actions)}
    best = dict.fromkeys(runs, 0.0)
    for _ in range(3):
        for name, step in runs.items():
            started = time.perf_counter()
            for _ in range(args.periods):
                step()
            rate = args.periods * args.envs / (time.perf_counter() - started)
            best[name] = max(best[name], rate)
    print(f"{args.model}, {args.envs} robots, {args.threads} thread(s), control_dt "
          f"{config.control_dt} s ({config.control_steps} physics steps), best of 3:")
    for name, rate in best.items():
        print(f"  {name:<20} {rate:8.0f} env steps/s  ({rate / best['batch engine']:.2f} of "
              "the engine)")


def reevaluate(folder: Path, no_video: bool) -> None:
    """Evaluates a saved training folder again (its settings from its results.json, which
    gets the new evaluation)."""
    saved = json.loads((folder / "results.json").read_text())
    args = argparse.Namespace(model=saved["model"], control_dt=saved["control_dt"],
                              episode_s=saved["episode_s"], eval_s=saved["eval_s"], threads=1,
                              no_video=no_video)
    results = {**saved, **evaluate(folder, args)}
    write_json(folder / "results.json", results)
    print(table([results]))


def report(paths: list[str], combine: str | None, plot: str | None) -> None:
    """Prints the table of results.json files (or combined lists); writes them as one list
    with their learning curves (``combine``) and draws the curves (``plot``)."""
    results: list[dict] = []
    for path in paths:
        data = json.loads(Path(path).read_text())
        for r in data if isinstance(data, list) else [data]:
            if "curve" not in r:  # a training folder: its curve.csv lies beside
                csv = np.loadtxt(Path(path).parent / "curve.csv", delimiter=",", skiprows=1)
                r["curve"] = np.round(csv, 4).tolist()
            results.append(r)
    print(table(results))
    if combine:
        write_json(Path(combine), results)
    if plot:
        plot_curves(results, Path(plot))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    t = sub.add_parser("train", help="train, evaluate, save")
    t.add_argument("--model", default="tetraspine3")
    t.add_argument("--steps", type=int, default=150_000, help="env steps (all robots)")
    t.add_argument("--envs", type=int, default=8, help="robots stepped together")
    t.add_argument("--threads", type=int, default=1, help="batch engine threads")
    t.add_argument("--seed", type=int, default=0)
    t.add_argument("--control-dt", type=float, default=0.05, help="[s]")
    t.add_argument("--episode-s", type=float, default=10.0, help="training episodes [s]")
    t.add_argument("--eval-s", type=float, default=30.0, help="evaluation episodes [s]")
    t.add_argument("--no-video", action="store_true")
    t.add_argument("--out", default="runs/ppo")
    p = sub.add_parser("speed", help="env steps/s: batch engine, vector env, SB3 adapter")
    p.add_argument("--model", default="tetraspine3")
    p.add_argument("--envs", type=int, default=8)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--control-dt", type=float, default=0.05)
    p.add_argument("--episode-s", type=float, default=10.0)
    p.add_argument("--periods", type=int, default=200, help="control periods per timing")
    e = sub.add_parser("evaluate", help="evaluate a saved training folder again")
    e.add_argument("folder")
    e.add_argument("--video", action="store_true", help="rewrite its video.mp4 too")
    r = sub.add_parser("report", help="print the table of saved results.json files")
    r.add_argument("paths", nargs="+")
    r.add_argument("--combine", default=None, help="write the results as one JSON list")
    r.add_argument("--plot", default=None, help="draw their learning curves into this PNG")
    args = parser.parse_args()
    if args.command == "train":
        train(args)
    elif args.command == "speed":
        speed(args)
    elif args.command == "evaluate":
        reevaluate(Path(args.folder), not args.video)
    else:
        report(args.paths, args.combine, args.plot)


if __name__ == "__main__":
    main()
