"""A learnt policy as NumPy arrays: what a robot's computer runs (NumPy only).

``tensim rl export DIR --onnx policy.onnx`` writes ``policy.onnx``, ``policy.npz`` (the same
network's weights) and ``policy.json`` (the observation layout, the normalisation, the
action's cables and units) side by side. This module needs nothing but NumPy and the
standard library, so it can be copied alone onto a robot::

    from tensim.rl import policy
    act = policy.load("policy.json")
    action = act(observation)          # (n_motors,) in [-1, 1]
    command = act.command(action)      # V* [m/s] or rest lengths [m], per motorised cable
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np


def _relu(x: np.ndarray) -> np.ndarray:
    return np.maximum(x, 0.0)


ACTIVATIONS: dict[str, Callable[[np.ndarray], np.ndarray]] = {"tanh": np.tanh, "relu": _relu}


def normalized(obs: np.ndarray, mean: np.ndarray, var: np.ndarray, clip: float,
               epsilon: float) -> np.ndarray:
    """Observations as a policy's network sees them: clip((obs - mean) / sqrt(var + epsilon),
    -clip, clip) (PPO's ``VecNormalize``)."""
    return np.clip((obs - mean) / np.sqrt(var + epsilon), -clip, clip)


class Policy:
    """A deterministic multilayer perceptron with the observation normaliser in front.

    action = out(W_k ... act(W_1 clip((obs - mean) / sqrt(var + eps), -clip, clip) + b_1) ...)
    with ``out`` tanh (SAC) or a clip to [-1, 1] (PPO).

    Attributes:
        meta: the ``policy.json`` record (layout, normalisation, action).
        weights, biases: per layer, (out, in) and (out,) arrays.
        activations: per hidden layer, a name of :data:`ACTIVATIONS`.
    """

    def __init__(self, meta: dict[str, Any], weights: list[np.ndarray], biases: list[np.ndarray]):
        self.meta, self.weights, self.biases = meta, weights, biases
        norm = meta["normalization"]
        self.mean, self.var = np.asarray(norm["mean"]), np.asarray(norm["var"])
        self.clip, self.epsilon = float(norm["clip"]), float(norm["epsilon"])
        self.activations = list(meta["network"]["activations"])
        self.squash = meta["network"]["output"]

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        """(..., n_obs) observations as the network sees them."""
        return normalized(obs, self.mean, self.var, self.clip, self.epsilon)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """(..., n_motors) actions in [-1, 1] for (..., n_obs) observations."""
        x = self.normalize(np.asarray(obs, dtype=np.float64))
        for k, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            x = x @ w.T + b
            if k < len(self.activations):
                x = ACTIVATIONS[self.activations[k]](x)
        return np.tanh(x) if self.squash == "tanh" else np.clip(x, -1.0, 1.0)

    def command(self, action: np.ndarray) -> np.ndarray:
        """Actions in [-1, 1] -> each motorised cable's command: V* [m/s] or rest length [m]."""
        a = self.meta["action"]
        if a["kind"] == "vstar":
            return np.asarray(action) * np.asarray(a["max_speed_m_per_s"])
        rest = np.asarray(a["build_rest_length_m"])
        return np.clip(rest * (1.0 + np.asarray(action) * a["rest_span"]),
                       a["low"], a["high"])


def load(path: str | Path) -> Policy:
    """The policy of an exported ``policy.json`` (its weights from the ``policy.npz`` beside
    it), or of an export folder holding both.

    Raises:
        FileNotFoundError: no such file.
        ValueError: a file that is not a tensim policy.
    """
    path = Path(path)
    if path.is_dir():
        path = path / "policy.json"
    meta = json.loads(path.read_text())
    if meta.get("format") != "tensim-policy":
        raise ValueError(f"{path}: not a tensim policy (format {meta.get('format')!r})")
    with np.load(path.parent / meta["network"]["weights"], allow_pickle=False) as saved:
        return from_arrays(meta, {name: saved[name] for name in saved.files})


def from_arrays(meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> Policy:
    """The policy of a ``policy.json`` record and its ``policy.npz`` arrays (``w0``, ``b0``,
    ... per layer, as ``meta["network"]["layers"]`` counts them), in float64."""
    n = len(meta["network"]["layers"])
    return Policy(meta, [np.asarray(arrays[f"w{k}"], dtype=np.float64) for k in range(n)],
                  [np.asarray(arrays[f"b{k}"], dtype=np.float64) for k in range(n)])
