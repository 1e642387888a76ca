"""What a tensegrity environment simulates: the robot, its actions, observations, task and
randomisation, as validated frozen records."""

from __future__ import annotations

import dataclasses
import math

from tensim._input import InputError
from tensim.model import WorldOptions

ACTIONS = ("auto", "vstar", "rest_length")
FRAMES = ("robot", "heading")
TASKS = ("direction", "turn", "goal", "hold")
OBSERVATIONS = ("height", "pose", "velocity", "rod_axis", "cable_length", "rest_length",
                "tension", "contact", "end_contact", "task", "previous_action", "position")
ROLLING_OBSERVATION = ("height", "velocity", "rod_axis", "cable_length", "end_contact", "task",
                       "previous_action")
DEFAULT_OBSERVATION = ("height", "pose", "velocity", "cable_length", "rest_length", "tension",
                       "task", "previous_action")


def _range(name: str, value: tuple[float, float]) -> None:
    lo, hi = value
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
        raise InputError(f"randomization {name} must be (low, high) multipliers with "
                         f"0 < low <= high, got {value!r}")


@dataclasses.dataclass(frozen=True)
class Randomization:
    """Per-episode domain randomisation and sensor/actuator imperfections.

    Physics multipliers are drawn uniformly in (low, high) for each episode of each robot and
    applied through the batch engine's :class:`~tensim.sim.PhysicsScale`; (1, 1) leaves a
    parameter as built.

    Attributes:
        friction, stiffness, damping, mass, motor_speed: (low, high) multipliers.
        yaw: start heading drawn uniformly in [-pi, pi) (False: the build heading).
        pose_noise_m: std of each rigid body's start displacement [m] (z upward only).
        length_noise_m: std of the Gaussian noise on observed lengths and positions [m].
        tension_noise_n: std of the noise on observed tensions [N].
        velocity_noise: std of the noise on observed velocities [m/s, rad/s].
        action_delay: control periods between an action and its effect (0: next period).
    """

    friction: tuple[float, float] = (1.0, 1.0)
    stiffness: tuple[float, float] = (1.0, 1.0)
    damping: tuple[float, float] = (1.0, 1.0)
    mass: tuple[float, float] = (1.0, 1.0)
    motor_speed: tuple[float, float] = (1.0, 1.0)
    yaw: bool = False
    pose_noise_m: float = 0.0
    length_noise_m: float = 0.0
    tension_noise_n: float = 0.0
    velocity_noise: float = 0.0
    action_delay: int = 0

    def __post_init__(self) -> None:
        for name in ("friction", "stiffness", "damping", "mass", "motor_speed"):
            _range(name, getattr(self, name))
        for name in ("pose_noise_m", "length_noise_m", "tension_noise_n", "velocity_noise"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise InputError(f"randomization {name} must be a finite number >= 0, "
                                 f"got {value!r}")
        if not (isinstance(self.action_delay, int) and 0 <= self.action_delay <= 100):
            raise InputError(f"randomization action_delay must be an integer number of control "
                             f"periods in 0..100, got {self.action_delay!r}")

    @classmethod
    def start(cls) -> Randomization:
        """The default: each episode starts at a random heading with 2 mm pose noise (as
        Gymnasium's MuJoCo environments perturb their start), so seeds differ."""
        return cls(yaw=True, pose_noise_m=0.002)

    @classmethod
    def standard(cls) -> Randomization:
        """A moderate set for sim-to-real training: +-20 % physics, any heading, 5 mm."""
        return cls(friction=(0.7, 1.3), stiffness=(0.8, 1.2), damping=(0.8, 1.2),
                   mass=(0.9, 1.1), motor_speed=(0.8, 1.2), yaw=True, pose_noise_m=0.005,
                   length_noise_m=0.001, tension_noise_n=0.2, velocity_noise=0.01)


@dataclasses.dataclass(frozen=True)
class EnvConfig:
    """What an environment simulates.

    Attributes:
        model: a preset name or a structure ``.yaml`` file.
        action: ``"vstar"`` (target velocity V* per cable under the robot's impedance law),
            ``"rest_length"`` (commanded rest length per cable; a PD motor's target length)
            or ``"auto"`` (vstar where the robot has an impedance controller and no PD motor,
            else rest_length).
        normalize_actions: actions in [-1, 1] (V* = a max_speed; rest = l0 (1 + a rest_span))
            rather than in SI units.
        clip_actions: out-of-range actions are clipped to the box (counted in
            ``info["action_clipped"]``); False raises an error instead. NaN always raises.
        rest_span: half-range of the rest-length actions, as a fraction of the build rest
            length.
        control_dt: control period [s], a whole number of physics steps.
        episode_s: episode length [s].
        task: ``"direction"`` (reward: metres walked along ``direction``), ``"turn"``
            (reward: radians turned about the vertical, counter-clockwise unless
            ``clockwise``, less metres the centre of mass moved), ``"goal"``
            (reward: metres closer to a goal ``goal_m`` away from the start; the episode
            ends within ``goal_radius_m``) or ``"hold"`` (reward: minus the mean body
            displacement from the start shape [m] per second).
        direction: (2,) the rewarded direction in the ground plane, in the robot's start
            frame when ``randomization.yaw`` turns the robot, else in the world.
        goal_m: (2,) goal position from the start centre of mass, same frame [m].
        goal_radius_m: distance at which the goal counts as reached [m].
        clockwise: the ``turn`` task rewards clockwise turning.
        control_cost: weight of the mean squared normalised action, per second.
        bar_contact_cost: penalty per rod-rod contact, per second.
        roll_reward: task ``"direction"``: reward per radian the robot turns about its
            rolling axis, the horizontal axis z x ``direction`` (the best rigid fit of the rod
            ends' move over the control period, Kabsch's) [m/rad]; a robot that rolls without
            slipping on a hull of radius r earns r per radian from the progress term, so a
            weight near r pays the turning as much again, and rocking or crawling earns
            nothing net. 0: off.
        slip_cost: penalty per metre the rod ends on the ground slide horizontally (the
            horizontal speed of each rod end with a ground contact on its end of the rod,
            times the control period; rolling without slipping keeps it near 0) [1]. 0: off.
        observation: the observation terms, in order (see :data:`OBSERVATIONS` and docs/rl.md).
        history: previous observations appended to each observation (0: none).
        frame: the frame observations are written in, about the vertical through the centre
            of mass: ``"robot"`` (x toward the first rigid body seen from above) or
            ``"heading"`` (x along the task's heading: ``direction``, or toward the goal;
            for ``turn`` and ``hold`` the start's ``direction``), which stays put while a
            rolling robot tumbles.
        randomization: domain randomisation and sensor/actuator imperfections (default:
            :meth:`Randomization.start`, a random heading and 2 mm pose noise).
        threads: the batch engine's worker threads (vector env).
        world: physics step, gravity, ground.
    """

    model: str = "tetraspine3"
    action: str = "auto"
    normalize_actions: bool = True
    clip_actions: bool = True
    rest_span: float = 0.2
    control_dt: float = 0.01
    episode_s: float = 10.0
    task: str = "direction"
    direction: tuple[float, float] = (0.0, 1.0)
    goal_m: tuple[float, float] = (0.0, 1.0)
    goal_radius_m: float = 0.1
    clockwise: bool = False
    control_cost: float = 0.0
    bar_contact_cost: float = 0.0
    roll_reward: float = 0.0
    slip_cost: float = 0.0
    observation: tuple[str, ...] = DEFAULT_OBSERVATION
    history: int = 0
    frame: str = "robot"
    randomization: Randomization = dataclasses.field(default_factory=Randomization.start)
    threads: int = 1
    world: WorldOptions = dataclasses.field(default_factory=WorldOptions)

    def __post_init__(self) -> None:
        if self.action not in ACTIONS:
            raise InputError(f"action must be one of {', '.join(ACTIONS)}, got {self.action!r}")
        if self.frame not in FRAMES:
            raise InputError(f"frame must be one of {', '.join(FRAMES)}, got {self.frame!r}")
        if self.task not in TASKS:
            raise InputError(f"task must be one of {', '.join(TASKS)}, got {self.task!r}")
        steps = round(self.control_dt / self.world.timestep) if math.isfinite(
            self.control_dt) else 0
        if steps < 1 or abs(steps * self.world.timestep - self.control_dt) > 1e-12:
            raise InputError(f"control_dt = {self.control_dt} s must be a whole number of "
                             f"physics steps ({self.world.timestep} s)")
        if not (math.isfinite(self.episode_s) and self.episode_s >= self.control_dt):
            raise InputError(f"episode_s must be a finite number >= control_dt, "
                             f"got {self.episode_s}")
        for name in ("direction", "goal_m"):
            value = getattr(self, name)
            if len(value) != 2 or not all(math.isfinite(v) for v in value):
                raise InputError(f"{name} must be two finite numbers (x, y), got {value!r}")
        if not math.hypot(*self.direction) > 0:
            raise InputError("direction must be a non-zero vector in the ground plane")
        for name in ("rest_span", "goal_radius_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InputError(f"{name} must be a finite number > 0, got {value!r}")
        for name in ("control_cost", "bar_contact_cost", "roll_reward", "slip_cost"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise InputError(f"{name} must be a finite number >= 0, got {value!r}")
        if self.roll_reward and self.task != "direction":
            raise InputError(f"roll_reward rewards rolling along a direction: it needs task "
                             f"'direction', got task {self.task!r}")
        if not (isinstance(self.history, int) and 0 <= self.history <= 100):
            raise InputError(f"history must be an integer number of observations in 0..100, "
                             f"got {self.history!r}")
        unknown = [t for t in self.observation if t not in OBSERVATIONS]
        if unknown or not self.observation or len(set(self.observation)) != len(
                self.observation):
            raise InputError(f"observation must list distinct terms of {', '.join(OBSERVATIONS)}"
                             f", got {self.observation!r}")
        if not (isinstance(self.threads, int) and self.threads >= 1):
            raise InputError(f"threads must be an integer >= 1, got {self.threads!r}")

    @property
    def control_steps(self) -> int:
        """Physics steps per control period."""
        return round(self.control_dt / self.world.timestep)

    @property
    def max_steps(self) -> int:
        """Control periods per episode."""
        return round(self.episode_s / self.control_dt)
