"""The rolling task's reward terms for rolling itself: the turn about the rolling axis
(``roll_reward``) and the slip of the feet on the ground (``slip_cost``), against numbers
worked out by hand on constructed states."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

pytest.importorskip("gymnasium", reason="the rl extra (gymnasium) is not installed")

from tensim import InputError
from tensim.rl import (
    DEFAULT_OBSERVATION,
    ROLLING_OBSERVATION,
    EnvConfig,
    Randomization,
    TensegrityEnv,
)
from tensim.rl.evaluate import support_faces
from tensim.rl.train import TrainSettings, fingerprint
from tensim.sim import compiled_available
from tensim.sim.motion import roll_change

HEADING = np.array([np.cos(np.radians(30.0)), np.sin(np.radians(30.0))])


def _about(axis: np.ndarray, angle: float) -> np.ndarray:
    """The rotation matrix of ``angle`` [rad] about the unit ``axis`` (Rodrigues)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]],
                  [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def _prism() -> tuple[np.ndarray, np.ndarray]:
    """The six rod ends of a straight triangular prism (unit circumradius, 2 m long) lying on
    a side, its long axis horizontal and square to ``HEADING``, and that axis (unit)."""
    axis = np.array([-HEADING[1], HEADING[0], 0.0])  # z x heading: the rolling axis
    up, ahead = np.array([0.0, 0.0, 1.0]), np.array([*HEADING, 0.0])
    angles = np.radians([90.0, 210.0, 330.0])  # a vertex on top, a side down
    ends = np.array([x * axis + np.sin(a) * up + np.cos(a) * ahead
                     for x in (0.0, 2.0) for a in angles])
    return ends - [0.0, 0.0, ends[:, 2].min()], axis


def _roll_over(ends: np.ndarray, axis: np.ndarray, steps: int) -> np.ndarray:
    """(steps + 1, 6, 3) the prism rolled without slipping toward ``HEADING`` over its
    leading bottom edge through 120 degrees (onto its next side) in ``steps`` steps."""
    ahead = np.array([*HEADING, 0.0])
    bottom = ends[np.argsort(ends[:, 2])[:4]]  # the side it stands on
    pivot = bottom[np.argmax(bottom @ ahead)]  # on the leading edge, about which it tips
    return np.array([(ends - pivot) @ _about(axis, a).T + pivot
                     for a in np.linspace(0.0, 2 * np.pi / 3, steps + 1)])


def test_a_prism_rolled_through_its_faces_earns_the_angle_it_turned():
    # three tips of 120 degrees over the leading edge (rolling without slipping, each about a
    # new pivot, 2 pi about the rolling axis in all) along a heading of 30 degrees: the term
    # sums to 2 pi, the prism stands on three sides in turn with all six ends on the ground
    ends, axis = _prism()
    path = [ends]
    for _ in range(3):
        path.extend(_roll_over(path[-1], axis, 20)[1:])
    path = np.array(path)
    heading = np.tile(HEADING, (len(path) - 1, 1))
    turned = roll_change(path[:-1], path[1:], heading)
    assert turned.sum() == pytest.approx(2 * np.pi, abs=1e-9)  # (rigid moves: exact fits)
    assert turned == pytest.approx(np.full(60, 2 * np.pi / 60), abs=1e-9)
    # it moved along the heading by the perimeter of its triangle, 3 sqrt(3) for a unit
    # circumradius: r = 3 sqrt(3) / (2 pi) metres per radian
    moved = (path[-1] - path[0]).mean(axis=0)[:2] @ HEADING
    assert moved == pytest.approx(3 * np.sqrt(3), abs=1e-9)
    faces = support_faces(path[::20])
    assert len(set(faces)) == 3 and set().union(*faces) == {str(i) for i in range(6)}
    # rolled back it earns the turn back: rocking over an edge and back sums to 0
    back = roll_change(path[1:][::-1], path[:-1][::-1], heading)
    assert back.sum() == pytest.approx(-2 * np.pi, abs=1e-9)


def test_turns_about_other_axes_and_moves_without_turning_earn_no_roll():
    ends, _ = _prism()
    heading = HEADING[None]
    for moved in (ends + np.array([0.3, -0.2, 0.1]),  # slid, no turn
                  ends @ _about(np.array([0.0, 0.0, 1.0]), 0.4).T,  # turned about the vertical
                  ends @ _about(np.array([*HEADING, 0.0]), 0.4).T):  # about the heading
        assert roll_change(ends[None], moved[None], heading)[0] == pytest.approx(
            0.0, abs=1e-12)
    # rolling toward the heading is positive, away from it negative, for any heading
    for deg in (0.0, 100.0, -135.0):
        h = np.array([[np.cos(np.radians(deg)), np.sin(np.radians(deg))]])
        roll_axis = np.array([-h[0, 1], h[0, 0], 0.0])
        top = np.array([[0.0, 0.0, 1.0], [0.5, 0.2, 0.0], [-0.3, 0.4, 0.2]])
        turned = top @ _about(roll_axis, 0.1).T
        assert roll_change(top[None], turned[None], h)[0] == pytest.approx(0.1, abs=1e-12)
        assert (turned[0, :2] - top[0, :2]) @ h[0] > 0  # the top moved ahead: rolling


needs_engine = pytest.mark.skipif(not compiled_available(),
                                  reason="the environments step on the compiled cable law")


def _moving(env: TensegrityEnv, qvel: np.ndarray) -> None:
    """Gives robot 0 of ``env`` the velocities ``qvel`` at its present pose."""
    worlds = env.worlds
    m, d = env.robot.model, mujoco.MjData(env.robot.model)
    mujoco.mj_setState(m, d, worlds.state(0), mujoco.mjtState.mjSTATE_INTEGRATION)
    d.qvel[:] = qvel
    state = np.empty(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_INTEGRATION))
    mujoco.mj_getState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
    worlds.batch.state[0] = state
    worlds.batch.forward(np.arange(1, dtype=np.int32))


