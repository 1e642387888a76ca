"""Imitation of the statics rolling gait: a policy network learnt by DAgger (Ross, Gordon and
Bagnell 2011) from the gait's actions (:mod:`tensim.rl.expert`), written as an exported
policy that ``tensim rl evaluate`` runs and ``tensim rl train --init`` fine-tunes with PPO
(``tensim rl imitate``).

Iteration 0 lets the expert drive (its actions with Gaussian noise of ``noise``, as DART
does, so the data hold states a little off its path and the actions that lead back); every
later iteration lets the policy learnt so far drive (with probability ``beta`` the expert's
action instead, per control period) while a shadow expert labels each state it visits. The
labelled states of all iterations are pooled and the network (PPO's actor: 2 x 128 tanh, its
output clipped to [-1, 1]) is fitted to them by least squares, with the observation
normaliser (the pooled states' mean and variance) in front, as PPO's ``VecNormalize`` has it.

A run folder holds ``settings.json``, ``data.npz`` (the labelled states), ``policy.json`` and
``policy.npz`` (the latest policy; each iteration's also in ``iterations/N/``, to choose
one after the run), ``network.npz`` (its weights in float64) and ``record.json`` (per
iteration: who drove, their speed in body lengths/s, the imitation loss); it resumes at the
next iteration, as if it had not stopped.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tensim._files import atomic_path, write_json
from tensim._input import InputError
from tensim.rl.policy import Policy, from_arrays, normalized
from tensim.rl.train import CLIP_OBS, EPSILON, TrainSettings
from tensim.structure import body_length

HIDDEN = (128, 128)  # PPO's actor (tensim.rl.train.ppo_recipe's net_arch), tanh
BATCH = 256  # samples per gradient step
EPISODE_SEEDS = 1_000_000  # each run's episodes draw their starts from seed * this + k


@dataclasses.dataclass(frozen=True)
class ImitationSettings:
    """How the gait is imitated.

    Attributes:
        iterations: DAgger iterations (the first with the expert driving).
        episodes: episodes per iteration.
        noise: std of the Gaussian noise on the expert's actions while it drives, in the
            [-1, 1] action box (DART; 0: none).
        beta: after the first iteration, the chance per control period that the expert's
            action drives instead of the policy's (0: the policy alone).
        epochs: passes over the pooled data per fit.
        learning_rate: Adam's step size.
    """

    iterations: int = 4
    episodes: int = 16
    noise: float = 0.1
    beta: float = 0.0
    epochs: int = 30
    learning_rate: float = 1e-3

    def __post_init__(self) -> None:
        for name in ("iterations", "episodes", "epochs"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise InputError(f"--{name} must be an integer >= 1, got {value!r}")
        if not (math.isfinite(self.noise) and self.noise >= 0):
            raise InputError(f"--noise must be a number >= 0, got {self.noise!r}")
        if not (math.isfinite(self.beta) and 0 <= self.beta <= 1):
            raise InputError(f"--beta must be a probability in [0, 1], got {self.beta!r}")
        if not (math.isfinite(self.learning_rate) and self.learning_rate > 0):
            raise InputError(f"--learning-rate must be > 0, got {self.learning_rate!r}")


Control = Callable[[np.ndarray, np.ndarray], np.ndarray]  # (observation, expert's) -> action


def episode(env: Any, expert: Any, seed: int, control: Control | None = None
            ) -> dict[str, Any]:
    """One episode of ``env`` (a :class:`~tensim.rl.TensegrityEnv`) from the start ``seed``
    draws, the expert labelling every state.

    Args:
        env: the environment.
        expert: its :class:`~tensim.rl.expert.Expert`.
        seed: the start's seed.
        control: the action that drives, from the observation and the expert's action
            (None: the expert's).

    Returns:
        ``observations`` (T, n_obs), ``labels`` (T, n_motors) the expert's actions,
        ``actions`` (T, n_motors) those that drove, ``body_lengths_per_s`` (the centre of
        mass's displacement along the heading over the episode, from MjData, per body
        length) and ``unstable``.
    """
    obs, _ = env.reset(seed=seed)
    worlds = env.worlds
    expert.start(worlds, 0)
    start = worlds.f["subtree_com"][0, 0, :2].copy()
    observations, labels, actions, unstable = [], [], [], False
    config = env.robot.config
    for _ in range(config.max_steps):
        label = expert.act(worlds, 0)
        action = label if control is None else control(obs, label)
        observations.append(obs)
        labels.append(label)
        actions.append(action)
        obs, _, terminated, _, info = env.step(np.asarray(action, dtype=np.float32))
        if terminated:
            unstable = bool(info["unstable"])
            break
    span = len(actions) * config.control_dt
    moved = worlds.f["subtree_com"][0, 0, :2] - start
    speed = float(moved @ worlds.target[0]) / span / body_length(env.robot.compiled.structure)
    return {"observations": np.array(observations), "labels": np.array(labels),
            "actions": np.array(actions), "body_lengths_per_s": speed, "unstable": unstable}


def network(n_obs: int, n_actions: int, seed: int) -> Any:
    """PPO's actor network (2 x 128, tanh), its weights drawn from ``seed``."""
    import torch

    torch.manual_seed(seed)
    sizes = (n_obs, *HIDDEN)
    layers: list[Any] = []
    for a, b in itertools.pairwise(sizes):
        layers += [torch.nn.Linear(a, b), torch.nn.Tanh()]
    return torch.nn.Sequential(*layers, torch.nn.Linear(sizes[-1], n_actions)).double()


def normalization(observations: np.ndarray) -> dict[str, Any]:
    """The observation normaliser of ``observations`` (N, n_obs): their mean and variance
    (as :class:`~tensim.rl.policy.Policy` and PPO's ``VecNormalize`` use them)."""
    return {"mean": observations.mean(axis=0).tolist(), "var": observations.var(axis=0).tolist(),
            "clip": CLIP_OBS, "epsilon": EPSILON}


def fit(net: Any, inputs: np.ndarray, targets: np.ndarray, epochs: int, learning_rate: float,
        seed: int) -> float:
    """Fits ``net`` to map ``inputs`` (N, n_in, normalised) to ``targets`` (N, n_out) by
    least squares (Adam on minibatches of :data:`BATCH`); returns the mean squared error over
    the data after the fit (per action component)."""
    import torch

    x = torch.as_tensor(inputs, dtype=torch.float64)
    y = torch.as_tensor(targets, dtype=torch.float64)
    optimizer = torch.optim.Adam(net.parameters(), lr=learning_rate)
    generator = torch.Generator().manual_seed(seed)
    for _ in range(epochs):
        for batch in torch.randperm(len(x), generator=generator).split(BATCH):
            optimizer.zero_grad()
            loss = torch.mean((net(x[batch]) - y[batch]) ** 2)
            loss.backward()
            optimizer.step()
    with torch.no_grad():
        return float(torch.mean((net(x) - y) ** 2))


def _linears(net: Any) -> list[Any]:
    """The network's torch Linear layers, in order."""
    import torch

    return [m for m in net if isinstance(m, torch.nn.Linear)]


def load_into(net: Any, arrays: dict[str, np.ndarray]) -> None:
    """Sets ``net``'s layers to ``arrays`` (``policy.npz``'s layout: ``w0``, ``b0``, ...)."""
    import torch

    with torch.no_grad():
        for k, layer in enumerate(_linears(net)):
            layer.weight.copy_(torch.as_tensor(arrays[f"w{k}"], dtype=torch.float64))
            layer.bias.copy_(torch.as_tensor(arrays[f"b{k}"], dtype=torch.float64))


def imitate(settings: TrainSettings, imitation: ImitationSettings, out: Path, *,
            resume: bool = False,
            progress: Callable[[dict[str, Any]], None] | None = None) -> dict[str, Any]:
    """Learns a policy that imitates the statics rolling gait by DAgger in the env of
    ``settings`` (its ``seed`` seeds the starts, the network and the noise), writing the run
    folder ``out`` after every iteration.

    Args:
        settings: the env and the policy's record (``algo`` must be ``"ppo"``: the network
            is PPO's actor, so that ``tensim rl train --init`` continues it).
        imitation: iterations, episodes, noise and the fit.
        out: the run folder.
        resume: continue the run in ``out`` at its next iteration (same settings;
            ``iterations`` may grow).
        progress: called with each iteration's record.

    Returns:
        The record: ``iterations`` (each: ``iteration``, ``driver``, ``episodes``, the mean
        and spread of the driven episodes' ``body_lengths_per_s``, ``unstable_episodes``,
        ``expert_agreement_mse`` (the mean squared difference between the actions that
        drove and the expert's labels), ``fit_mse``, ``samples`` pooled, ``env_steps`` and
        ``cpu_s`` so far), ``env_steps`` and ``cpu_s`` in all.

    Raises:
        InputError: the gait does not apply (:func:`tensim.rl.expert.check_rolling`),
            ``settings.algo`` is not PPO, or ``out`` holds another run (or any run, without
            ``resume``).
    """
    from tensim.rl._robot import Robot
    from tensim.rl.env import TensegrityEnv
    from tensim.rl.expert import Expert, check_rolling

    if settings.algo != "ppo":
        raise InputError(f"--algo {settings.algo}: an imitated policy is PPO's actor (so "
                         "`tensim rl train --init` fine-tunes it with PPO); use --algo ppo")
    check_rolling(Robot(settings.env_config()))
    import torch

    torch.set_num_threads(1)  # a small network: one thread is fastest, and leaves the rest free
    out = Path(out)
    record, data = _open(settings, imitation, out, resume)
    env = TensegrityEnv(settings.env_config())
    expert = Expert(env.robot)
    net = network(env.robot.observation_space.shape[0], env.robot.motors.size, settings.seed)
    policy: Policy | None = None
    if record["iterations"]:  # the fit's own float64 weights, so a resumed run is the same
        load_into(net, _arrays(out / NETWORK))
        policy = from_arrays(json.loads((out / "policy.json").read_text()),
                             _arrays(out / "policy.npz"))
    start_cpu = time.process_time() - record["cpu_s"]
    for it in range(len(record["iterations"]), imitation.iterations):
        control = _driver(policy, imitation, np.random.default_rng([settings.seed, it]), it)
        runs = [episode(env, expert, settings.seed * EPISODE_SEEDS + it * imitation.episodes
                        + k, control) for k in range(imitation.episodes)]
        data = _pooled(data, runs)
        norm = normalization(data["observations"])
        loss = fit(net, _normalized(data["observations"], norm), data["labels"],
                   imitation.epochs, imitation.learning_rate, settings.seed * 1000 + it)
        record["env_steps"] += sum(len(r["labels"]) for r in runs)
        record["cpu_s"] = round(time.process_time() - start_cpu, 1)
        record["iterations"].append(_row(it, runs, loss, data, record))
        policy = _write_iteration(out, settings, imitation, net, norm, data, record)
        if progress is not None:
            progress(record["iterations"][-1])
    env.close()
    return record


NETWORK = "network.npz"  # the fitted network's float64 weights (policy.npz holds float32)


def _pooled(data: dict[str, np.ndarray], runs: list[dict[str, Any]]
            ) -> dict[str, np.ndarray]:
    """The labelled states so far with those of ``runs``."""
    new = {k: np.concatenate([r[k] for r in runs]) for k in ("observations", "labels")}
    if not data["labels"].size:
        return new
    return {k: np.concatenate([data[k], new[k]]) for k in new}


def _row(it: int, runs: list[dict[str, Any]], loss: float, data: dict[str, np.ndarray],
         record: dict[str, Any]) -> dict[str, Any]:
    """Iteration ``it``'s entry of the learning record."""
    speeds = [r["body_lengths_per_s"] for r in runs]
    driven = np.concatenate([r["actions"] for r in runs])
    labels = np.concatenate([r["labels"] for r in runs])
    return {"iteration": it, "driver": "expert" if it == 0 else "policy",
            "episodes": len(runs), "body_lengths_per_s": round(float(np.mean(speeds)), 4),
            "body_lengths_per_s_std": round(float(np.std(speeds, ddof=1)), 4)
            if len(speeds) > 1 else 0.0,
            "unstable_episodes": sum(bool(r["unstable"]) for r in runs),
            "expert_agreement_mse": round(float(np.mean((driven - labels) ** 2)), 6),
            "fit_mse": round(loss, 6), "samples": int(data["labels"].shape[0]),
            "env_steps": record["env_steps"], "cpu_s": record["cpu_s"]}


def _write_iteration(out: Path, settings: TrainSettings, imitation: ImitationSettings,
                     net: Any, norm: dict[str, Any], data: dict[str, np.ndarray],
                     record: dict[str, Any]) -> Policy:
    """Writes the iteration's policy (into ``out`` and ``out/iterations/N``), the network's
    weights, the pooled data and, last (it names the iteration done), the record; returns
    the policy."""
    from tensim.rl.export import layer_arrays, policy_meta, write_policy

    done = len(record["iterations"])
    arrays = layer_arrays(_linears(net))
    training = {"env_steps": record["env_steps"], "cpu_s": record["cpu_s"],
                "imitation": {"expert": "statics rolling gait", "iterations": done}
                | _plain(imitation)}
    meta = policy_meta(settings, arrays, ["tanh"] * len(HIDDEN), "clip", norm, training)
    write_policy(out, meta, arrays)
    write_policy(out / "iterations" / str(done - 1), meta, arrays)
    weights = layer_arrays(_linears(net), np.float64)
    for name, arrays_out in ((NETWORK, weights), ("data.npz", data)):
        with atomic_path(out / name) as tmp, open(tmp, "wb") as f:
            np.savez(f, **arrays_out)  # type: ignore[arg-type]
    write_json(out / "record.json", record)
    return from_arrays(meta, arrays)


def _driver(policy: Policy | None, imitation: ImitationSettings, rng: np.random.Generator,
            iteration: int) -> Control | None:
    """Who drives iteration ``iteration``: the expert (with noise) first, then the policy
    (the expert with probability ``beta``)."""
    if iteration == 0 or policy is None:
        if imitation.noise <= 0:
            return None
        return lambda obs, label: np.clip(label + rng.normal(0.0, imitation.noise,
                                                             label.shape), -1.0, 1.0)
    learnt = policy

    def drive(obs: np.ndarray, label: np.ndarray) -> np.ndarray:
        if imitation.beta and rng.random() < imitation.beta:
            return label
        return learnt(obs)

    return drive


def _normalized(observations: np.ndarray, norm: dict[str, Any]) -> np.ndarray:
    """As :meth:`Policy.normalize` with the normaliser ``norm``."""
    return normalized(observations, np.asarray(norm["mean"]), np.asarray(norm["var"]),
                      norm["clip"], norm["epsilon"])


def _plain(imitation: ImitationSettings) -> dict[str, Any]:
    return {k: v for k, v in dataclasses.asdict(imitation).items() if k != "iterations"}


def _arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as saved:
        return {k: saved[k] for k in saved.files}


def _open(settings: TrainSettings, imitation: ImitationSettings, out: Path, resume: bool
          ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The record and the pooled data of the run in ``out`` (new: empty ones).

    Raises:
        InputError: ``out`` holds a run and not ``resume``, or one of other settings; or is
            neither empty nor a run.
    """
    from tensim.models import PRESETS

    mine = {"env": dataclasses.asdict(settings) | {"steps": 0},
            "imitation": _plain(imitation)}
    if settings.model not in PRESETS:
        mine["env"]["model"] = Path(settings.model).name
    if settings.action == "auto":  # as before it was a setting
        del mine["env"]["action"]
    if (out / "record.json").is_file():
        if not resume:
            raise InputError(f"--out {out} already holds an imitation run: add --resume to "
                             "continue it, or choose another --out")
        theirs = json.loads((out / "settings.json").read_text())
        if theirs != mine:
            changed = [f"{part}.{k}" for part in mine for k in mine[part]
                       if theirs.get(part, {}).get(k) != mine[part][k]]
            raise InputError(f"--out {out}: its run has other settings (changed: "
                             f"{', '.join(changed)}); --resume continues only the same run "
                             "(--iterations may grow)")
        return json.loads((out / "record.json").read_text()), _arrays(out / "data.npz")
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise InputError(f"--out {out}: not an empty folder and holds no imitation run")
    out.mkdir(parents=True, exist_ok=True)
    if settings.model not in PRESETS:  # the robot file, beside the policy (rl evaluate)
        with atomic_path(out / Path(settings.model).name) as tmp:
            tmp.write_bytes(Path(settings.model).read_bytes())
    write_json(out / "settings.json", mine)
    empty = {"observations": np.empty((0, 0)), "labels": np.empty((0, 0))}
    return {"iterations": [], "env_steps": 0, "cpu_s": 0.0}, empty
