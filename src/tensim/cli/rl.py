"""``tensim rl``: learn a policy with reinforcement learning, evaluate it, export it to a
robot (needs the rl extra: ``pip install 'tensim[rl]'``)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from tensim.cli._common import count, finite, nonnegative, positive


def _env_options(p: argparse.ArgumentParser) -> None:
    """The env's options, shared by `rl train` and `rl imitate` (one env, one set of names)."""
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--control-dt", type=positive, default=0.02, help="control period [s]")
    p.add_argument("--episode", type=positive, default=10.0, help="episode length [s]")
    p.add_argument("--dt", type=positive, default=0.002, help="physics step [s] (default "
                   "0.002)")
    p.add_argument("--cable-law", choices=("explicit", "implicit", "implicitfast"),
                   default="implicitfast", help="the cable law (default implicitfast: stiff "
                   "cables at a 2 ms step)")
    p.add_argument("--rest-span", type=positive, default=0.6, metavar="FRACTION",
                   help="rest-length actions reach l0 (1 +- FRACTION), within the motor's "
                   "minimum rest length (default 0.6)")
    p.add_argument("--frame", choices=("heading", "robot"), default="heading",
                   help="observations in the heading's frame (default) or the robot's")
    p.add_argument("--randomize", choices=("start", "standard"), default="start",
                   help="randomise each episode's start only (a random heading, 2 mm of pose "
                   "noise; default) or also its physics, motor speeds and sensors (+-10-30 %%, "
                   "tensim.rl.Randomization.standard)")
    p.add_argument("--action", choices=("auto", "rest_length", "vstar"), default="auto",
                   help="the actions: auto (default) V* under the robot's impedance law where "
                   "it has one (a structure file gets the laws that hold its build pose), else "
                   "rest lengths; rest_length: each motorised cable's rest length, as a lab's "
                   "length-commanding actuators (what `rl imitate`'s gait commands)")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("rl", help="reinforcement learning: train, evaluate, export a policy")
    rl = p.add_subparsers(dest="rl_command", required=True)

    t = rl.add_parser("train", help="train a policy (PPO or SAC, Stable-Baselines3) on the "
                      "batch engine; resumable")
    t.add_argument("model", help="preset name or structure .yaml file")
    t.add_argument("--algo", choices=("ppo", "sac"), default="ppo")
    t.add_argument("--task", choices=("roll", "turn", "goal"), default="roll",
                   help="roll along --heading, turn in place, or reach a goal along it")
    t.add_argument("--heading", type=finite, default=0.0, metavar="DEG",
                   help="heading in the robot's start frame [deg] (default 0)")
    t.add_argument("--steps", type=count, default=100_000, help="env steps in all")
    t.add_argument("--envs", type=count, default=16, help="robots stepped together")
    _env_options(t)
    t.add_argument("--bar-contact-cost", type=positive, default=None,
                   help="penalty per rod-rod contact per second (default none)")
    t.add_argument("--roll-reward", type=positive, default=None, metavar="M_PER_RAD",
                   help="--task roll: also reward each radian the robot turns about its "
                   "rolling axis (z x heading; the best rigid fit of the rod ends' move) with "
                   "M_PER_RAD metres (default none)")
    t.add_argument("--slip-cost", type=positive, default=None,
                   help="penalty per metre the rod ends on the ground slide (default none)")
    t.add_argument("--rollout-steps", type=count, default=None, metavar="STEPS",
                   help="PPO: env steps per update, all robots together (default 4096; "
                   "minibatches of a quarter of it)")
    t.add_argument("--checkpoint", type=count, default=10_000, metavar="STEPS",
                   help="env steps between checkpoints (default 10000)")
    t.add_argument("--resume", action="store_true", help="continue the run in --out")
    t.add_argument("--init", default=None, metavar="POLICY",
                   help="start a new PPO run from an exported policy.json of the same robot "
                   "and task (its actor and observation normaliser; the value function "
                   "learns afresh)")
    t.add_argument("--init-std", type=positive, default=None, metavar="STD",
                   help="with --init: the action noise's standard deviation to start from, "
                   "in the [-1, 1] action box (default 0.61)")
    t.add_argument("--init-lr", type=positive, default=None, metavar="LR",
                   help="with --init: PPO's learning rate (default 3e-4)")
    t.add_argument("--init-warmup", type=int, default=None, metavar="UPDATES",
                   help="with --init: PPO updates in which the value function learns alone "
                   "(default 10)")
    t.add_argument("--keep", action="store_true",
                   help="also export every checkpoint's policy to OUT/checkpoints/STEPS/ "
                   "(policy.json, policy.npz), to choose one after the run")
    t.add_argument("--out", default="runs/rl", help="run folder")
    t.set_defaults(run=train)

    e = rl.add_parser("evaluate", help="drive one robot with a trained policy; write a run "
                      "folder with body_lengths_per_s")
    e.add_argument("run_dir", metavar="DIR|POLICY",
                   help="a `tensim rl train` folder or an exported policy.json")
    e.add_argument("--duration", type=positive, default=30.0, help="simulated time [s]")
    e.add_argument("--seed", type=int, default=0, help="the start's seed")
    e.add_argument("--video", action="store_true", help="also video.mp4 (offscreen OpenGL)")
    e.add_argument("--dt", type=positive, default=None,
                   help="physics step [s] (default: the one it was trained at)")
    e.add_argument("--cable-law", choices=("explicit", "implicit", "implicitfast"),
                   default=None, help="cable law (default: the one it was trained with)")
    for name in ("friction", "stiffness", "damping", "mass", "motor_speed"):
        e.add_argument(f"--{name.replace('_', '-')}", type=positive, default=None,
                       metavar="FACTOR", help=f"multiplies the robot's {name.replace('_', ' ')} "
                       "(physics it was not trained on; default 1)")
    e.add_argument("--out", default=None, help="run folder (default DIR/evaluation)")
    e.set_defaults(run=evaluate)

    i = rl.add_parser("imitate", help="learn a rolling policy by imitating the statics "
                      "rolling gait (DAgger); writes an exported policy that `rl train --init` "
                      "fine-tunes; resumable")
    i.add_argument("model", help="preset name or structure .yaml file")
    i.add_argument("--task", choices=("roll",), default="roll",
                   help="roll along --heading (the statics gait's task)")
    i.add_argument("--heading", type=finite, default=0.0, metavar="DEG",
                   help="heading in the robot's start frame [deg] (default 0)")
    i.add_argument("--iterations", type=count, default=4,
                   help="DAgger iterations, the first with the gait driving (default 4)")
    i.add_argument("--episodes", type=count, default=16, help="episodes per iteration "
                   "(default 16)")
    i.add_argument("--noise", type=nonnegative, default=0.1, metavar="STD",
                   help="noise on the gait's actions while it drives, in the [-1, 1] action "
                   "box (default 0.1)")
    i.add_argument("--beta", type=nonnegative, default=0.0,
                   help="after the first iteration, the chance per control period that the "
                   "gait drives instead of the policy (default 0)")
    i.add_argument("--epochs", type=count, default=30, help="passes over the data per fit "
                   "(default 30)")
    _env_options(i)
    i.add_argument("--resume", action="store_true", help="continue the run in --out")
    i.add_argument("--out", default="runs/imitate", help="run folder")
    i.set_defaults(run=imitate)

    x = rl.add_parser("export", help="write the policy as ONNX and NumPy arrays, with its "
                      "observation/action layout and normalisation (policy.json)")
    x.add_argument("run_dir", metavar="DIR", help="a `tensim rl train` folder, or one that "
                   "holds an exported policy.json (a `tensim rl imitate` folder)")
    x.add_argument("--onnx", default=None, metavar="FILE",
                   help="ONNX file (policy.json and policy.npz go beside it; without it they "
                   "go into DIR)")
    x.set_defaults(run=export)