@needs_engine
@pytest.mark.parametrize("observation", [DEFAULT_OBSERVATION, ROLLING_OBSERVATION])
def test_slip_is_the_horizontal_speed_of_the_ends_on_the_ground(observation):
    # the feet's contacts from MuJoCo's contact list, or (the rolling observation's end-cap
    # flags) from the contact sensors; the build pose, which stands on three rod ends
    config = EnvConfig(model="three_bar", control_dt=0.02, slip_cost=1.0,
                       observation=observation, randomization=Randomization(),
                       world=dataclasses.replace(EnvConfig().world, timestep=0.002,
                                                 cable_law="implicitfast"))
    env = TensegrityEnv(config)
    env.reset(seed=0)
    worlds, ids = env.worlds, np.arange(1)
    ends = worlds._end_positions(ids)[0]
    radius = float(env.robot.model.geom_size[env.robot.model.geom_bodyid
                                             == worlds._end_body[0], 0].max())
    low = ends[:, 2] < radius + 0.01  # the ends resting on the ground (within 1 cm)
    assert low.sum() == 3 and worlds._contact(ids)[1][0] @ low == 3
    # every bar sliding at (0.3, -0.4, 0.1) m/s without turning: 0.5 m/s at each foot (the
    # vertical part is no slip)
    nv = env.robot.model.nv
    bodies = env.robot.model.jnt_dofadr[env.robot.model.jnt_type == mujoco.mjtJoint.mjJNT_FREE]
    qvel = np.zeros(nv)
    for dof in bodies:
        qvel[dof:dof + 3] = [0.3, -0.4, 0.1]
    _moving(env, qvel)
    assert worlds.slip(ids)[0] == pytest.approx(0.5 * low.sum(), rel=1e-9)
    # each bar spinning at 2 rad/s about the vertical through its centre of mass (free
    # joints' angular velocity is in the body frame: the world's z turned into it): each foot
    # moves at 2 rad/s times its horizontal distance from its bar's centre
    qvel[:] = 0.0
    xipos, xmat = worlds.f["xipos"][0], worlds.f["xmat"][0].reshape(-1, 3, 3)
    for dof, body in zip(bodies, worlds._body, strict=True):
        qvel[dof + 3:dof + 6] = xmat[body].T @ [0.0, 0.0, 2.0]
    _moving(env, qvel)
    centre = xipos[worlds._end_body]
    expected = 2.0 * np.hypot(*(ends - centre)[:, :2].T)[low].sum()
    assert worlds.slip(ids)[0] == pytest.approx(expected, rel=1e-9)


@needs_engine
def test_the_step_reward_adds_the_roll_and_slip_terms():
    from tensim.sim.motion import roll_change as roll

    settings = TrainSettings(model="three_bar", heading_deg=-30.0, roll_reward=0.3,
                             slip_cost=0.2)
    env = TensegrityEnv(settings.env_config())
    env.reset(seed=1)
    rng = np.random.default_rng(0)
    ids = np.arange(1)
    for _ in range(5):
        before = env.worlds.turn_points(ids)
        _, reward, _, _, info = env.step(rng.uniform(-1, 1, 6).astype(np.float32))
        turned = roll(before, env.worlds.turn_points(ids), env.worlds.target)[0]
        assert info["reward_roll"] == pytest.approx(0.3 * turned, rel=1e-12, abs=1e-15)
        assert info["reward_slip"] == pytest.approx(-0.2 * env.worlds.slip(ids)[0] * 0.02,
                                                    rel=1e-12, abs=1e-15)
        assert reward == pytest.approx(info["reward_progress"] + info["reward_control"]
                                       + info["reward_contact"] + info["reward_roll"]
                                       + info["reward_slip"], rel=1e-12, abs=1e-15)


def test_the_rolling_terms_are_validated_and_leave_old_fingerprints():
    with pytest.raises(InputError, match="roll_reward must be a finite number >= 0"):
        EnvConfig(roll_reward=-1.0)
    with pytest.raises(InputError, match="slip_cost must be a finite number >= 0"):
        EnvConfig(slip_cost=float("nan"))
    with pytest.raises(InputError, match="needs task 'direction', got task 'turn'"):
        EnvConfig(task="turn", roll_reward=0.3)
    with pytest.raises(InputError, match=r"--roll-reward .* needs --task roll"):
        TrainSettings(model="three_bar", task="turn", roll_reward=0.3)
    with pytest.raises(InputError, match="--slip-cost must be"):
        TrainSettings(model="three_bar", slip_cost=-0.1)
    plain = TrainSettings(model="three_bar")
    assert plain.env_config().roll_reward == plain.env_config().slip_cost == 0.0
    rolling = dataclasses.replace(plain, roll_reward=0.3)
    assert rolling.env_config().roll_reward == 0.3
    # runs from before the terms existed keep their fingerprint (resumable); others differ
    import hashlib
    import json

    record = dataclasses.asdict(plain) | {"steps": 0}
    for name in ("randomization", "roll_reward", "slip_cost", "rollout_steps", "action"):
        del record[name]
    old = hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest()[:16]
    assert fingerprint(plain) == old != fingerprint(rolling)
