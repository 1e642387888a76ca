"""Evaluating a learnt policy: the deterministic policy drives one robot for a while, and the
centre of mass's path, read from MjData, gives its speed in body lengths per second."""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path
from typing import Any

import numpy as np

from tensim._input import InputError
from tensim.control.rolling import heading_error_deg
from tensim.models import PRESETS
from tensim.rl.config import Randomization
from tensim.rl.policy import Policy, load
from tensim.rl.train import TrainSettings, load_settings
from tensim.sim.motion import yaw_change
from tensim.structure import body_length as structure_body_length

PHYSICS = ("friction", "stiffness", "damping", "mass", "motor_speed")  # evaluate's multipliers


def body_length(model: str) -> float:
    """The body length [m] of the robot ``model`` names (:func:`tensim.structure.body_length`)."""
    from tensim.models import load_model

    return structure_body_length(load_model(model))


def evaluation_randomization(physics: dict[str, float] | None = None) -> Randomization:
    """The evaluation's start: :meth:`Randomization.start` (a random heading, 2 mm of pose
    noise, no sensor noise), with the physics multipliers ``physics`` (``PHYSICS`` names
    them) fixed, whatever randomisation the policy was trained with.

    Raises:
        InputError: an unknown name or a multiplier that is not > 0.
    """
    physics = physics or {}
    unknown = sorted(set(physics) - set(PHYSICS))
    if unknown:
        raise InputError(f"physics multipliers: unknown {', '.join(unknown)} (expected "
                         f"{', '.join(PHYSICS)})")

    def fixed(name: str) -> tuple[float, float]:
        value = float(physics.get(name, 1.0))
        return value, value

    start = Randomization.start()
    return Randomization(friction=fixed("friction"), stiffness=fixed("stiffness"),
                         damping=fixed("damping"), mass=fixed("mass"),
                         motor_speed=fixed("motor_speed"), yaw=start.yaw,
                         pose_noise_m=start.pose_noise_m)


def run_policy(settings: TrainSettings, policy: Policy, duration_s: float, seed: int,
               frames: list[np.ndarray] | None = None,
               physics: dict[str, float] | None = None) -> dict[str, Any]:
    """Drives the robot with ``policy`` for ``duration_s`` seconds from the start ``seed``
    draws (:func:`evaluation_randomization` with the multipliers ``physics``); with
    ``frames``, appends about 15 images per second to it (offscreen OpenGL).

    Returns:
        ``time`` (T,) [s], ``com`` (T, 3) [m] (from MjData), ``heading`` (2,) the rewarded
        direction in the world (unit), ``yaw`` (T,) the turn about the vertical since the start
        [rad] (counter-clockwise; the turn task's measure, the best rigid fit of the rod
        ends' move from MjData, summed period by period),
        ``observations`` (T-1, n_obs), ``actions`` (T-1, n_motors), ``unstable`` and
        ``points`` (T, p, 3) the rod ends (or bodies) the yaw is fitted to [m].
    """
    from tensim.rl.env import TensegrityEnv

    config = settings.env_config(episode_s=duration_s,
                                 randomization=evaluation_randomization(physics))
    env = TensegrityEnv(config, render_mode=None if frames is None else "rgb_array")
    obs, _ = env.reset(seed=seed)
    every = max(1, round(1.0 / (15 * env.robot.config.control_dt)))
    worlds = env.worlds
    com = [worlds.f["subtree_com"][0, 0].copy()]
    everywhere = np.arange(1)
    points = [worlds.turn_points(everywhere)[0]]
    observations, actions, unstable = [], [], False
    for k in range(env.robot.config.max_steps):
        if frames is not None and k % every == 0:
            image = env.render()
            if image is not None:
                frames.append(image)
        action = policy(obs)
        observations.append(obs)
        actions.append(action)
        obs, _, terminated, _, info = env.step(action.astype(np.float32))
        com.append(worlds.f["subtree_com"][0, 0].copy())
        points.append(worlds.turn_points(everywhere)[0])
        if terminated:
            unstable = bool(info["unstable"])
            break
    env.close()
    dt = env.robot.config.control_dt
    cloud = np.array(points)
    turns = yaw_change(cloud[:-1], cloud[1:])
    return {"fps": round(1.0 / (every * dt)), "time": np.arange(len(com)) * dt,
            "com": np.array(com), "yaw": np.concatenate([[0.0], np.cumsum(turns)]),
            "heading": worlds.target[0].copy(), "points": cloud,
            "observations": np.array(observations), "actions": np.array(actions),
            "unstable": unstable}


def support_faces(points: np.ndarray) -> list[tuple[str, ...]]:
    """Per sample of ``points`` (T, p, 3) [m], the convex-hull face the robot stands on
    (:func:`~tensim.control.rolling.support_face`, points named by index): a policy that
    rolls visits several and puts every rod end on the ground; one that crawls or slides on
    one face does neither, whatever its speed."""
    from tensim.control.rolling import support_face

    return [support_face({str(i): p for i, p in enumerate(frame)}) for frame in points]


