"""The statics rolling gait (:mod:`tensim.experiments.roll`) as an expert of an environment's
robots: it looks at one robot of an env's batch (node positions, centre of mass, rest lengths,
read from that robot's MjData) and says the action that commands the rest lengths it would
command, in the env's own action units.

The gait keeps its own state machine and its own command array, so it can drive the robot
(the expert in control) or only watch a robot another policy drives and label each state with
what it would do there (a *shadow* expert, as DAgger's labels are made).
"""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace
from typing import Any

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from tensim._input import InputError
from tensim.control.roll_plans import PlanCache
from tensim.control.rolling import RollSettings, default_settings
from tensim.rl._robot import Robot
from tensim.structure import body_length


def expert_settings(robot: Robot) -> RollSettings:
    """The gait's settings on ``robot``: its defaults (:func:`default_settings`) with plans
    cached through the robot's symmetry (``cache``, much cheaper) and one look per control
    period of the env."""
    return dataclasses.replace(default_settings(robot.compiled.structure), cache=True,
                               period_s=robot.config.control_dt)


def check_rolling(robot: Robot) -> None:
    """Refuses a robot or task the statics rolling gait cannot drive.

    Raises:
        InputError: a task other than rolling along a heading, actions that are not rest
            lengths, or a robot whose nodes span no solid hull (nothing to roll on).
    """
    c = robot.config
    if c.task != "direction":
        raise InputError(f"the statics rolling gait rolls along a heading: it needs --task "
                         f"roll, got the env's task {c.task!r}")
    if robot.action != "rest_length":
        raise InputError(f"model {c.model!r}: its actions are {robot.action!r}; the statics "
                         "rolling gait commands rest lengths, so it can only teach a robot "
                         "with rest-length actions: give --action rest_length (a robot with "
                         "an impedance controller, or a structure file, acts by V* otherwise)")
    nodes = np.array([n.position for n in robot.compiled.structure.nodes], dtype=float)
    try:
        ConvexHull(nodes)
    except (QhullError, ValueError) as err:
        raise InputError(f"model {c.model!r}: its nodes span no solid convex hull, so it has "
                         "no faces to roll over and the statics rolling gait does not "
                         "apply") from err


def expert_action(robot: Robot, command: np.ndarray) -> np.ndarray:
    """(n_motors,) the normalised action whose command (:meth:`Robot.command`) is the rest
    lengths ``command`` (n_cables,) [m] of the motorised cables: (command / l0 - 1) / span,
    clipped to [-1, 1] (a command within the motors' limits comes back exactly)."""
    rest0 = robot.rest0[robot.motors]
    action = (command[robot.motors] / rest0 - 1.0) / robot.config.rest_span
    return np.clip(action, -1.0, 1.0)


class _View:
    """What the gait reads and writes of robot ``i`` of ``worlds``, as it reads a
    :class:`~tensim.sim.Simulation`: ``data`` (xpos, xmat, subtree_com), ``index``, ``time``
    and ``drive`` (``rest`` from the robot's activations, the gait's own ``rest_command``)."""

    def __init__(self, worlds: Any, i: int, command: np.ndarray):
        f, robot = worlds.f, worlds.robot
        self.index = robot.compiled.index
        self.data = SimpleNamespace(xpos=f["xpos"][i], xmat=f["xmat"][i],
                                    subtree_com=f["subtree_com"][i])
        self.time = float(worlds.steps[i]) * robot.config.control_dt
        self.drive = SimpleNamespace(rest=self.index.cable_act(f["act"][i]),
                                     rest_command=command)


class Expert:
    """The statics rolling gait of one robot of an env's batch.

    Args:
        robot: the env's robot (:func:`check_rolling` must accept it).
        settings: the gait's parameters (None: :func:`expert_settings`).
        plans: a plan cache to share (plans are of the build pose, the same every episode);
            None: a new one.

    Raises:
        InputError: the gait does not apply to ``robot`` (:func:`check_rolling`).
    """

    def __init__(self, robot: Robot, settings: RollSettings | None = None,
                 plans: PlanCache | None = None):
        check_rolling(robot)
        self.robot = robot
        self.settings = settings or expert_settings(robot)
        compiled = robot.compiled
        self.built = compiled.rest_length.copy()
        self.motorised = np.zeros(robot.n, dtype=bool)
        self.motorised[robot.motors] = True
        self.length = body_length(compiled.structure)
        self.plans = plans if plans is not None or not self.settings.cache else PlanCache(
            compiled.structure, self.built, self.settings,
            -float(robot.model.opt.gravity[2]))
        self.command = self.built.copy()
        self.gait: Any = None

    def start(self, worlds: Any, i: int) -> None:
        """A new episode of robot ``i``: the gait starts over, toward its heading (world)
        from where its centre of mass stands."""
        from tensim.experiments.roll import _Gait

        heading = worlds.heading[i]
        self.command = self.built.copy()
        self.gait = _Gait(self.robot.compiled.structure, self.built, self.motorised,
                          self.settings, math.degrees(math.atan2(heading[1], heading[0])),
                          None, worlds.f["subtree_com"][i, 0, :2].copy(), self.length,
                          cache=self.plans)

    def act(self, worlds: Any, i: int) -> np.ndarray:
        """Looks at robot ``i`` now and returns the (n_motors,) action in [-1, 1] that
        commands the gait's rest lengths (:func:`expert_action`)."""
        if self.gait is None:
            raise RuntimeError("Expert.start(...) first: the gait has no episode")
        self.gait.control(_View(worlds, i, self.command))
        return expert_action(self.robot, self.command)
