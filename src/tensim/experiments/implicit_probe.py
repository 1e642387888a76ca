"""Measurements behind the implicit cable law's choice (docs/speed.md, docs/architecture.md):
what sets the disturbance test's error at long steps, and what a law that solved its own cables'
implicit step, with nothing handed to MuJoCo's metric, would give
(``python -m tensim.experiments.implicit_probe loop-gain|peak|contacts|own-solve|spread|hold``).

- :func:`loop_gain`: ``h rho(diag(D) J M^-1 J^T)`` at a settled state, for the cables' own
  damping ``b`` and for the impedance laws' damping gains ``B`` (the gain of the explicit step's
  velocity feedback: above 2 a damper applied from the velocity at the step's start rings).
- :func:`peak_study`: the disturbance test's worst cable, where its peak lies against its
  level over the phases of the test.
- :func:`contact_study`: the disturbance test at a long step against its reference, as built,
  without the impedance laws' damping gains, and on MuJoCo's elliptic friction cones: the
  worst cable and the share of the push's samples in which the cables' length rates jump away
  from the reference's (:func:`velocity_jumps`).
- :func:`spread_study`: how far changes at the level of rounding (every cable's stiffness
  changed by 1e-9 or 1e-7 of itself) move the disturbance test's figure under each law.
- :func:`own_solve`: a probe, not a law of tensim: each step the cable forces of a robot with
  fixed or speed-limited rest lengths are computed in Python from a linearly implicit update of
  the cables alone and applied to MuJoCo's Euler step as plain forces (the robot of
  ``tensim.model.without_cable_law``). With ``theta`` = 0 it is the explicit law (it reproduces
  tensim's explicit runs); otherwise, with ``A = J M^-1 J^T`` and ``c = k h + b`` on the taut
  cables, the tension ``T`` solves ``(I + theta h C A) T = T_exp + theta k h xdot + theta h C J
  a_other``, where ``a_other = a_prev + M^-1 J^T T_prev`` (at the last step's state) is the last
  step's acceleration less the cables' share: the other forces (gravity, contacts, loads),
  lagged one step.
  ``coupled`` solves the whole system; ``own`` anticipates only each cable's own change (the
  diagonal of ``A``, its own effective mass) and takes the others' tensions from the last
  step; ``rowsum`` does the same with the row sums of ``|A|`` (diagonally dominant).
  Without the lagged term the update would soften a static stretch; with it a static state
  keeps the law's force exactly.
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import mujoco
import numpy as np

from tensim.experiments import laws
from tensim.model import WorldOptions, compile_structure
from tensim.model._compile import compile_spec, without_cable_law
from tensim.model._law_layout import A_REST, G_DAMPING, P_GAIN_B
from tensim.sim import NodeLoad, Simulation, ramp_hold_release
from tensim.structure import Structure

MODES = ("explicit", "own", "rowsum", "coupled")
STEPS_MS = (0.5, 1.0, 2.0, 4.0, 10.0)
RECORD_S = 0.02


def tendon_jacobian(m: mujoco.MjModel, d: mujoco.MjData, tendons: np.ndarray) -> np.ndarray:
    """(n, nv) dense Jacobians of ``tendons`` (MuJoCo keeps them sparse)."""
    jac = np.zeros((len(tendons), m.nv))
    for row, t in enumerate(tendons):
        adr, nnz = m.ten_J_rowadr[t], m.ten_J_rownnz[t]
        jac[row, m.ten_J_colind[adr:adr + nnz]] = d.ten_J[adr:adr + nnz]
    return jac


def cable_metric(m: mujoco.MjModel, d: mujoco.MjData, tendons: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(J, A = J M^-1 J^T): the cables' Jacobian and inverse effective mass [1/kg]."""
    jac = tendon_jacobian(m, d, tendons)
    solved = np.zeros_like(jac)
    mujoco.mj_solveM(m, d, solved, jac)
    return jac, jac @ solved.T