def _need_rl_extra() -> None:
    """Refuses clearly where the rl extra is missing."""
    import importlib.util

    from tensim import InputError

    missing = [m for m in ("gymnasium", "stable_baselines3", "torch")
               if importlib.util.find_spec(m) is None]
    if missing:
        raise InputError(f"tensim rl needs {', '.join(missing)}: pip install 'tensim[rl]'")


def train(args: argparse.Namespace) -> int:
    _need_rl_extra()
    from tensim.cli._common import Progress
    from tensim.rl.train import ROLLOUT_STEPS, TrainSettings
    from tensim.rl.train import train as run_training

    settings = TrainSettings(model=args.model, algo=args.algo, task=args.task,
                             heading_deg=args.heading, steps=args.steps, envs=args.envs,
                             seed=args.seed, control_dt=args.control_dt,
                             episode_s=args.episode, timestep=args.dt,
                             cable_law=args.cable_law, rest_span=args.rest_span,
                             frame=args.frame, randomization=args.randomize,
                             bar_contact_cost=args.bar_contact_cost or 0.0,
                             roll_reward=args.roll_reward or 0.0,
                             slip_cost=args.slip_cost or 0.0,
                             rollout_steps=args.rollout_steps or ROLLOUT_STEPS,
                             action=args.action)
    bar = Progress(f"rl train {args.algo}", args.quiet, unit="env steps",
                   rate_label="env steps/s")
    state = run_training(settings, Path(args.out), resume=args.resume,
                         checkpoint_steps=args.checkpoint, progress=bar,
                         init=None if args.init is None else Path(args.init),
                         init_std=args.init_std, init_lr=args.init_lr,
                         init_warmup=args.init_warmup, keep=args.keep)
    curve = state["curve"]
    last = [r for _, r in curve[-max(1, len(curve) // 10):]] if curve else []
    mean = sum(last) / len(last) if last else 0.0
    returns = f"mean return of the last {len(last)} episodes {mean:+.3f}" if last else \
        "no episode ended yet"
    print(f"{state['steps_done']} env steps; {returns}")
    print(f"training CPU time {state['cpu_s']:.0f} s; wrote {args.out}")
    return 0


def evaluate(args: argparse.Namespace) -> int:
    _need_rl_extra()
    from tensim.rl.evaluate import evaluate as run_evaluation

    source = Path(args.run_dir)
    out = Path(args.out) if args.out else (source.parent if source.is_file() else source) \
        / "evaluation"
    physics = {k: getattr(args, k) for k in ("friction", "stiffness", "damping", "mass",
                                              "motor_speed") if getattr(args, k) is not None}
    s = run_evaluation(source, out, args.duration, args.seed, video=args.video,
                       timestep=args.dt, cable_law=args.cable_law, physics=physics)
    if s["task"] == "turn":
        print(f"policy of {args.run_dir}: turned {math.degrees(s['yaw_turned_rad']):+.1f} deg "
              f"in {s['duration_s']:g} s = {s['yaw_rate_deg_per_s']:+.2f} deg/s "
              f"(counter-clockwise), centre of mass moved {s['displacement_body_lengths']:.3f} "
              f"body lengths (body length {s['body_length_m']:.3f} m); wrote {out}")
        _trained(s)
        return 0
    error = "no net displacement" if s["heading_error_deg"] is None else \
        f"heading error {s['heading_error_deg']:+.1f} deg"
    error += "".join(f", {k.replace('_', ' ')} x{v:g}" for k, v in physics.items())
    print(f"policy of {args.run_dir}: {s['displacement_along_heading_m']:+.3f} m along the "
          f"heading in "
          f"{s['duration_s']:g} s = {s['body_lengths_per_s']:+.4f} body lengths/s "
          f"(body length {s['body_length_m']:.3f} m), {error}; wrote {out}")
    _trained(s)
    return 0


def _trained(summary: dict) -> None:
    """Prints the training's budget where the policy records it."""
    if summary["training"]:
        init = summary["training"].get("init")
        before = f", started from a policy of {init['env_steps']} env steps in " \
            f"{init['cpu_s']:.0f} CPU s" if init else ""
        print(f"trained {summary['training']['env_steps']} env steps in "
              f"{summary['training']['cpu_s']:.0f} CPU s{before}")


def export(args: argparse.Namespace) -> int:
    _need_rl_extra()
    import importlib.util

    from tensim import InputError

    if args.onnx and importlib.util.find_spec("onnx") is None:
        raise InputError("--onnx needs the onnx package: pip install 'tensim[rl]' (without "
                         "--onnx, policy.json and policy.npz are written all the same)")
    from tensim.rl.export import export as run_export

    meta = run_export(Path(args.run_dir), Path(args.onnx) if args.onnx else None)
    where = Path(args.onnx).parent if args.onnx else Path(args.run_dir)
    print(f"{meta['observation']['size']} observations -> {len(meta['action']['cables'])} "
          f"actions ({meta['action']['kind']}); wrote "
          f"{', '.join(str(where / f) for f in ['policy.json', 'policy.npz'])}"
          + (f", {args.onnx}" if args.onnx else ""))
    return 0


def imitate(args: argparse.Namespace) -> int:
    _need_rl_extra()
    from tensim.rl.imitate import ImitationSettings
    from tensim.rl.imitate import imitate as run_imitation
    from tensim.rl.train import TrainSettings

    settings = TrainSettings(model=args.model, task=args.task, heading_deg=args.heading,
                             seed=args.seed, control_dt=args.control_dt,
                             episode_s=args.episode, timestep=args.dt,
                             cable_law=args.cable_law, rest_span=args.rest_span,
                             frame=args.frame, randomization=args.randomize,
                             action=args.action)
    imitation = ImitationSettings(iterations=args.iterations, episodes=args.episodes,
                                  noise=args.noise, beta=args.beta, epochs=args.epochs)

    def report(it: dict) -> None:
        if not args.quiet:
            print(f"iteration {it['iteration']}: {it['driver']} drove {it['episodes']} "
                  f"episodes at {it['body_lengths_per_s']:+.3f} body lengths/s (std "
                  f"{it['body_lengths_per_s_std']:.3f}); actions off the gait's by "
                  f"{it['expert_agreement_mse']:.4f} (mean square); fit {it['fit_mse']:.4f} "
                  f"on {it['samples']} states; {it['cpu_s']:.0f} CPU s", flush=True)

    record = run_imitation(settings, imitation, Path(args.out), resume=args.resume,
                           progress=report)
    _draw_imitation(Path(args.out), record)
    print(f"{record['env_steps']} env steps in {record['cpu_s']:.0f} CPU s; wrote "
          f"{Path(args.out) / 'policy.json'}")
    return 0


def _draw_imitation(out: Path, record: dict) -> None:
    """The learning record as a figure: speed of who drove, and the imitation errors."""
    from tensim.viz.plots import new_figure, save_figure

    rows = record["iterations"]
    its = [r["iteration"] for r in rows]
    fig = new_figure((7.0, 3.2))
    speed, error = fig.subplots(1, 2)
    speed.errorbar(its, [r["body_lengths_per_s"] for r in rows],
                   [r["body_lengths_per_s_std"] for r in rows], fmt="o-")
    speed.set(xlabel="iteration (0: the gait; k: the policy fitted at k - 1)",
              ylabel="body lengths/s", title="speed of the driver")
    error.semilogy(its, [r["expert_agreement_mse"] for r in rows], "o-",
                   label="driver vs gait")
    error.semilogy(its, [r["fit_mse"] for r in rows], "s--", label="fit")
    error.set(xlabel="iteration", ylabel="mean square action error", title="imitation")
    error.legend()
    fig.tight_layout()
    save_figure(fig, out / "imitation.png")
