"""Carrying a learnt policy to a robot: its network as NumPy arrays (``policy.npz``), ONNX
(``policy.onnx``) and a ``policy.json`` that says what goes in and what comes out."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from tensim._files import atomic_path, write_json
from tensim._input import InputError
from tensim.models import PRESETS
from tensim.rl.policy import Policy, from_arrays
from tensim.rl.train import TrainSettings, load_settings

FRAMES = {"robot": "robot frame: origin at the centre of mass, z up, x toward the first rigid "
                    "body (docs/rl.md)",
          "heading": "heading frame: origin at the centre of mass, z up, x along the heading "
                     "(toward the goal for the goal task) (docs/rl.md)"}


def load_learner(folder: Path) -> Any:
    """The Stable-Baselines3 model of the training run in ``folder``."""
    import stable_baselines3 as sb3

    settings = load_settings(folder)
    path = Path(folder) / "policy.zip"
    if not path.is_file():
        raise InputError(f"{folder}: the run has no policy yet (no policy.zip): let "
                         "`tensim rl train` reach its first checkpoint")
    algo: Any = {"ppo": sb3.PPO, "sac": sb3.SAC}[settings.algo]
    return algo.load(path, device="cpu")


def _layers(learner: Any) -> tuple[list[Any], list[str], str]:
    """The deterministic actor's torch Linear layers, hidden activations and output rule."""
    import torch

    policy = learner.policy
    if hasattr(policy, "actor") and hasattr(policy.actor, "mu"):  # SAC
        hidden, last, out = policy.actor.latent_pi, policy.actor.mu, "tanh"
    else:  # PPO (SB3's ActorCriticPolicy)
        hidden, last, out = policy.mlp_extractor.policy_net, policy.action_net, "clip"
    names = {torch.nn.Tanh: "tanh", torch.nn.ReLU: "relu"}
    linears = [m for m in hidden if isinstance(m, torch.nn.Linear)] + [last]
    activations = [names[type(m)] for m in hidden if not isinstance(m, torch.nn.Linear)]
    return linears, activations, out