def loop_gain(name: str = "tetraspine3", steps_ms: Sequence[float] = (1.0, 2.0, 4.0),
              settle_s: float = 2.0) -> dict[str, dict[str, float]]:
    """Per step [ms]: ``h rho(diag(D) A)`` for D = the cables' damping b, the impedance laws'
    B, and B + b, and the largest ``h B_i A_ii`` (a cable's B on its own effective mass), on
    preset ``name`` settled under its controller at 1 ms."""
    from tensim.models import preset

    model = preset(name)
    compiled = compile_structure(model.build(), WorldOptions(timestep=1e-3))
    with Simulation(compiled, controller=model.controller()) as sim:
        sim.step(round(settle_s / sim.dt))
        m, d, n = sim.model, sim.data, compiled.n_cables
        _, metric = cable_metric(m, d, m.actuator_trnid[:n, 0])
        gains = {"b": m.actuator_gainprm[:n, G_DAMPING].copy(),
                 "B": m.actuator_dynprm[:n, P_GAIN_B].copy()}
    gains["B+b"] = gains["B"] + gains["b"]
    return {f"{ms:g}": _gains(ms / 1e3, gains, metric) for ms in steps_ms}


def _gains(h: float, gains: dict[str, np.ndarray], metric: np.ndarray) -> dict[str, float]:
    out = {key: float(np.abs(np.linalg.eigvals(h * g[:, None] * metric)).max())
           for key, g in gains.items()}
    out["B, one cable alone"] = float((h * gains["B"] * np.diag(metric)).max())
    return out


@dataclasses.dataclass(frozen=True)
class Probe:
    """A robot for :func:`own_solve`: ``wound`` cables' rest lengths move to a fraction of
    their start at their motor's speed; every other rest length stays."""

    structure: Structure
    duration: float
    loads: tuple[NodeLoad, ...] = ()
    wound: tuple[tuple[str, float], ...] = ()


def probes() -> dict[str, Probe]:
    """The laws study's SUPERball push and 3-bar winding (``tensim.experiments.laws``)."""
    from tensim.models import preset

    ball = preset("superball").build()
    push = ramp_hold_release(ball.nodes[0].name, (0.0, 1.0, 0.0), 150.0, 0.5, 0.2, 0.6, 0.2)
    return {"superball": Probe(ball, 3.0, (push,)),
            "three_bar": Probe(laws.three_bar(), 4.0,
                               wound=(("bottom_0", 0.75), ("vertical_1", 0.75)))}


def cable_tensions(mode: str, theta: float, dt: float, m: mujoco.MjModel, d: mujoco.MjData,
                   tendons: np.ndarray, explicit: np.ndarray, k: np.ndarray, b: np.ndarray,
                   taut: np.ndarray, last: tuple[np.ndarray, np.ndarray]
                   ) -> tuple[np.ndarray, np.ndarray]:
    """This step's tensions [N] under ``mode`` (see the module's docstring), and the
    acceleration they give, M^-1 J^T T (to add to the step's ``qacc`` for the next step's
    ``a_other``). ``last``: (a_other, the last step's tensions)."""
    if mode == "explicit" or not taut.any():
        return explicit, np.zeros(m.nv)
    jac, metric = cable_metric(m, d, tendons)
    c = theta * dt * np.where(taut, k * dt + b, 0.0)
    a_other, t_prev = last
    rhs = explicit + theta * dt * np.where(taut, k, 0.0) * d.ten_velocity[tendons]
    if mode == "coupled":
        tension = np.linalg.solve(np.eye(len(k)) + c[:, None] * metric, rhs + c * (jac @ a_other))
    else:  # the others' tensions lagged, each cable's own anticipated with ``own``
        own = np.diag(metric) if mode == "own" else np.abs(metric[:, taut]).sum(axis=1)
        lagged = jac @ a_other - metric @ t_prev + own * t_prev
        tension = (rhs + c * lagged) / (1.0 + c * own)
    tension = np.where(taut, np.maximum(tension, 0.0), 0.0)
    solved = np.zeros_like(jac)
    mujoco.mj_solveM(m, d, solved, jac)
    return tension, solved.T @ tension


