"""The vector environment's vectorised contact and observation code against the per-robot
loops it replaced, on random states of a rolling 3-bar (rods tumbling onto the ground and
onto each other)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("gymnasium", reason="the rl extra (gymnasium) is not installed")

from tensim.rl import EnvConfig, Randomization, TensegrityVectorEnv
from tensim.rl.config import ROLLING_OBSERVATION
from tensim.sim import compiled_available
from test_rl_rolling import three_bar

pytestmark = pytest.mark.skipif(not compiled_available(),
                                reason="the environments step on the compiled cable law")


def _slow_contact(w, ids):
    """The per-robot reference: each robot's contact list read and classified on its own."""
    m, rods = w.robot.model, w.robot.rods
    touch = np.zeros((ids.size, w._body.size))
    ends = np.zeros((ids.size, rods["body"].size))
    bars = np.zeros(ids.size)
    for row, i in enumerate(ids):
        d = w.batch.get_data(int(i))
        pair = m.geom_bodyid[d.contact.geom[:d.ncon]]
        inside = w._robot_body[pair].all(axis=1) & (pair[:, 0] != pair[:, 1])
        bars[row] = inside.sum()
        body_pos, body_mat = d.xpos, d.xmat.reshape(-1, 3, 3)
        for (a, b), point in zip(pair, d.contact.pos[:d.ncon], strict=True):
            if a != 0 and b != 0:
                continue
            body = max(a, b)
            if w._slot[body] >= 0:
                touch[row, w._slot[body]] = 1.0
            best, nearest = np.inf, -1
            for e, (rb, local) in enumerate(zip(rods["body"].ravel(),
                                                rods["local"].reshape(-1, 3), strict=True)):
                if rb == body:
                    far = np.linalg.norm(body_pos[rb] + body_mat[rb] @ local - point)
                    if far < best:
                        best, nearest = far, e
            if nearest >= 0:
                ends[row, nearest] = 1.0
    return touch, ends, bars


def test_contact_flags_and_bar_contacts_equal_the_per_robot_loop(tmp_path):
    path = tmp_path / "three_bar.yaml"
    path.write_text(three_bar())
    # (the bar-bar contact cost adds the pair sensors bar_contacts reads)
    config = EnvConfig(model=str(path), control_dt=0.02, observation=ROLLING_OBSERVATION,
                       randomization=Randomization(yaw=True, pose_noise_m=0.15),
                       bar_contact_cost=1.0)
    env = TensegrityVectorEnv(6, config, autoreset_mode="same_step")
    assert env.worlds._bar_rows is not None
    env.reset(seed=3)
    w, rng = env.worlds, np.random.default_rng(4)
    seen = np.zeros(3)
    for period in range(40):
        if period % 10 == 0:
            env.reset(seed=int(rng.integers(1 << 30)))
        env.step(rng.uniform(-1, 1, env.action_space.shape))
        ids = np.sort(rng.choice(env.num_envs, rng.integers(1, env.num_envs + 1),
                                 replace=False)).astype(np.int32)
        touch, ends, bars = _slow_contact(w, ids)
        fast_touch, fast_ends = w._contact(ids)
        np.testing.assert_array_equal(fast_touch, touch)
        np.testing.assert_array_equal(fast_ends, ends)
        np.testing.assert_array_equal(w.bar_contacts(ids), bars)
        seen += [touch.sum(), ends.sum(), bars.sum()]
    assert (seen > 0).all(), seen  # ground contacts, end caps and bar-bar contacts all met