def policy_record(folder: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The ``policy.json`` record and the ``policy.npz`` arrays of the run in ``folder``."""
    folder = Path(folder)
    settings = load_settings(folder)
    linears, activations, out = _layers(load_learner(folder))
    with np.load(folder / "normalizer.npz") as norm:
        normalization = {"mean": norm["mean"].tolist(), "var": norm["var"].tolist(),
                         "clip": float(norm["clip"]), "epsilon": float(norm["epsilon"])}
    arrays = layer_arrays(linears)
    progress = json.loads((folder / "progress.json").read_text())
    training = {"env_steps": int(progress["steps_done"]),
                "cpu_s": round(float(progress.get("cpu_s", 0.0)), 1)} \
        | ({"init": progress["init"]} if "init" in progress else {})
    return policy_meta(settings, arrays, activations, out, normalization, training), arrays


def layer_arrays(linears: list[Any], dtype: Any = np.float32) -> dict[str, np.ndarray]:
    """A network's torch Linear layers as ``policy.npz`` holds them: ``w0``, ``b0``, ...
    (float32 by default, as exported)."""
    arrays: dict[str, np.ndarray] = {}
    for k, layer in enumerate(linears):
        arrays[f"w{k}"] = layer.weight.detach().cpu().numpy().astype(dtype)
        arrays[f"b{k}"] = layer.bias.detach().cpu().numpy().astype(dtype)
    return arrays


def write_policy(where: Path, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
    """Writes ``policy.npz`` (the arrays) and then ``policy.json`` (the record that names
    them) into ``where``, each atomically."""
    where.mkdir(parents=True, exist_ok=True)
    with atomic_path(where / "policy.npz") as tmp, open(tmp, "wb") as f:
        np.savez(f, **arrays)  # type: ignore[arg-type]
    write_json(where / "policy.json", meta)


def policy_meta(settings: TrainSettings, arrays: dict[str, np.ndarray], activations: list[str],
                out: str, normalization: dict[str, Any], training: dict[str, Any]
                ) -> dict[str, Any]:
    """The ``policy.json`` record of a network (``arrays``: ``w0``, ``b0``, ... of its
    layers) trained in the env of ``settings``, with its observation ``normalization``
    (mean, var, clip, epsilon) and the record of its ``training``."""
    from tensim.rl._robot import Robot

    config = settings.env_config()
    robot = Robot(config)
    action: dict[str, Any] = {"kind": robot.action, "cables": list(robot.cables),
                              "range": [-1.0, 1.0], "low": robot.low.tolist(),
                              "high": robot.high.tolist()}
    if robot.action == "vstar":
        action["max_speed_m_per_s"] = robot.high.tolist()
    else:
        action["build_rest_length_m"] = robot.rest0[robot.motors].tolist()
        action["rest_span"] = config.rest_span
    trained = dataclasses.asdict(settings) | {"model": Path(settings.model).name
                                              if settings.model not in PRESETS else
                                              settings.model}
    if trained["action"] == "auto":  # as before it was a setting
        del trained["action"]
    return {
        "format": "tensim-policy", "version": 1, "model": settings.model,
        "settings": trained, "training": training,
        "algo": settings.algo, "task": settings.task, "heading_deg": settings.heading_deg,
        "control_dt_s": config.control_dt, "physics_step_s": config.world.timestep,
        "cable_law": config.world.cable_law,
        "observation": {"size": int(robot.observation_space.shape[0]),
                        "terms": {k: list(v) for k, v in robot.layout.items()},
                        "frame": FRAMES[config.frame]},
        "normalization": normalization,
        "network": {"weights": "policy.npz", "layers": [list(a.shape) for a in
                                                        arrays.values()][::2],
                    "activations": activations, "output": out,
                    "onnx_input": "the raw observation (normalisation inside)",
                    "onnx_output": "the action in [-1, 1]"},
        "action": action,
    }


def export(folder: Path, onnx: Path | None = None, where: Path | None = None
           ) -> dict[str, Any]:
    """Writes ``policy.json`` and ``policy.npz`` beside ``onnx`` (or into ``where``, by
    default ``folder``) and, with ``onnx``, the ONNX graph: raw observation in, action in
    [-1, 1] out. A robot file (not a preset) is copied beside them, so ``tensim rl evaluate
    policy.json`` runs.

    Returns:
        the ``policy.json`` record.
    """
    folder = Path(folder)
    exported = _exported(folder)
    meta, arrays = exported if exported is not None else policy_record(folder)
    where = Path(onnx).parent if onnx is not None else Path(where or folder)
    where.mkdir(parents=True, exist_ok=True)
    robot = meta["settings"]["model"]
    if robot not in PRESETS and (exported is None or where.resolve() != folder.resolve()):
        with atomic_path(where / robot) as tmp:  # the robot file, for `rl evaluate`
            shutil.copyfile(folder / robot if exported is not None else
                            load_settings(folder).model, tmp)
    if onnx is not None:
        meta["network"]["onnx"] = Path(onnx).name
        _write_onnx(from_arrays(meta, arrays), Path(onnx))
    write_policy(where, meta, arrays)
    return meta


def _exported(folder: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]] | None:
    """The record and arrays of a folder that holds a policy already exported but no
    training run (``tensim rl imitate``'s, or an export folder): None for a training run."""
    path = folder / "policy.json"
    if (folder / "policy.zip").is_file() or not path.is_file():
        return None
    meta = json.loads(path.read_text())
    if meta.get("format") != "tensim-policy":
        raise InputError(f"{path}: not a tensim policy (format {meta.get('format')!r})")
    meta["network"].pop("onnx", None)
    with np.load(folder / meta["network"]["weights"], allow_pickle=False) as saved:
        return meta, {name: saved[name] for name in saved.files}


def _write_onnx(policy: Policy, path: Path) -> None:
    import torch

    class _Net(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            f32 = torch.float32
            self.mean = torch.tensor(policy.mean, dtype=f32)
            self.scale = torch.tensor(1.0 / np.sqrt(policy.var + policy.epsilon), dtype=f32)
            self.w = [torch.tensor(w, dtype=f32) for w in policy.weights]
            self.b = [torch.tensor(b, dtype=f32) for b in policy.biases]

        def forward(self, obs: torch.Tensor) -> torch.Tensor:
            x = torch.clamp((obs - self.mean) * self.scale, -policy.clip, policy.clip)
            for k, (w, b) in enumerate(zip(self.w, self.b, strict=True)):
                x = x @ w.T + b
                if k < len(policy.activations):
                    x = torch.tanh(x) if policy.activations[k] == "tanh" else torch.relu(x)
            return torch.tanh(x) if policy.squash == "tanh" else torch.clamp(x, -1.0, 1.0)

    example = torch.zeros((1, policy.mean.size), dtype=torch.float32)
    with atomic_path(path) as tmp:
        torch.onnx.export(_Net(), (example,), str(tmp), input_names=["observation"],
                          output_names=["action"], dynamo=False,
                          dynamic_axes={"observation": {0: "batch"}, "action": {0: "batch"}})