def own_solve(probe: Probe, dt: float, mode: str = "explicit", theta: float = 0.5,
              contact: bool = True, discrete: bool = False) -> dict[str, np.ndarray] | None:
    """One run of ``probe`` at step ``dt`` [s] under ``mode`` (``MODES``) on MuJoCo's Euler step
    (``discrete``: its ``discrete`` step, with no cable in its metric); ``contact`` False turns
    contacts and gravity off. Returns the peak load-cell tension of each cable [N] and
    the centre of mass every ``RECORD_S`` (``time``, ``com``), or None where it blew up."""
    s = probe.structure
    compiled = compile_structure(s, WorldOptions(timestep=dt), tuple(p.node for p in probe.loads))
    start = mujoco.MjData(compiled.model)
    if compiled.model.nkey:
        mujoco.mj_resetDataKeyframe(compiled.model, start, 0)
    mujoco.mj_forward(compiled.model, start)
    n = compiled.n_cables
    rest = start.act[compiled.model.actuator_actadr[:n] + A_REST].copy()
    m = compile_spec(without_cable_law(compiled))
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_DISCRETE if discrete else \
        mujoco.mjtIntegrator.mjINT_EULER
    if not contact:
        m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
        m.opt.gravity[:] = 0.0
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = start.qpos, start.qvel
    k = np.array([c.stiffness for c in s.cables])
    b = np.array([c.damping for c in s.cables])
    names = [c.name for c in s.cables]
    wound = {names.index(w): share * rest[names.index(w)] for w, share in probe.wound}
    tendons = m.actuator_trnid[:n, 0]
    mujoco.mj_forward(m, d)  # the other forces' acceleration, for the first step's lagged term
    last = (d.qacc.copy(), np.zeros(n))
    peak, times, com = np.zeros(n), [], []
    every = round(RECORD_S / dt)
    for step in range(round(probe.duration / dt)):
        mujoco.mj_fwdPosition(m, d)
        mujoco.mj_fwdVelocity(m, d)
        if step % every == 0:
            times.append(d.time)
            com.append(d.subtree_com[0].copy())
        for i, target in wound.items():  # a kinematic motor: toward its target at its speed
            rest[i] = max(target, rest[i] - s.cables[i].motor.max_speed * dt)
        stretch = d.ten_length[tendons] - rest
        taut = stretch > 0.0
        spring = np.where(taut, k * stretch, 0.0)
        peak = np.maximum(peak, spring)
        explicit = np.where(taut, np.maximum(spring + b * d.ten_velocity[tendons], 0.0), 0.0)
        tension, pull = cable_tensions(mode, theta, dt, m, d, tendons, explicit, k, b, taut,
                                       last)
        d.ctrl[:n] = -tension
        for j, load in enumerate(probe.loads):
            d.ctrl[n + 3 * j:n + 3 * j + 3] = [np.interp(d.time, load.times, load.forces[:, a])
                                               for a in range(3)]
        mujoco.mj_step(m, d)
        last = (d.qacc + pull, tension)
        if not np.isfinite(d.qvel).all() or np.abs(d.qvel).max() > 200.0:
            return None
    return {"peak": peak, "time": np.array(times), "com": np.array(com)}


def compare(run: dict[str, np.ndarray], reference: dict[str, np.ndarray]) -> tuple[float, float,
                                                                                    float]:
    """(worst cable's max-tension change [%], largest distance of the centre of mass from the
    reference's at the same time [m], the reference's path length [m])."""
    change = 100.0 * (run["peak"] - reference["peak"]) / reference["peak"]
    at = np.stack([np.interp(run["time"], reference["time"], reference["com"][:, a])
                   for a in range(3)], axis=1)
    travel = float(np.linalg.norm(np.diff(reference["com"], axis=0), axis=1).sum())
    return (float(change[np.argmax(np.abs(change))]),
            float(np.linalg.norm(run["com"] - at, axis=1).max()), travel)


