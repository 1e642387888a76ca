"""Env steps per CPU second of a rolling robot's environments (``tensim bench --rl``).

The robot and task are those ``tensim rl train MODEL --task roll`` trains on (20 ms control,
a 2 ms step under the implicitfast cable law, the rolling observation in the heading frame).
Six ways of stepping ``n`` robots run in turn, on the same table of random actions:

- the raw engine: MuJoCo's batch engine stepping tensim's model of the robot, its commands
  ready-made (no observation: the model without the contact sensors the rolling
  observation adds to it);
- :class:`~tensim.rl.TensegrityVectorEnv` and :class:`~tensim.rl.sb3.SB3VecEnv` over ``n``
  robots;
- :class:`~tensim.rl.TensegrityEnv` stepped ``n`` times;
- a plain Gymnasium ``MujocoEnv`` of the same robot, as one writes it by hand: the MJCF of
  ``tensim export-mjcf`` (MuJoCo's tendon springs in place of the cable law, a tension
  actuator per motorised cable), stepped with ``mj_step`` ``n`` times, observing what the
  rolling observation holds (read from its MjData with NumPy, in the heading's frame),
  starting from the same settled pose;
- the same plain env observing only qpos and qvel (the least an environment can observe).

CPU time of this process (time.process_time), best of ``repeats``; the wall time beside it
says how much the machine's other work stretched the runs.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from tensim.benchmarks._machine import core_share, load_average

CASES = ("raw engine", "TensegrityVectorEnv", "SB3VecEnv", "TensegrityEnv", "plain MujocoEnv",
         "plain, qpos+qvel")
PLAIN = CASES[4]  # the plain env the fractions compare with: the same observation
TENSION_N = 200.0  # the plain env's tension command at action 0 [N] (0 to 400 N)


def plain_env(mjcf: Path, frame_skip: int, motors: np.ndarray, qpos: np.ndarray,
              ends: list[tuple[str, str]] | None = None) -> Any:
    """A Gymnasium ``MujocoEnv`` of the exported model: ``motors`` are its actions (a tension
    command each), metres along its heading its reward, ``qpos`` its start (with 2 mm of noise
    and a random heading, as Gymnasium's MuJoCo environments perturb theirs).

    Its observation: with ``ends`` (each rod's end sites), what the rolling observation holds,
    read from MjData as one writes it by hand (the height, the centre of mass's and each body's
    linear and angular velocity, the rod axes, the cable lengths, each end cap's ground
    contact, the heading, the previous action; vectors in the heading's frame); without, the
    qpos and qvel."""
    import gymnasium as gym
    from gymnasium.envs.mujoco import MujocoEnv

    class Plain(MujocoEnv):
        metadata = {"render_modes": ["rgb_array"], "render_fps": 50}  # noqa: RUF012

        def __init__(self) -> None:
            model = mujoco.MjModel.from_xml_path(str(mjcf))
            free = np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
            size = model.nq + model.nv
            if ends is not None:  # height, 3 + 6 per body, 3 per rod, cables, 2 per rod, ...
                size = 1 + 3 + 6 * free.size + 5 * len(ends) + model.ntendon + 2 + motors.size
            space = gym.spaces.Box(-np.inf, np.inf, (size,), np.float64)
            super().__init__(str(mjcf), frame_skip, observation_space=space, width=64,
                             height=64)
            self.action_space = gym.spaces.Box(-1.0, 1.0, (motors.size,), np.float32)
            self.init_qpos = qpos.copy()
            # ids looked up once
            self.dofs = model.jnt_dofadr[free][:, None] + np.arange(6)
            self.bodies = model.jnt_bodyid[free]
            self.mass = model.body_mass[self.bodies] / model.body_mass[self.bodies].sum()
            names = [n for pair in ends or [] for n in pair]
            self.ends = np.array([model.site(n).id for n in names], dtype=int)
            self.end_body = model.site_bodyid[self.ends]
            self.geom_body = model.geom_bodyid.copy()
            self.previous = np.zeros(motors.size)
            self.heading = np.array([1.0, 0.0])
            self.frame = np.eye(3)

        def step(self, action: np.ndarray) -> Any:
            action = np.clip(action, -1.0, 1.0)
            ctrl = np.zeros(self.model.nu)
            ctrl[motors] = -TENSION_N * (1.0 + action)
            before = self.data.subtree_com[0, :2].copy()
            self.do_simulation(ctrl, self.frame_skip)
            self.previous = action
            reward = float((self.data.subtree_com[0, :2] - before) @ self.heading)
            return self._obs(), reward, False, False, {}

        def _obs(self) -> np.ndarray:
            d = self.data
            if ends is None:
                return np.concatenate([d.qpos, d.qvel])
            qvel = d.qvel[self.dofs]  # (bodies, 6): linear (world), angular (local)
            linear = qvel[:, :3]
            angular = np.einsum("bij,bj->bi", d.xmat[self.bodies].reshape(-1, 3, 3),
                                qvel[:, 3:])
            tips = d.site_xpos[self.ends].reshape(-1, 2, 3)
            axes = tips[:, 1] - tips[:, 0]
            axes /= np.linalg.norm(axes, axis=1, keepdims=True)
            world = np.concatenate([(self.mass @ linear)[None], linear, angular, axes,
                                    [[*self.heading, 0.0]]])
            turned = world @ self.frame.T  # into the heading's frame
            return np.concatenate([d.subtree_com[0, 2:], turned[:-1].ravel(), d.ten_length,
                                   self._end_contacts(), turned[-1, :2], self.previous])

        def _end_contacts(self) -> np.ndarray:
            """1 at the end cap nearest each ground contact of its body."""
            d, flags = self.data, np.zeros(self.ends.size)
            if not d.ncon:
                return flags
            contact = d.contact
            pair = self.geom_body[contact.geom]
            ground = (pair == 0).any(axis=1)
            body, points = pair[ground].max(axis=1), contact.pos[ground]
            far = np.linalg.norm(d.site_xpos[self.ends] - points[:, None], axis=2)
            far[self.end_body != body[:, None]] = np.inf
            hit = np.isfinite(far).any(axis=1)
            flags[np.argmin(far[hit], axis=1)] = 1.0
            return flags

        def reset_model(self) -> np.ndarray:
            noise = self.np_random.uniform(-0.002, 0.002, self.model.nq)
            self.set_state(self.init_qpos + noise, self.init_qvel)
            yaw = self.np_random.uniform(-np.pi, np.pi)
            self.heading = np.array([np.cos(yaw), np.sin(yaw)])
            c, s = self.heading
            self.frame = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
            self.previous = np.zeros(motors.size)
            return self._obs()

    return Plain()


def _loops(model: str, n: int, periods: int, folder: Path) -> dict[str, Callable[[], None]]:
    """Each case's loop of ``periods`` control periods of ``n`` robots."""
    from tensim.io._mjcf_motors import NODE_SITE
    from tensim.io.mjcf import save_mjcf
    from tensim.model import compile_structure
    from tensim.rl import TensegrityEnv, TensegrityVectorEnv
    from tensim.rl._robot import load_robot
    from tensim.rl.sb3 import SB3VecEnv
    from tensim.rl.train import TrainSettings

    config = TrainSettings(model, task="roll", rest_span=0.6).env_config()
    # the engine steps the robot alone: without the contact sensors the observation adds
    bare = dataclasses.replace(config, observation=("height",))
    engine, vector = TensegrityVectorEnv(n, bare), TensegrityVectorEnv(n, config)
    sb3, single = SB3VecEnv(n, config), TensegrityEnv(config)
    robot, structure = single.robot, load_robot(model)
    mjcf = save_mjcf(compile_structure(structure, config.world), folder / "robot.xml")
    start = mujoco.MjData(robot.model)
    mujoco.mj_setState(robot.model, start, robot.initial_state,
                       mujoco.mjtState.mjSTATE_INTEGRATION)
    qpos = start.qpos.copy()
    ends = [(f"{NODE_SITE}{a}", f"{NODE_SITE}{b}") for a, b in (r.nodes for r in structure.rods)]
    plain = plain_env(mjcf, config.control_steps, robot.motors, qpos, ends)
    bare_plain = plain_env(mjcf, config.control_steps, robot.motors, qpos)
    actions = np.random.default_rng(0).uniform(-1, 1, (periods, n, robot.motors.size))
    commands = np.stack([robot.command(a)[0] for a in actions])
    engine.reset(seed=0)
    vector.reset(seed=0)
    sb3.seed(0)
    sb3.reset()
    single.reset(seed=0)
    plain.reset(seed=0)
    bare_plain.reset(seed=0)
    batch, ctrl = engine.worlds.batch, engine.worlds.f["ctrl"]

    def raw() -> None:
        for c in commands:
            ctrl[:, :robot.n] = c
            batch.step(nstep=config.control_steps, stage=mujoco.mjtStage.mjSTAGE_VEL)

    def each(env: Any) -> Callable[[], None]:
        def loop() -> None:
            for a in actions:
                for action in a:
                    env.step(action)
        return loop

    def together(env: Any) -> Callable[[], None]:
        def loop() -> None:
            for a in actions:
                env.step(a)
        return loop

    return dict(zip(CASES, (raw, together(vector), together(sb3), each(single), each(plain),
                            each(bare_plain)), strict=True))


def bench_rl(model: str = "three_bar", envs: tuple[int, ...] = (16, 64), periods: int = 100,
             repeats: int = 3) -> dict[str, Any]:
    """Env steps per CPU second of each case (:data:`CASES`) at each robot count of ``envs``,
    the cases taking turns, best of ``repeats``.

    Returns:
        ``{"model", "periods", "repeats", "load_average_before", "core_share",
        "envs": {n: {case: {"cpu_rate", "wall_rate", "per_engine", "per_plain"}}}}``.
    """
    load = load_average()
    report: dict[str, Any] = {"model": model, "periods": periods, "repeats": repeats,
                              "load_average_before": load, "envs": {}}
    shares: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in envs:
            loops = _loops(model, n, periods, Path(tmp))
            cpu: dict[str, list[float]] = {k: [] for k in loops}
            wall: dict[str, list[float]] = {k: [] for k in loops}
            for _ in range(repeats):  # interleaved: every case once per round
                for name, loop in loops.items():
                    c0, w0 = time.process_time(), time.perf_counter()
                    loop()
                    cpu[name].append(time.process_time() - c0)
                    wall[name].append(time.perf_counter() - w0)
            steps = periods * n
            rates = {k: steps / min(cpu[k]) for k in loops}
            report["envs"][n] = {k: {"cpu_rate": rates[k], "wall_rate": steps / min(wall[k]),
                                     "per_engine": rates[k] / rates[CASES[0]],
                                     "per_plain": rates[k] / rates[PLAIN]} for k in loops}
            shares.update({f"{k}, {n} robots": core_share(cpu[k], wall[k]) for k in loops})
    report["core_share"] = shares
    return report


def format_rl(report: dict[str, Any]) -> str:
    """The table of :func:`bench_rl`'s report: each case's env steps per CPU second as a
    fraction of the raw engine's and of the plain env's, then the rates themselves (which
    vary with the machine; the fractions much less)."""
    lines = [f"{report['model']}, the roll task of `tensim rl train` (20 ms control = 10 "
             "physics steps of 2 ms, implicitfast cable law, heading frame), "
             f"{report['periods']} periods per run, cases interleaved, best of "
             f"{report['repeats']}; env steps per CPU second, as a fraction of"]
    for n, cases in report["envs"].items():
        lines.append(f"  {n} robots             the raw engine's  the plain env's")
        lines += [f"    {name:<22}{row['per_engine']:11.2f}{row['per_plain']:17.2f}"
                  for name, row in cases.items()]
    lines.append("env steps per CPU second (per wall second):")
    for n, cases in report["envs"].items():
        lines.append(f"  {n} robots: " + ", ".join(
            f"{name} {row['cpu_rate']:.0f} ({row['wall_rate']:.0f})"
            for name, row in cases.items()))
    return "\n".join(lines)