def load_policy(source: Path) -> tuple[TrainSettings, Policy]:
    """The settings and deterministic policy of a training run folder (its latest
    checkpoint) or of an exported ``policy.json`` (``tensim rl export``).

    Raises:
        InputError: ``source`` is neither, or a ``policy.json`` without its settings.
    """
    source = Path(source)
    if not source.is_file():
        from tensim.rl.export import policy_record

        meta, arrays = policy_record(source)
        n = len(arrays) // 2
        return load_settings(source), Policy(meta, [arrays[f"w{k}"] for k in range(n)],
                                             [arrays[f"b{k}"] for k in range(n)])
    try:
        runner = load(source)
    except (ValueError, KeyError, OSError) as err:
        raise InputError(f"{source}: not an exported policy ({err})") from err
    if "settings" not in runner.meta:
        raise InputError(f"{source}: exported without its training settings; export the run "
                         "again with `tensim rl export`")
    data = dict(runner.meta["settings"])
    if data["model"] not in PRESETS:  # the robot file exported beside it
        data["model"] = str(source.parent / data["model"])
    return TrainSettings(**data), runner


def evaluate(folder: Path, out: Path, duration_s: float = 30.0, seed: int = 0,
             video: bool = False, timestep: float | None = None,
             cable_law: str | None = None,
             physics: dict[str, float] | None = None) -> dict[str, Any]:
    """Evaluates the policy of ``folder`` (a training run, or an exported ``policy.json``) and
    writes a run folder ``out`` (``trajectory.parquet``, ``summary.json`` with
    ``body_lengths_per_s`` and ``heading_error_deg``, the angle from the heading to the net
    displacement, counter-clockwise, None below :data:`~tensim.control.rolling.MOVED_M`
    (:func:`~tensim.control.rolling.heading_error_deg`); ``path.png``,
    ``report.html``; with ``video``, ``video.mp4``). ``timestep`` [s] and ``cable_law``
    replace the physics the policy was trained with (None: as trained); ``physics`` holds
    fixed multipliers of the robot's friction, stiffness, damping, mass or motor speed
    (:func:`evaluation_randomization`; the start is drawn as in training without physics or
    sensor randomisation). The summary also holds ``yaw_turned_rad`` (counter-clockwise, the
    turn of :func:`run_policy`), ``yaw_rate_deg_per_s`` and ``displacement_body_lengths``
    (the centre of mass's net horizontal displacement over the body length), which say how
    well a ``turn`` policy turns in place, and whether it rolls: ``faces_visited`` (distinct
    support faces of the rod ends' hull, sampled every control period), ``support_changes``
    and ``ends_on_ground`` of ``ends`` (the rod ends that were ever in the support face).

    Raises:
        tensim.viz._gl.OffscreenUnavailable: ``video`` where no offscreen OpenGL works.

    Returns:
        the summary.
    """
    from tensim.runs import finish_run, replace_folder
    from tensim.sim import TimeSeries
    from tensim.viz.plots import new_figure, save_figure

    settings, policy = load_policy(folder)
    trained = {"timestep": settings.timestep, "cable_law": settings.cable_law}
    settings = dataclasses.replace(settings, timestep=timestep or settings.timestep,
                                   cable_law=cable_law or settings.cable_law)
    frames: list[np.ndarray] | None = [] if video else None
    run = run_policy(settings, policy, duration_s, seed, frames, physics)
    t, com, heading = run["time"], run["com"], run["heading"]
    moved = com[-1, :2] - com[0, :2]
    along = float(moved @ heading)
    error = heading_error_deg(moved, heading)
    length = body_length(settings.model)
    faces = support_faces(run["points"])
    summary = {"command": "rl evaluate", "policy_run": str(folder), "model": settings.model,
               "algo": settings.algo, "task": settings.task, "seed": seed,
               "duration_s": float(t[-1]), "body_length_m": round(length, 6),
               "displacement_along_heading_m": round(along, 6),
               "speed_m_per_s": round(along / t[-1], 6) if t[-1] > 0 else 0.0,
               "body_lengths_per_s": round(along / t[-1] / length, 6) if t[-1] > 0 else 0.0,
               "heading_world": [round(float(h), 6) for h in heading],
               "heading_error_deg": None if error is None else round(error, 3),
               "yaw_turned_rad": round(float(run["yaw"][-1]), 6),
               "yaw_rate_deg_per_s": round(float(np.degrees(run["yaw"][-1]) / t[-1]), 6)
               if t[-1] > 0 else 0.0,
               "displacement_body_lengths": round(float(np.hypot(*moved)) / length, 6),
               "faces_visited": len(set(faces)), "support_changes": int(sum(
                   a != b for a, b in itertools.pairwise(faces))),
               "ends_on_ground": len(set().union(*faces)),
               "ends": int(run["points"].shape[1]),
               "physics": dict(physics or {}),
               "training": policy.meta.get("training"),
               "unstable": run["unstable"], "timestep_s": settings.timestep,
               "cable_law": settings.cable_law, "trained_physics": trained}
    series = TimeSeries(t, {f"pos_{a}/com": com[:, k] for k, a in enumerate("xyz")})
    with replace_folder(out) as stage:
        series.to_parquet(stage / "trajectory.parquet")
        fig = new_figure((5.0, 5.0))
        ax = fig.add_subplot()
        ax.plot(com[:, 0], com[:, 1], label="centre of mass")
        ax.annotate("", com[0, :2] + heading * length, com[0, :2],
                    arrowprops={"arrowstyle": "->", "color": "grey"})
        ax.set(xlabel="x [m]", ylabel="y [m]", aspect="equal",
               title=f"{summary['body_lengths_per_s']:.3f} body lengths/s along the heading")
        save_figure(fig, stage / "path.png")
        if frames:
            from tensim.viz.video import write_video

            write_video(frames, stage / "video.mp4", run["fps"])
        finish_run(stage, summary, series)
    return summary