def own_solve_study(case: str, modes: Sequence[str] = ("coupled",), theta: float = 0.5,
                    contact: bool = True, steps_ms: Sequence[float] = STEPS_MS,
                    steps: Sequence[str] = ("euler",),
                    announce: Callable[[str], None] | None = None) -> list[str]:
    """Lines: ``case``'s 0.05 ms explicit reference (Euler), then per MuJoCo step (``euler``,
    ``discrete``), mode and step its errors."""
    probe = probes()[case]
    reference = own_solve(probe, 5e-5, contact=contact)
    if reference is None:
        raise RuntimeError(f"{case}: the reference blew up")
    lines = [f"{case}{'' if contact else ' (no contact, no gravity)'}: reference 0.05 ms "
             f"explicit, max tension {reference['peak'].max():.1f} N"]
    for integrator, mode in ((i, m) for i in steps for m in modes):
        for ms in steps_ms:
            if announce:
                announce(f"{case}: {mode} on {integrator} at {ms:g} ms")
            run = own_solve(probe, ms / 1e3, mode, theta, contact, integrator == "discrete")
            head = f"  {mode:<8} {integrator:<8} {ms:>4g} ms:"
            if run is None:
                lines.append(f"{head} blew up")
                continue
            tension, path, travel = compare(run, reference)
            share = f" ({100 * path / travel:5.1f} % of its travel)" if contact else ""
            lines.append(f"{head} max tension {tension:+7.2f} %, centre of mass "
                         f"{path * 1e3:6.1f} mm{share}")
    return lines


PHASES = ((25.0, 30.0), (30.0, 35.0), (35.0, 40.0), (40.0, 45.0), (50.0, 60.0))


def peak_study(dt: float = 4e-3, law: str = "implicit") -> dict[str, Any]:
    """The disturbance test at ``dt`` [s] under ``law`` against its 0.05 ms explicit reference:
    the worst cable, its peak change [%], when the recorded peaks fall [s], and the change of
    its mean tension over each of ``PHASES`` [%]."""
    from tensim.experiments.disturbance import run_disturbance

    runs = {key: run_disturbance(dt=step, world=WorldOptions(timestep=step, cable_law=name))[0]
            for key, step, name in (("reference", 5e-5, "explicit"), ("run", dt, law))}
    ref, run = runs["reference"], runs["run"]
    change = 100.0 * (run.peak_tension - ref.peak_tension) / ref.peak_tension
    worst = int(np.argmax(np.abs(change)))
    cable = run.cables[worst]
    series = {key: (r.trajectory.time, r.trajectory[f"tension/{cable}"]) for key, r in runs.items()}

    def mean(key: str, lo: float, hi: float) -> float:
        t, x = series[key]
        return float(x[(t >= lo) & (t < hi)].mean())

    return {"cable": cable, "change_percent": float(change[worst]),
            "reference_peak_N": float(ref.peak_tension[worst]),
            "peak_N": float(run.peak_tension[worst]),
            "recorded_peak_s": {key: float(t[np.argmax(x)]) for key, (t, x) in series.items()},
            "phase_change_percent": {f"{lo:g}-{hi:g}": 100.0 * (mean("run", lo, hi) / mean(
                "reference", lo, hi) - 1.0) for lo, hi in PHASES},
            "run_peak_over_hold_mean_percent": 100.0 * (run.peak_tension[worst] / mean(
                "run", 35.0, 40.0) - 1.0),
            "reference_peak_over_hold_mean_percent": 100.0 * (ref.peak_tension[worst] / mean(
                "reference", 35.0, 40.0) - 1.0)}


PUSH_S = (30.0, 45.0)  # the disturbance test's push: its rise, hold and fall [s]
JUMP_M_S = 5e-3  # a length rate this far from the reference's is a jump [m/s]


