"""The robot an environment drives: compiled model, action mapping and observation layout."""

from __future__ import annotations

import logging
from typing import Any

import gymnasium as gym
import numpy as np

from tensim._input import InputError
from tensim.control import default_impedance
from tensim.design.check import Finding, check_structure
from tensim.model import CompiledModel, compile_structure
from tensim.models import PRESETS, load_model, preset
from tensim.rl.config import EnvConfig
from tensim.sim import MODE_IMPEDANCE, MODE_REST, CableDrive, Controller, Simulation
from tensim.structure import Structure

_log = logging.getLogger(__name__)

def load_robot(model: str) -> Structure:
    """A preset's structure, or a structure YAML file (:func:`tensim.models.load_model`)."""
    return load_model(model)


def default_controller(model: str, structure: Structure) -> Controller | None:
    """The impedance controller that sets the robot's law gains for ``vstar`` actions.

    A preset's own controller (None for a preset without one: its actions are rest lengths);
    for a structure file, the laws that hold its build pose (``default_impedance``), or None
    where it has no motorised cable it can give a law (e.g. only wrapped cables).
    """
    if model in PRESETS:
        return preset(model).controller()
    try:
        return default_impedance(structure)
    except ValueError:
        return None


class _Configure:
    """Sets the law's gains (from the controller) and every cable's mode for the actions."""

    def __init__(self, controller: Controller | None, mode: int):
        self.controller, self.mode = controller, mode

    def configure(self, setup: Any) -> None:
        if self.controller is not None:
            self.controller.configure(setup)
        setup.drive.mode[:] = self.mode


class Robot:
    """What every environment of one config shares.

    Attributes:
        config: the configuration.
        action: the resolved action kind (``"vstar"`` or ``"rest_length"``).
        compiled: the compiled robot.
        model: its MjModel with the controller's gains and the action's cable modes.
        initial_state: the settled build state (``mjSTATE_INTEGRATION``, after the motor
            update at t = 0).
        low, high: (n_cables,) the command box in SI units ([m/s] or [m]).
        action_space, observation_space: one robot's spaces.
    """

    def __init__(self, config: EnvConfig):
        self.config = config
        structure = load_robot(config.model)
        self.findings = _check(structure, config)
        self.compiled: CompiledModel = compile_structure(structure, config.world)
        controller = default_controller(config.model, structure)
        self.action = config.action
        if self.action == "auto":
            self.action = "vstar" if controller is not None else "rest_length"
        if self.action == "vstar" and controller is None:
            raise InputError(f"model {config.model!r} has no impedance controller, so V* "
                             "actions would do nothing: use action='rest_length'")
        mode = MODE_IMPEDANCE if self.action == "vstar" else MODE_REST
        with Simulation(self.compiled, controller=_Configure(controller, mode)) as sim:
            self.model = sim.model
            self.initial_state = sim.get_state()
            rest0 = sim.drive.rest.copy()
        drive = CableDrive(self.compiled, self.model)  # parameters read from the MjModel
        self.n = self.compiled.n_cables
        self.n_bodies = len(self.compiled.index.bodies)
        speed = drive.max_speed.astype(float).copy()
        if not (speed > 0).any():  # no cables, or (in a model edited by hand) no motor speed
            raise InputError(f"model {config.model!r}: no cable has a motor that moves, so "
                             "no action can change the robot")
        self.stiffness = drive.stiffness.copy()
        if self.action == "vstar":
            self.low, self.high = -speed, speed.copy()
        else:
            span = config.rest_span * rest0
            self.low = np.maximum(drive.min_rest, rest0 - span)
            self.high = rest0 + span
        self.rest0 = rest0
        if config.normalize_actions:
            self.action_space = gym.spaces.Box(-1.0, 1.0, (self.n,), dtype=np.float32)
        else:
            self.action_space = gym.spaces.Box(self.low.astype(np.float32),
                                               self.high.astype(np.float32), dtype=np.float32)
        self.layout = observation_layout(config.observation, self.n, self.n_bodies)
        size = sum(stop - start for start, stop in self.layout.values())
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (size,), dtype=np.float64)

    def command(self, action: np.ndarray) -> tuple[np.ndarray, np.ndarray, Any]:
        """(n_robots, n_cables) actions -> the ``ctrl`` commands in SI units, the actions as
        applied (in the action space's units) and whether each robot's action was clipped.

        Raises:
            InputError: an action of the wrong shape, non-finite, or out of range with
                ``clip_actions=False``; naming the robot.
        """
        action = np.asarray(action, dtype=float)
        box = self.action_space
        if action.ndim != 2 or action.shape[1] != self.n:
            raise InputError(f"actions must have shape (n_robots, {self.n}), "
                             f"got {action.shape}")
        bad = ~np.isfinite(action).all(axis=1)
        if bad.any():
            raise InputError(f"robot {int(np.argmax(bad))}: action holds NaN or infinite "
                             f"values: {action[int(np.argmax(bad))]}")
        low, high = box.low.astype(float), box.high.astype(float)
        out = np.any((action < low - 1e-6) | (action > high + 1e-6), axis=1)
        if out.any() and not self.config.clip_actions:
            i = int(np.argmax(out))
            raise InputError(f"robot {i}: action outside the box [{low.min()}, {high.max()}]"
                             f" (clip_actions=False): {action[i]}")
        applied = np.clip(action, low, high)
        if not self.config.normalize_actions:
            return applied, applied, out
        if self.action == "vstar":
            return applied * self.high, applied, out
        return np.clip(self.rest0 * (1.0 + applied * self.config.rest_span), self.low,
                       self.high), applied, out


def observation_layout(terms: tuple[str, ...], n: int, n_bodies: int
                       ) -> dict[str, tuple[int, int]]:
    """Each observation term's slice (start, stop) in the flat vector."""
    sizes = {"height": 1, "pose": 7 * n_bodies, "velocity": 3 + 6 * n_bodies,
             "cable_length": n, "rest_length": n, "tension": n, "contact": n_bodies,
             "task": 2, "previous_action": n, "position": 2}
    layout, start = {}, 0
    for term in terms:
        layout[term] = (start, start + sizes[term])
        start += sizes[term]
    return layout


def _check(structure: Structure, config: EnvConfig) -> list[Finding]:
    """``tensim check``'s findings at the environment's step: a step that blows up is refused,
    the other findings are logged as warnings.

    Raises:
        InputError: the physics step is above the structure's stable bound.
    """
    findings = check_structure(structure, config.world.timestep, source=config.model)
    for finding in findings:
        if finding.severity == "error" and finding.item == "timestep":
            raise InputError(f"model {config.model!r} at world.timestep = "
                             f"{config.world.timestep:g} s: {finding.message}; {finding.fix}")
        _log.warning("%s: %s; %s", finding.item, finding.message, finding.fix)
    return findings
