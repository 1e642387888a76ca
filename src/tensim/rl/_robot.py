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
from tensim.rl._contacts import with_bar_sensors, with_contact_sensors
from tensim.rl.config import EnvConfig
from tensim.sim import MODE_IMPEDANCE, MODE_PD, MODE_REST, CableDrive, Controller, Simulation
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
    """Sets the law's gains (from the controller) and the mode of the motorised cables (all
    cables when ``motors`` is None) for the actions; the others hold their rest length."""

    def __init__(self, controller: Controller | None, mode: int,
                 motors: np.ndarray | None = None, pd: np.ndarray | None = None):
        self.controller, self.mode, self.motors, self.pd = controller, mode, motors, pd

    def configure(self, setup: Any) -> None:
        if self.controller is not None:
            self.controller.configure(setup)
        if self.motors is None:
            setup.drive.mode[:] = self.mode
        else:
            setup.drive.mode[:] = MODE_REST
            setup.drive.mode[self.motors] = self.mode
        if self.pd is not None:  # PD motors keep their servo: the command is its target
            setup.drive.mode[self.pd] = MODE_PD


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
        if {"contact", "end_contact"} & set(config.observation):  # read for all robots at once
            self.compiled = with_contact_sensors(self.compiled)
        if config.bar_contact_cost:  # the bar-bar contacts counted for all robots at once
            self.compiled = with_bar_sensors(self.compiled)
        controller = default_controller(config.model, structure)
        self.action = config.action
        pd = np.array([c.motor.pd for c in structure.cables], dtype=bool)
        if self.action == "auto":  # a PD motor's command is its target, not V*
            self.action = "vstar" if controller is not None and not pd.any() else "rest_length"
        if self.action == "vstar" and controller is None:
            raise InputError(f"model {config.model!r} has no impedance controller, so V* "
                             "actions would do nothing: use action='rest_length'")
        mode = MODE_IMPEDANCE if self.action == "vstar" else MODE_REST
        self.motors = motorised(config.model, structure)
        if self.action == "vstar" and pd.any():
            name = structure.cables[int(np.argmax(pd))].name
            raise InputError(f"model {config.model!r}: cable {name!r} has a PD motor "
                             "(pd_stiffness), whose command is a target length; V* actions "
                             "would replace its servo by the impedance law: use "
                             "action='rest_length'")
        with Simulation(self.compiled, controller=_Configure(controller, mode, self.motors,
                                                             pd)) as sim:
            self.model = sim.model
            self.initial_state = sim.get_state()
            # each motor's command at build: a rest length, or a PD motor's target
            rest0 = np.where(pd, sim.drive.rest_command, sim.drive.rest)
        drive = CableDrive(self.compiled, self.model)  # parameters read from the MjModel
        self.n = self.compiled.n_cables
        self.n_bodies = len(self.compiled.index.bodies)
        self.cables = tuple(self.compiled.index.cables[i] for i in self.motors)
        speed = drive.max_speed.astype(float)[self.motors]
        if not (speed > 0).any():  # (in a model edited by hand) no motor speed
            raise InputError(f"model {config.model!r}: no cable has a motor that moves, so "
                             "no action can change the robot")
        if self.action == "vstar":
            self.low, self.high = -speed, speed.copy()
        else:
            span = config.rest_span * rest0[self.motors]
            self.low = np.maximum(drive.min_rest[self.motors], rest0[self.motors] - span)
            self.high = rest0[self.motors] + span
        self.rest0 = rest0
        self.hold = rest0.copy()  # passive cables keep their rest length (MODE_REST)
        if self.action == "vstar":
            self.hold[self.motors] = 0.0
        m = self.motors.size
        if config.normalize_actions:
            self.action_space = gym.spaces.Box(-1.0, 1.0, (m,), dtype=np.float32)
        else:
            self.action_space = gym.spaces.Box(self.low.astype(np.float32),
                                               self.high.astype(np.float32), dtype=np.float32)
        self.rods = rod_ends(structure, self.compiled)
        self.layout = observation_layout(config.observation, self.n, self.n_bodies, m,
                                         len(structure.rods), config.history)
        size = max(stop for _, stop in self.layout.values())
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (size,), dtype=np.float64)
        # the action box and the commands' parts in float64, read once (each step uses them)
        self._box = (self.action_space.low.astype(float), self.action_space.high.astype(float))
        self._outside = (self._box[0] - 1e-6, self._box[1] + 1e-6)  # beyond these: clipped
        self._rest_low, self._rest_high = self.low, self.high
        self._rest0_motors = rest0[self.motors]
        self._hold = self.hold[None]  # (1, n_cables), repeated for each robot's commands

    def command(self, action: np.ndarray) -> tuple[np.ndarray, np.ndarray, Any]:
        """(n_robots, n_motors) actions -> the (n_robots, n_cables) ``ctrl`` commands in SI
        units (passive cables hold their build value), the actions as applied (in the action
        space's units) and whether each robot's action was clipped.

        Raises:
            InputError: an action of the wrong shape, non-finite, or out of range with
                ``clip_actions=False``; naming the robot.
        """
        action = np.asarray(action, dtype=float)
        m = self.motors.size
        if action.ndim != 2 or action.shape[1] != m:
            raise InputError(f"actions must have shape (n_robots, {m}) (one per motorised "
                             f"cable), got {action.shape}")
        if not np.logical_and.reduce(np.isfinite(action), axis=None):  # (.all(), unwrapped)
            bad = ~np.isfinite(action).all(axis=1)
            raise InputError(f"robot {int(np.argmax(bad))}: action holds NaN or infinite "
                             f"values: {action[int(np.argmax(bad))]}")
        low, high = self._box
        out = np.logical_or.reduce((action < self._outside[0]) | (action > self._outside[1]),
                                   axis=1)
        if not self.config.clip_actions and out.any():
            i = int(np.argmax(out))
            raise InputError(f"robot {i}: action outside the box [{low.min()}, {high.max()}]"
                             f" (clip_actions=False): {action[i]}")
        applied = np.minimum(np.maximum(action, low), high)  # np.clip, without its overhead
        command = applied
        if self.config.normalize_actions and self.action == "vstar":
            command = applied * self.high
        elif self.config.normalize_actions:
            command = np.minimum(np.maximum(
                self._rest0_motors * (1.0 + applied * self.config.rest_span), self._rest_low),
                self._rest_high)
        commands = self._hold.repeat(action.shape[0], axis=0)
        commands[:, self.motors] = command
        return commands, applied, out