def velocity_jumps(time: np.ndarray, rates: np.ndarray, reference_time: np.ndarray,
                   reference_rates: np.ndarray, window: tuple[float, float] = PUSH_S,
                   threshold: float = JUMP_M_S) -> float:
    """The share of the samples in ``window`` [s] in which some cable's length rate is more
    than ``threshold`` [m/s] from the reference's at the same time (interpolated).

    Args:
        time: (n,) [s]. rates: (n, c) the cables' length rates [m/s].
        reference_time: (r,) [s]. reference_rates: (r, c) [m/s].
    """
    inside = (time >= window[0]) & (time < window[1])
    reference = np.stack([np.interp(time[inside], reference_time, reference_rates[:, j])
                          for j in range(rates.shape[1])], axis=1)
    return float((np.abs(rates[inside] - reference) > threshold).any(axis=1).mean())


def _rates(result: Any) -> tuple[np.ndarray, np.ndarray]:
    ts = result.trajectory
    return ts.time, np.stack([ts[f"velocity/{c}"] for c in result.cables], axis=1)


def contact_variants() -> dict[str, Callable[[WorldOptions], Any]]:
    """The disturbance test as built, with the impedance laws' damping gains B set to 0, on
    MuJoCo's elliptic friction cones, and with the contact time constant (0.02 s) halved and
    doubled (each against its own reference)."""
    return {"as built": laws._tetraspine3,
            "B = 0": laws._tetraspine3_variant(damping_scale=0.0),
            "elliptic cones": lambda world: laws._tetraspine3(
                dataclasses.replace(world, cone="elliptic")),
            **{f"contact time constant {tc:g} s": _timeconst(tc) for tc in (0.01, 0.04)}}


def _timeconst(tc: float) -> Callable[[WorldOptions], Any]:
    return lambda world: laws._tetraspine3(dataclasses.replace(world, contact_timeconst=tc))


def contact_study(dt: float = 4e-3, cable_laws: Sequence[str] = ("explicit", "implicit")
                  ) -> list[str]:
    """Per variant of :func:`contact_variants` and law at ``dt`` [s]: the worst cable's
    max-tension change against the 0.05 ms explicit reference [%], when its peak falls [s],
    the largest distance of the centre of mass [mm], and :func:`velocity_jumps` in the push."""
    lines = []
    for name, run in contact_variants().items():
        reference = run(WorldOptions(timestep=5e-5))
        lines.append(f"{name}:")
        for law in cable_laws:
            result = run(WorldOptions(timestep=dt, cable_law=law))
            tension, path = laws.compare(result, reference)
            change = (result.peak_tension - reference.peak_tension) / reference.peak_tension
            cable = result.cables[int(np.argmax(np.abs(change)))]
            ts = result.trajectory
            at = float(ts.time[np.argmax(ts[f"tension/{cable}"])])
            jumps = velocity_jumps(*_rates(result), *_rates(reference))
            lines.append(f"  {law:<9} {dt * 1e3:g} ms: max tension {tension:+.2f} % ({cable}, "
                         f"peak at {at:.2f} s), centre of mass {path * 1e3:.1f} mm, push "
                         f"samples with a jump {100 * jumps:.0f} %")
    return lines


SPREAD_SCALES = (0.0, 1e-9, 1e-7)  # relative changes of every cable's stiffness


def spread_study(steps_ms: Sequence[float] = (1.0, 2.0, 4.0),
                 rows: Sequence[str] = ("explicit", "implicit", laws.SPLIT),
                 scales: Sequence[float] = SPREAD_SCALES) -> list[str]:
    """The disturbance test's figure (the worst cable's max-tension change against the 0.05 ms
    explicit reference of the robot as built, [%]) per row of ``tensim experiment laws`` and
    step, with every cable's stiffness changed by each of ``scales`` (relative): how far changes
    at the level of rounding move it, against which the rows' differences are read."""
    reference = laws._tetraspine3(WorldOptions(timestep=5e-5))
    runs = {scale: laws._tetraspine3_variant(stiffness_scale=1.0 + scale) for scale in scales}
    lines = []
    for row in rows:
        for ms in steps_ms:
            world = laws.row_world(row, ms / 1e3)
            figures = [laws.compare(run(world), reference)[0] for run in runs.values()]
            lines.append(f"  {row:<9} {ms:>3g} ms: " + " ".join(f"{f:+6.2f} %" for f in figures))
    return lines


