"""Env steps per CPU second for a 3-bar (rods 1.4 m, 6 motorised and 3 passive cables, 20 ms
control = 20 physics steps of 1 ms): MuJoCo's batch engine alone stepping tensim's model,
the ``TensegrityVectorEnv``, the ``SB3VecEnv`` on top of it, and a plain MuJoCo Gymnasium env
(``gymnasium.envs.mujoco.MujocoEnv``) of the same robot exported by ``tensim export-mjcf``
(tendon springs for the cables, tendon-force actuators, observations qpos and qvel).

    python benchmarks/rl_speed.py [--envs 8] [--periods 200] [--repeats 3]
    python benchmarks/rl_speed.py --model three_bar --dt 0.002 --cable-law implicitfast \
        --envs 16          # the preset as `tensim rl train` trains it

Each case runs ``--periods`` control periods, the cases take turns, best of ``--repeats``;
CPU time of this process (time.process_time), so other work on the machine matters less.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np

SCALE = 2.86  # examples/tensegrity_prism.yaml scaled to 1.4 m rods
BOTTOM = [(0.2, 0.0), (-0.1, 0.173205), (-0.1, -0.173205)]
TOP = [(-0.173205, 0.1), (0.0, -0.2), (0.173205, 0.1)]


def three_bar() -> str:
    """The 3-bar of tests/test_rl_rolling.py as structure YAML."""
    nodes = [f"  - {{name: b{i}, position: [{x * SCALE:.6f}, {y * SCALE:.6f}, 0.05]}}"
             for i, (x, y) in enumerate(BOTTOM)]
    nodes += [f"  - {{name: t{i}, position: [{x * SCALE:.6f}, {y * SCALE:.6f}, "
              f"{0.3 * SCALE + 0.05:.6f}]}}" for i, (x, y) in enumerate(TOP)]
    motor = "motor: {max_speed: 0.2, max_tension: 2000.0, min_rest_length: 0.1, min_length: 0.1}"
    cables = [f"  - {{name: {k}_{i}, nodes: [{k[0]}{i}, {k[0]}{(i + 1) % 3}], pretension: 120, "
              f"{motor}}}" for k in ("bottom", "top") for i in range(3)]
    cables += [f"  - {{name: vertical_{i}, nodes: [b{i}, t{(i + 2) % 3}], pretension: 190}}"
               for i in range(3)]
    return "\n".join(["name: three_bar", "defaults:",
                      "  rod: {radius: 0.02, linear_density: 2.857, friction: 0.8}",
                      "  cable: {stiffness: 3000.0, damping: 20.0}", "nodes:", *nodes,
                      "rods:", *[f"  - {{name: rod_{i}, nodes: [b{i}, t{i}]}}" for i in range(3)],
                      "cables:", *cables, ""])


def plain_env(mjcf: Path, frame_skip: int, motors: np.ndarray):
    """A MuJoCo Gymnasium env of the exported model, as one would write it by hand."""
    import gymnasium as gym
    from gymnasium.envs.mujoco import MujocoEnv

    class Plain(MujocoEnv):
        metadata = {"render_modes": ["rgb_array"], "render_fps": 50}  # noqa: RUF012

        def __init__(self) -> None:
            model = mujoco.MjModel.from_xml_path(str(mjcf))
            space = gym.spaces.Box(-np.inf, np.inf, (model.nq + model.nv,), np.float64)
            super().__init__(str(mjcf), frame_skip, observation_space=space, width=64,
                             height=64)
            self.action_space = gym.spaces.Box(-1.0, 1.0, (motors.size,), np.float32)

        def step(self, action):
            ctrl = np.zeros(self.model.nu)
            ctrl[motors] = -200.0 * (1.0 + np.asarray(action))  # a tension command [N]
            before = self.data.subtree_com[0, 0]
            self.do_simulation(ctrl, self.frame_skip)
            reward = self.data.subtree_com[0, 0] - before
            return self._obs(), reward, False, False, {}

        def _obs(self):
            return np.concatenate([self.data.qpos, self.data.qvel])

        def reset_model(self):
            noise = self.np_random.uniform(-0.002, 0.002, self.model.nq)
            self.set_state(self.init_qpos + noise, self.init_qvel)
            return self._obs()

    return Plain()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=8)
    parser.add_argument("--periods", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--model", default=None,
                        help="a preset or structure file (default: the 3-bar written here)")
    parser.add_argument("--dt", type=float, default=0.001, help="physics step [s]")
    parser.add_argument("--cable-law", default="explicit")
    args = parser.parse_args()

    from tensim.io.mjcf import save_mjcf
    from tensim.model import WorldOptions
    from tensim.rl import EnvConfig, TensegrityEnv, TensegrityVectorEnv
    from tensim.rl.config import ROLLING_OBSERVATION
    from tensim.rl.sb3 import SB3VecEnv

    folder = Path(tempfile.mkdtemp())
    (folder / "three_bar.yaml").write_text(three_bar())
    config = EnvConfig(model=args.model or str(folder / "three_bar.yaml"), control_dt=0.02,
                       observation=ROLLING_OBSERVATION,
                       world=WorldOptions(timestep=args.dt, cable_law=args.cable_law))
    vector, sb3 = TensegrityVectorEnv(args.envs, config), SB3VecEnv(args.envs, config)
    single = TensegrityEnv(config)
    save_mjcf(single.robot.compiled, folder / "three_bar.xml")
    plain = plain_env(folder / "three_bar.xml", config.control_steps, single.robot.motors)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (args.envs, single.robot.motors.size)).astype(np.float32)
    vector.reset(seed=0)
    sb3.reset()
    single.reset(seed=0)
    plain.reset(seed=0)
    raw = vector.worlds.batch

    def engine() -> None:
        raw.step(nstep=config.control_steps, stage=mujoco.mjtStage.mjSTAGE_VEL)

    def plain_steps() -> None:
        for a in actions:
            plain.step(a)

    def single_steps() -> None:
        for a in actions:
            single.step(a)

    runs = {"batch engine (tensim model)": engine,
            "TensegrityVectorEnv": lambda: vector.step(actions),
            "SB3VecEnv": lambda: sb3.step(actions),
            "TensegrityEnv, one robot": single_steps,
            "plain MujocoEnv (MJCF springs)": plain_steps}
    best = dict.fromkeys(runs, 0.0)
    for _ in range(args.repeats):
        for name, step in runs.items():
            started = time.process_time()
            for _ in range(args.periods):
                step()
            best[name] = max(best[name], args.periods * args.envs /
                             (time.process_time() - started))
    print(f"{args.model or '3-bar'}, {args.envs} robots, control_dt {config.control_dt} s "
          f"({config.control_steps} physics steps of {args.dt * 1e3:g} ms, {args.cable_law} "
          "cable law), env steps per CPU second, best of "
          f"{args.repeats}:")
    for name, rate in best.items():
        print(f"  {name:<32} {rate:8.0f}  ({rate / best['batch engine (tensim model)']:.2f} "
              f"of the engine, {rate / best['plain MujocoEnv (MJCF springs)']:.2f} of the "
              "plain env)")


if __name__ == "__main__":
    main()