def motorised(model: str, structure: Structure) -> np.ndarray:
    """Indices of the cables that have a motor (the action space's cables).

    Raises:
        InputError: a robot with no motorised cable.
    """
    motors = np.flatnonzero([not c.motor.passive for c in structure.cables])
    if motors.size == 0:
        raise InputError(f"model {model!r} has no motorised cable (every cable is passive), "
                         "so a policy has nothing to act on: give some cables a 'motor'")
    return motors


def rod_ends(structure: Structure, compiled: CompiledModel) -> dict[str, np.ndarray]:
    """Each rod's end nodes as (body id, position in that body's frame): arrays ``body``
    (n_rods, 2) and ``local`` (n_rods, 2, 3) [m]."""
    idx = compiled.index
    ends = [rod.nodes for rod in structure.rods]
    body = np.array([[idx.node_body[a] for a in e] for e in ends], dtype=int).reshape(-1, 2)
    local = np.array([[idx.node_local[a] for a in e] for e in ends], float).reshape(-1, 2, 3)
    return {"body": body, "local": local}


def observation_layout(terms: tuple[str, ...], n: int, n_bodies: int, n_motors: int | None = None,
                       n_rods: int = 0, history: int = 0) -> dict[str, tuple[int, int]]:
    """Each observation term's slice (start, stop) in the flat vector; with ``history`` the
    previous observations follow under the key ``"history"``."""
    sizes = {"height": 1, "pose": 7 * n_bodies, "velocity": 3 + 6 * n_bodies,
             "rod_axis": 3 * n_rods, "cable_length": n, "rest_length": n, "tension": n,
             "contact": n_bodies, "end_contact": 2 * n_rods, "task": 2,
             "previous_action": n if n_motors is None else n_motors, "position": 2}
    layout, start = {}, 0
    for term in terms:
        layout[term] = (start, start + sizes[term])
        start += sizes[term]
    if history:
        layout["history"] = (start, start * (1 + history))
    return layout


def _check(structure: Structure, config: EnvConfig) -> list[Finding]:
    """``tensim check``'s findings at the environment's step: a step that blows up is refused,
    the other findings are logged (warnings as warnings, notes at INFO).

    Raises:
        InputError: the physics step is above the structure's stable bound.
    """
    findings = check_structure(structure, config.world.timestep, source=config.model,
                               cable_law=config.world.cable_law)
    for finding in findings:
        if finding.severity == "error" and finding.item == "timestep":
            raise InputError(f"model {config.model!r} at world.timestep = "
                             f"{config.world.timestep:g} s: {finding.message}; {finding.fix}")
        level = logging.INFO if finding.severity == "note" else logging.WARNING
        _log.log(level, "%s: %s; %s", finding.item, finding.message, finding.fix)
    return findings