def main(argv: Sequence[str] | None = None) -> None:
    """The command line: ``loop-gain``, ``peak DT_MS LAW``, ``contacts``, ``spread``, ``hold``,
    ``own-solve CASE [MODES]``."""
    parser = argparse.ArgumentParser(prog="python -m tensim.experiments.implicit_probe")
    sub = parser.add_subparsers(dest="what", required=True)
    sub.add_parser("loop-gain")
    sub.add_parser("contacts")
    sub.add_parser("spread")
    sub.add_parser("hold")
    peak = sub.add_parser("peak")
    peak.add_argument("dt_ms", type=float)
    peak.add_argument("law")
    own = sub.add_parser("own-solve")
    own.add_argument("case", choices=sorted(probes()))
    own.add_argument("--modes", default="coupled")
    own.add_argument("--theta", type=float, default=0.5)
    own.add_argument("--no-contact", action="store_true")
    own.add_argument("--steps", default="euler", help="MuJoCo's steps: euler,discrete")
    args = parser.parse_args(argv)
    if args.what == "loop-gain":
        print("tetraspine3: h rho(D J M^-1 J^T) of the cables' damping b, the impedance laws' "
              "B and B + b (explicit velocity feedback rings above 2), and B on one cable alone")
        for ms, gains in loop_gain().items():
            print(f"  {ms:>3} ms: " + ", ".join(f"{k} {v:5.2f}" for k, v in gains.items()))
    elif args.what == "contacts":
        print("tetraspine3 at 4 ms against its 0.05 ms explicit reference; a jump: a cable's "
              "length rate more than 5 mm/s from the reference's, over the push (30-45 s)")
        for line in contact_study():
            print(line)
    elif args.what == "spread":
        print("tetraspine3: worst cable's max-tension change against the 0.05 ms explicit "
              "reference, with every cable's stiffness changed by " + ", ".join(
                  f"{scale:g}" for scale in SPREAD_SCALES))
        for line in spread_study():
            print(line)
    elif args.what == "hold":
        from tensim.experiments.controller_hold import hold_study

        print("tetraspine3 against its 0.05 ms explicit reference, the impedance laws and motors "
              "updated every step or held over 4 ms; over 34-40 s: the motor updates at their "
              "speed limit, the change of the cables' length rates between updates")
        for line in hold_study():
            print(line)
    elif args.what == "peak":
        r = peak_study(args.dt_ms / 1e3, args.law)
        print(f"tetraspine3, {args.law} at {args.dt_ms:g} ms: worst cable {r['cable']} "
              f"{r['change_percent']:+.2f} % ({r['reference_peak_N']:.3f} -> {r['peak_N']:.3f} N)"
              f", recorded peak at {r['recorded_peak_s']['run']:.2f} s (reference "
              f"{r['recorded_peak_s']['reference']:.2f} s)")
        print("  mean tension change by phase: " + ", ".join(
            f"{k} s {v:+.2f} %" for k, v in r["phase_change_percent"].items()))
        print(f"  peak above the hold's mean: {r['run_peak_over_hold_mean_percent']:.2f} % "
              f"(reference {r['reference_peak_over_hold_mean_percent']:.2f} %)")
    else:
        for line in own_solve_study(args.case, args.modes.split(","), args.theta,
                                    not args.no_contact, steps=args.steps.split(",")):
            print(line)


if __name__ == "__main__":
    main()
