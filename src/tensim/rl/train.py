"""Training runs: a policy learnt with Stable-Baselines3 (PPO or SAC) on the batch engine,
checkpointed into a run folder so it resumes where it stopped (``tensim rl train``).

A run folder holds ``settings.json`` (what it trains, with a fingerprint of the robot file),
``policy.zip`` (SB3's format), ``normalizer.npz`` (the observation normaliser's running mean
and variance), ``progress.json`` (env steps done, the learning curve) and, for SAC, its
replay buffer (as .npz arrays); ``learning_curve.png`` is drawn at the end.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tensim._files import atomic_path, write_json
from tensim._input import InputError
from tensim.model import WorldOptions
from tensim.model._law_layout import CABLE_LAWS
from tensim.models import PRESETS
from tensim.rl.config import ACTIONS, FRAMES, ROLLING_OBSERVATION, EnvConfig, Randomization

ALGOS = ("ppo", "sac")
TASKS = {"roll": "direction", "turn": "turn", "goal": "goal"}
RANDOMIZATIONS = {"start": Randomization.start, "standard": Randomization.standard}
CLIP_OBS = 10.0  # the observation normaliser's clip (SB3's VecNormalize default)
EPSILON = 1e-8  # its variance floor
ROLLOUT_STEPS = 4096  # env steps per PPO update, all robots together
MIN_ROLLOUT = 16  # the shortest PPO rollout per robot
VALUE_WARMUP = 10  # PPO updates in which a warm-started run's value function learns alone


@dataclasses.dataclass(frozen=True)
class TrainSettings:
    """What a training run learns.

    Attributes:
        model: a preset name or a structure ``.yaml`` file.
        algo: ``"ppo"`` or ``"sac"``.
        task: ``"roll"`` (along ``heading_deg``), ``"turn"`` (in place, counter-clockwise) or
            ``"goal"`` (a point ``goal_m`` metres ahead along ``heading_deg``).
        heading_deg: the heading in the robot's start frame [deg].
        steps: env steps in all (all robots together).
        envs: robots stepped together on the batch engine.
        seed: seeds the environments and the learner.
        control_dt: control period [s].
        episode_s: episode length [s].
        goal_m: distance of the goal [m] (task ``goal``).
        bar_contact_cost: penalty per rod-rod contact, per second.
        roll_reward: task ``roll``: reward per radian turned about the rolling axis
            [m/rad] (:class:`~tensim.rl.EnvConfig`; 0: off).
        slip_cost: penalty per metre the rod ends on the ground slide (0: off).
        timestep: the physics step [s].
        cable_law: the cable law (``tensim.model.CABLE_LAWS``); the implicit laws hold stiff
            cables at longer steps.
        rest_span: half-range of the rest-length actions, as a fraction of the build rest
            length.
        frame: the observations' frame (``"heading"`` or ``"robot"``, see
            :class:`~tensim.rl.EnvConfig`).
        randomization: the training episodes' randomisation: ``"start"`` (a random heading
            and 2 mm of pose noise, :meth:`Randomization.start`) or ``"standard"`` (also
            physics, motor speeds and sensor noise, :meth:`Randomization.standard`).
        rollout_steps: PPO: env steps per update, all robots together (rounded down to a
            whole number per robot, at most ``steps``; minibatches of a quarter of it). A
            larger rollout averages each update's gradient over more episodes.
        action: the actions (:class:`~tensim.rl.EnvConfig`): ``"auto"`` (V* under the
            robot's impedance law where it has one, which a structure file gets from the laws
            that hold its build pose; else rest lengths), ``"vstar"`` or ``"rest_length"``
            (each motorised cable's rest length, as a lab's length-commanding actuators, and
            what the statics rolling gait commands).
    """

    model: str
    algo: str = "ppo"
    task: str = "roll"
    heading_deg: float = 0.0
    steps: int = 100_000
    envs: int = 16
    seed: int = 0
    control_dt: float = 0.02
    episode_s: float = 10.0
    goal_m: float = 2.0
    bar_contact_cost: float = 0.0
    roll_reward: float = 0.0
    slip_cost: float = 0.0
    timestep: float = 0.002
    cable_law: str = "implicitfast"
    rest_span: float = 0.6
    frame: str = "heading"
    randomization: str = "start"
    rollout_steps: int = ROLLOUT_STEPS
    action: str = "auto"

    def __post_init__(self) -> None:
        if self.action not in ACTIONS:
            raise InputError(f"--action must be one of {', '.join(ACTIONS)}, got "
                             f"{self.action!r}")
        if self.algo not in ALGOS:
            raise InputError(f"--algo must be one of {', '.join(ALGOS)}, got {self.algo!r}")
        if self.task not in TASKS:
            raise InputError(f"--task must be one of {', '.join(TASKS)}, got {self.task!r}")
        for name in ("steps", "envs", "rollout_steps"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise InputError(f"--{name.replace('_', '-')} must be an integer >= 1, got "
                             f"{value!r}")
        least = self.envs * (MIN_ROLLOUT if self.algo == "ppo" else 1)
        if self.steps < least:
            raise InputError(f"--steps {self.steps} is less than one update's env steps "
                             f"({least} with --envs {self.envs})")
        if self.rollout_steps != ROLLOUT_STEPS:
            if self.algo != "ppo":
                raise InputError(f"--rollout-steps {self.rollout_steps}: PPO's rollout; "
                                 f"--algo {self.algo} has none")
            if self.rollout_steps < least:
                raise InputError(f"--rollout-steps must be at least {MIN_ROLLOUT} per robot "
                                 f"({least} with --envs {self.envs}), got {self.rollout_steps}")
        if self.cable_law not in CABLE_LAWS:
            raise InputError(f"--cable-law must be one of {', '.join(CABLE_LAWS)}, got "
                             f"{self.cable_law!r}")
        if self.frame not in FRAMES:
            raise InputError(f"--frame must be one of {', '.join(FRAMES)}, got {self.frame!r}")
        if self.randomization not in RANDOMIZATIONS:
            raise InputError(f"--randomize must be one of {', '.join(RANDOMIZATIONS)}, got "
                             f"{self.randomization!r}")
        if not (math.isfinite(self.timestep) and self.timestep > 0):
            raise InputError(f"--dt must be a physics step > 0 [s], got {self.timestep}")
        for name in ("roll_reward", "slip_cost"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise InputError(f"--{name.replace('_', '-')} must be a finite number >= 0, "
                                 f"got {value!r}")
        if self.roll_reward and self.task != "roll":
            raise InputError(f"--roll-reward rewards rolling along the heading: it needs "
                             f"--task roll, got --task {self.task}")
        if not math.isfinite(self.heading_deg):
            raise InputError(f"--heading must be a finite angle [deg], got {self.heading_deg}")

    def env_config(self, episode_s: float | None = None,
                   randomization: Randomization | None = None) -> EnvConfig:
        """The environment it trains in (``episode_s`` overrides the episode length,
        ``randomization`` the training's randomisation)."""
        h = math.radians(self.heading_deg)
        heading = (round(math.cos(h), 12), round(math.sin(h), 12))
        return EnvConfig(model=self.model, task=TASKS[self.task], direction=heading,
                         goal_m=(self.goal_m * heading[0], self.goal_m * heading[1]),
                         control_dt=self.control_dt,
                         episode_s=self.episode_s if episode_s is None else episode_s,
                         observation=ROLLING_OBSERVATION, frame=self.frame,
                         rest_span=self.rest_span, bar_contact_cost=self.bar_contact_cost,
                         roll_reward=self.roll_reward, slip_cost=self.slip_cost,
                         randomization=randomization or RANDOMIZATIONS[self.randomization](),
                         world=WorldOptions(timestep=self.timestep, cable_law=self.cable_law),
                         action=self.action)


ROBOT_FILE = "robot.yaml"  # a structure file's copy in the run folder


def fingerprint(settings: TrainSettings) -> str:
    """A hash of the settings, with a robot file's contents in place of its path (a preset:
    its name); ``steps`` is left out, so a resumed run may train longer, and so is the
    default randomisation, reward terms that are off, the default rollout and the default
    actions, so runs from before they were settings keep their fingerprint."""
    record = dataclasses.asdict(settings) | {"steps": 0}
    if record["randomization"] == "start":
        del record["randomization"]
    for name in ("roll_reward", "slip_cost"):
        if not record[name]:
            del record[name]
    if record["rollout_steps"] == ROLLOUT_STEPS:
        del record["rollout_steps"]
    if record["action"] == "auto":
        del record["action"]
    if settings.model not in PRESETS:
        record["model"] = hashlib.sha256(Path(settings.model).read_bytes()).hexdigest()
    return hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest()[:16]


def load_settings(folder: Path) -> TrainSettings:
    """The settings of the run in ``folder``.

    Raises:
        InputError: ``folder`` holds no training run.
    """
    path = Path(folder) / "settings.json"
    if not path.is_file():
        raise InputError(f"{folder}: no training run here (no settings.json); train one with "
                         "`tensim rl train`")
    data = json.loads(path.read_text())
    if data["model"] not in PRESETS:  # the copy of the robot file it trained on
        data["model"] = str(Path(folder) / ROBOT_FILE)
    return TrainSettings(**{k: v for k, v in data.items() if k != "fingerprint"})


def train(settings: TrainSettings, out: Path, *, resume: bool = False,
          checkpoint_steps: int = 10_000, init: Path | None = None,
          init_std: float | None = None, init_lr: float | None = None,
          init_warmup: int | None = None, keep: bool = False,
          progress: Callable[[float, float], None] | None = None) -> dict[str, Any]:
    """Trains (or resumes training) and returns the progress record.

    Args:
        settings: what to learn.
        out: the run folder.
        resume: continue the run in ``out`` (its settings and robot file must be the same,
            ``steps`` may grow).
        checkpoint_steps: env steps between checkpoints.
        init: a new PPO run starts from this exported policy (``policy.json`` of ``tensim rl
            export``) rather than from random weights: its actor and observation normaliser
            (the value function learns afresh, alone for its first :data:`VALUE_WARMUP`
            updates); the progress record keeps its budget under ``init``.
        init_std: with ``init``, the PPO action noise's standard deviation to start from
            (in the [-1, 1] action box; default that of :func:`ppo_recipe`, 0.61): an
            exported policy carries no noise, and a smaller one fine-tunes it more gently.
        init_lr: with ``init``, PPO's learning rate (default that of :func:`ppo_recipe`,
            3e-4).
        init_warmup: with ``init``, the PPO updates in which the value function learns alone
            (default :data:`VALUE_WARMUP`).
        keep: also export every checkpoint's policy (``policy.json`` and ``policy.npz``) to
            ``out/checkpoints/STEPS/``, so a checkpoint can be chosen after the run.
        progress: called with (env steps done, steps in all).

    Raises:
        InputError: ``out`` already holds a run and ``resume`` is False, a resumed run's
            settings or robot file changed, or ``init`` does not fit the run, or
            ``init_std``, ``init_lr`` or ``init_warmup`` is given without ``init`` or is not
            > 0 (``init_warmup``: an integer >= 0).
    """
    out = Path(out)
    tuning = _fine_tuning(init, init_std, init_lr, init_warmup)
    start_policy = _start_policy(settings, init) if init is not None else None
    state = _open(settings, out, resume)
    if start_policy is not None and state["steps_done"]:
        raise InputError(f"--init {init}: --out {out} has trained already; --init starts a "
                         "new run only")
    learner, env = _learner(settings, out, state)
    if start_policy is not None:
        state["init"] = _warm_start(learner, env, start_policy, Path(init or ""), init_std)
        state["init"] |= tuning
        if init_lr is not None:
            from stable_baselines3.common.utils import FloatSchedule

            learner.learning_rate, learner.lr_schedule = init_lr, FloatSchedule(init_lr)
    done = int(state["steps_done"])
    start = time.process_time() - float(state.get("cpu_s", 0.0))
    curve = _Curve(state["curve"])
    # PPO collects whole rollouts, SAC one env step of every robot at a time: the run stops
    # at the last whole one within ``steps``, so it never trains past its budget
    whole = learner.n_steps * settings.envs if settings.algo == "ppo" else settings.envs
    warmup = int(state["init"].get("value_warmup_updates", VALUE_WARMUP)) * whole \
        if "init" in state else 0
    while settings.steps - done >= whole:
        chunk = max(whole, min(checkpoint_steps, settings.steps - done) // whole * whole)
        if done < warmup:  # the actor waits while the new value function learns
            chunk = min(chunk, warmup - done)
        _train_actor(learner, done >= warmup)
        learner.learn(chunk, reset_num_timesteps=False, callback=curve.callback())
        done = int(learner.num_timesteps)
        state.update(steps_done=done, curve=curve.points, cpu_s=time.process_time() - start)
        _checkpoint(learner, env, out, state, settings)
        if keep:
            from tensim.rl.export import export

            export(out, where=out / "checkpoints" / str(done))
        if progress is not None:
            progress(done, settings.steps)
    env.close()
    _draw_curve(out, state["curve"], settings)
    return state


def _fine_tuning(init: Path | None, std: float | None, lr: float | None,
                 warmup: int | None) -> dict[str, Any]:
    """The record of a warm start's own settings (those given).

    Raises:
        InputError: one is given without ``init``, or is out of range.
    """
    given = {"--init-std": std, "--init-lr": lr, "--init-warmup": warmup}
    for name, value in given.items():
        if value is None:
            continue
        if init is None:
            raise InputError(f"{name} {value}: applies only to a run started with --init")
        if name == "--init-warmup":
            if not (isinstance(value, int) and value >= 0):
                raise InputError(f"{name} must be an integer >= 0 (PPO updates), got {value!r}")
        elif not (math.isfinite(value) and value > 0):
            raise InputError(f"{name} must be a number > 0, got {value!r}")
    return ({} if lr is None else {"learning_rate": lr}) | \
        ({} if warmup is None else {"value_warmup_updates": warmup})


def _start_policy(settings: TrainSettings, source: Path) -> Any:
    """The exported policy ``source`` a new run of ``settings`` starts from.

    Raises:
        InputError: not an exported policy, not PPO's, or trained on another robot, task,
            observation or action.
    """
    from tensim.rl._robot import Robot
    from tensim.rl.policy import load

    try:
        policy = load(source)
    except (ValueError, KeyError, OSError) as err:
        raise InputError(f"--init {source}: not an exported policy ({err})") from err
    robot = Robot(settings.env_config())
    # (a robot file is known by its observation and actions: its copies go by other names)
    preset = {settings.model, policy.meta.get("model")} & set(PRESETS)
    mine = {"algo": settings.algo, "model": settings.model if preset else "a file",
            "task": settings.task, "observation": int(robot.observation_space.shape[0]),
            "actions": int(robot.action_space.shape[0])}
    theirs = {"algo": policy.meta.get("algo"), "model": policy.meta.get("model")
              if preset else "a file", "task": policy.meta.get("task"),
              "observation": policy.meta["observation"]["size"],
              "actions": len(policy.meta["action"]["cables"])}
    differ = [k for k in mine if mine[k] != theirs[k]]
    if settings.algo != "ppo" or differ:
        raise InputError(f"--init {source}: a PPO run starts only from a PPO policy of the "
                         f"same robot, task, observation and actions (differ: "
                         f"{', '.join(differ) or 'algo'}; this run {mine}, the policy {theirs})")
    return policy


def _warm_start(learner: Any, env: Any, policy: Any, source: Path,
                std: float | None = None) -> dict[str, Any]:
    """Copies the exported ``policy``'s actor layers and observation normaliser into a new
    PPO ``learner`` and its ``env`` (and sets its action noise to ``std``, if given);
    returns the record of where it came from.

    Raises:
        InputError: the network's layers differ.
    """
    import torch

    from tensim.rl.export import _layers

    linears, activations, _ = _layers(learner)
    shapes = [list(layer.weight.shape) for layer in linears]
    if shapes != policy.meta["network"]["layers"] or activations != policy.activations:
        raise InputError(f"--init {source}: its network ({policy.meta['network']['layers']}, "
                         f"{policy.activations}) is not this run's ({shapes}, {activations})")
    with torch.no_grad():
        for layer, w, b in zip(linears, policy.weights, policy.biases, strict=True):
            layer.weight.copy_(torch.as_tensor(w, dtype=layer.weight.dtype))
            layer.bias.copy_(torch.as_tensor(b, dtype=layer.bias.dtype))
        if std is not None:
            learner.policy.log_std.fill_(math.log(std))
    trained = policy.meta.get("training") or {}
    env.obs_rms.mean, env.obs_rms.var = policy.mean.copy(), policy.var.copy()
    env.obs_rms.count = float(max(1, trained.get("env_steps", 1)))
    return {"policy": source.name, "env_steps": int(trained.get("env_steps", 0)),
            "cpu_s": float(trained.get("cpu_s", 0.0))} | ({} if std is None else
                                                          {"action_std": std})


def _train_actor(learner: Any, on: bool) -> None:
    """Lets PPO's optimiser change the actor (its layers and action noise) or not."""
    if not hasattr(learner.policy, "action_net"):  # SAC: nothing held back
        return
    policy = learner.policy
    actor = [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters(),
             policy.log_std]
    for parameter in actor:
        parameter.requires_grad_(on)


def _open(settings: TrainSettings, out: Path, resume: bool) -> dict[str, Any]:
    print_ = fingerprint(settings)
    progress_file = out / "progress.json"
    if progress_file.is_file():
        if not resume:
            raise InputError(f"--out {out} already holds a training run: add --resume to "
                             "continue it, or choose another --out")
        old = json.loads((out / "settings.json").read_text())
        if old.get("fingerprint") != print_:
            old["model"] = settings.model if old["model"] not in PRESETS else old["model"]
            raise InputError(f"--out {out}: its run was trained with other settings or another "
                             f"robot file ({_differences(old, settings)}); --resume continues "
                             "only the same run (--steps may grow)")
        if old["steps"] != settings.steps:  # the settings record the steps trained to
            write_json(out / "settings.json", old | {"steps": settings.steps})
        state: dict[str, Any] = json.loads(progress_file.read_text())
        return state
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise InputError(f"--out {out}: not an empty folder and holds no training run")
    out.mkdir(parents=True, exist_ok=True)
    if settings.model not in PRESETS:
        with atomic_path(out / ROBOT_FILE) as tmp:
            tmp.write_bytes(Path(settings.model).read_bytes())
    write_json(out / "settings.json", dataclasses.asdict(settings) | {"fingerprint": print_})
    return {"steps_done": 0, "curve": [], "cpu_s": 0.0}


def _differences(old: dict[str, Any], settings: TrainSettings) -> str:
    new = dataclasses.asdict(settings)
    changed = [k for k in new if k != "steps" and old.get(k) != new[k]]
    return "changed: " + ", ".join(changed) if changed else "the robot file changed"


def _learner(settings: TrainSettings, out: Path, state: dict[str, Any]) -> Any:
    import stable_baselines3 as sb3
    import torch
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from tensim.rl.sb3 import SB3VecEnv

    torch.set_num_threads(1)  # small networks: one thread is fastest, and leaves the rest free

    venv = SB3VecEnv(settings.envs, settings.env_config())
    venv.seed(settings.seed)
    env: Any = VecNormalize(VecMonitor(venv, info_keywords=("reward_progress",)),
                       norm_obs=True, norm_reward=settings.algo == "ppo",
                       clip_obs=CLIP_OBS, epsilon=EPSILON)
    algo: Any = {"ppo": sb3.PPO, "sac": sb3.SAC}[settings.algo]
    if state["steps_done"]:
        with np.load(out / "normalizer.npz") as saved:
            env.obs_rms.mean, env.obs_rms.var = saved["mean"], saved["var"]
            env.obs_rms.count = float(saved["count"])
            env.ret_rms.mean, env.ret_rms.var = saved["ret_mean"], saved["ret_var"]
            env.ret_rms.count = float(saved["ret_count"])
        learner = algo.load(out / "policy.zip", env=env, device="cpu")
        if settings.algo == "sac" and (out / "replay_buffer.npz").is_file():
            _load_replay(learner.replay_buffer, out / "replay_buffer.npz")
        return learner, env
    kwargs = ppo_recipe(settings.envs, settings.steps, settings.rollout_steps) \
        if settings.algo == "ppo" else {"learning_starts": min(1000, settings.steps // 2)}
    return algo("MlpPolicy", env, seed=settings.seed, device="cpu", verbose=0, **kwargs), env




def ppo_recipe(envs: int, steps: int, rollout_steps: int = ROLLOUT_STEPS) -> dict[str, Any]:
    """PPO's settings for ``envs`` robots and a budget of ``steps`` env steps: a rollout of
    about ``rollout_steps`` env steps per update (default :data:`ROLLOUT_STEPS`; at most the
    budget), ten epochs of minibatches of a quarter of it, Adam at 3e-4, gamma 0.99, GAE
    0.95 and an initial action std of exp(-0.5) = 0.61 in the [-1, 1] action box."""
    n_steps = max(MIN_ROLLOUT, min(rollout_steps, steps) // envs)
    return {"n_steps": n_steps, "batch_size": max(MIN_ROLLOUT, n_steps * envs // 4),
            "n_epochs": 10, "learning_rate": 3e-4, "gamma": 0.99, "gae_lambda": 0.95,
            "policy_kwargs": {"log_std_init": -0.5, "net_arch": [128, 128]}}


class _Curve:
    """The learning curve: (env steps, return) of every episode that ended, from SB3's
    episode records (``VecMonitor``)."""

    def __init__(self, points: list[list[float]]):
        self.points = [list(p) for p in points]

    def callback(self) -> Any:
        from stable_baselines3.common.callbacks import BaseCallback

        curve = self

        class _Record(BaseCallback):
            def _on_step(self) -> bool:
                curve.points += [[int(self.num_timesteps), float(info["episode"]["r"])]
                                 for info in self.locals.get("infos", []) if "episode" in info]
                return True

        return _Record()


def _checkpoint(learner: Any, env: Any, out: Path, state: dict[str, Any],
                settings: TrainSettings) -> None:
    """Writes the policy, normaliser and replay buffer, then the progress that names them."""
    with atomic_path(out / "policy.zip") as tmp:
        learner.save(tmp.with_suffix(".zip"))
        tmp.with_suffix(".zip").replace(tmp)
    rms, ret = env.obs_rms, env.ret_rms
    with atomic_path(out / "normalizer.npz") as tmp, open(tmp, "wb") as f:
        np.savez(f, mean=rms.mean, var=rms.var, count=rms.count, ret_mean=ret.mean,
                 ret_var=ret.var, ret_count=ret.count, clip=CLIP_OBS, epsilon=EPSILON)
    if settings.algo == "sac":
        _save_replay(learner.replay_buffer, out / "replay_buffer.npz")
    write_json(out / "progress.json", state)


# the arrays of SB3's replay buffer, kept as data (SB3's own save_replay_buffer pickles it)
_REPLAY = ("observations", "next_observations", "actions", "rewards", "dones", "timeouts")


def _save_replay(buffer: Any, path: Path) -> None:
    """Writes a replay buffer's arrays and fill state to ``path`` (.npz, atomically)."""
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez(f, pos=buffer.pos, full=buffer.full,
                 **{name: getattr(buffer, name) for name in _REPLAY
                    if getattr(buffer, name, None) is not None})


def _load_replay(buffer: Any, path: Path) -> None:
    """Restores a replay buffer written by :func:`_checkpoint` (no pickle involved)."""
    with np.load(path, allow_pickle=False) as saved:
        for name in _REPLAY:
            if name in saved:
                getattr(buffer, name)[...] = saved[name]
        buffer.pos, buffer.full = int(saved["pos"]), bool(saved["full"])


def _draw_curve(out: Path, points: list[list[float]], settings: TrainSettings) -> None:
    from tensim.viz.plots import new_figure, save_figure

    fig = new_figure((6.0, 3.5))
    ax = fig.add_subplot()
    if points:
        steps, returns = np.array(points).T
        ax.plot(steps, returns, ".", ms=2, alpha=0.4, label="episodes")
        window = max(1, len(returns) // 20)
        smooth = np.convolve(returns, np.ones(window) / window, mode="valid")
        ax.plot(steps[window - 1:], smooth, label=f"mean of {window}")
        ax.legend()
    unit = "m" if settings.task != "turn" else "rad - m"
    ax.set(xlabel="env steps", ylabel=f"episode return [{unit}]",
           title=f"{settings.algo.upper()} on {Path(settings.model).stem}: {settings.task}")
    fig.tight_layout()
    save_figure(fig, out / "learning_curve.png")
