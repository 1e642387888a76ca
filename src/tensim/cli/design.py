"""``tensim design``: self-stress, stiffness, inverse statics and motor sizing of a structure."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tensim.cli._common import load_model, output_option, positive

if TYPE_CHECKING:
    from tensim.design.motors import CableDuty, TrackedPeaks


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("design", help="design a structure: prestress, stiffness, which cable to "
                       "pull, motor sizing (see docs/design.md)")
    steps = p.add_subparsers(dest="step", required=True)
    q = steps.add_parser("prestress", help="states of self-stress and mechanisms; write an "
                         "all-tension prestressed structure")
    q.add_argument("model", help="preset name or structure .yaml file")
    level = q.add_mutually_exclusive_group(required=True)
    level.add_argument("--min-tension", type=positive, metavar="N",
                       help="smallest cable tension [N]")
    level.add_argument("--tension", type=positive, metavar="N",
                       help="tension of the cable named by --cable [N]")
    level.add_argument("--force-density", type=positive, metavar="Q",
                       help="mean cable force density t/L [N/m]")
    q.add_argument("--cable", default=None, help="the cable that --tension sets")
    output_option(q, "--out", "file", default=None, metavar="FILE.yaml",
                   help="write the prestressed structure here")
    q.set_defaults(run=run_prestress)
    s = steps.add_parser("stiffness", help="tangent stiffness, mechanisms stiffened by "
                         "prestress, natural frequencies and the softest modes")
    s.add_argument("model", help="preset name or structure .yaml file")
    s.add_argument("--modes", type=int, default=4, help="softest modes to list and draw")
    output_option(s, "--out", "folder", default=None,
                  help="output folder (modes.png, stiffness.json)")
    s.set_defaults(run=run_stiffness)
    register_size(steps)
    register_pull(steps)
    register_form(steps)
    register_members(steps)
    register_loads(steps)


def _node_vector(text: str, sep: str, form: str) -> tuple[str, tuple[float, float, float]]:
    """``NODE<sep>X,Y,Z`` as (node, vector); ``form`` names the expected text in the error."""
    node, _, rest = text.partition(sep)
    try:
        values = tuple(float(v) for v in rest.split(","))
    except ValueError:
        values = ()
    if not node or len(values) != 3 or not all(map(math.isfinite, values)):
        raise argparse.ArgumentTypeError(f"expected {form}, got {text!r}")
    return node, values


def _load(text: str) -> tuple[str, tuple[float, float, float]]:
    """``NODE:FX,FY,FZ`` as (node, force [N])."""
    return _node_vector(text, ":", "NODE:FX,FY,FZ in newtons")


def register_loads(steps: argparse._SubParsersAction) -> None:
    d = steps.add_parser("loads", help="static response to node loads; load factors at which "
                         "the first cable slackens and the first rod buckles")
    d.add_argument("model", help="preset name or structure .yaml file")
    d.add_argument("--load", type=_load, action="append", required=True,
                   metavar="NODE:FX,FY,FZ", help="world-frame force at NODE [N]; repeatable")
    d.add_argument("--free", action="store_true", help="no feet: zero gravity, held only by "
                   "the structure's fixed nodes (with none, the load must balance itself)")
    d.set_defaults(run=run_loads)


def run_loads(args: argparse.Namespace) -> int:
    import numpy as np

    from tensim.design.loading import load_response
    from tensim.design.report import table

    structure = load_model(args.model)
    loads = dict(args.load)
    result = load_response(structure, loads, supports=not args.free)
    where = (f"standing on {', '.join(result.supports)} (pinned), under gravity"
             if result.supports else "free, at zero gravity")
    print(f"{structure.name} {where}; load " + ", ".join(
        f"{n} ({', '.join(f'{v:g}' for v in f)}) N" for n, f in loads.items()))
    def mm(values: np.ndarray) -> list[str]:  # to 0.01 mm: finer digits are round-off
        return [f"{round(1e3 * float(v), 2) + 0.0:.2f}" for v in values]

    print(table([(n, *mm(result.linear[n]), *mm(result.exact[n])) for n in result.linear
                 if n not in result.supports],  # the pinned feet move by microns
                ("node", "dx [mm]", "dy [mm]", "dz [mm]", "exact dx", "exact dy", "exact dz")))
    print(table([(c.name, t0, t1) for c, t0, t1 in zip(
        structure.cables, result.tensions[0], result.tensions[1], strict=True)],
        ("cable", "tension [N]", "loaded [N]")))
    if result.supports:
        print(table([(n, f[0, 2], np.hypot(*f[0, :2]) / f[0, 2], f[1, 2],
                      np.hypot(*f[1, :2]) / f[1, 2] if f[1, 2] > 0 else "lifts",
                      result.friction[n]) for n, f in result.ground.items()],
                    ("foot", "normal [N]", "friction used", "loaded [N]", "loaded used",
                     "friction")))
        for what, factor in (("a foot lifts (the ground cannot pull)", result.lift_factor),
                             ("a foot needs all its friction", result.slip_factor)):
            print(f"{what}: at load factor {factor:.4g}" if factor is not None else
                  f"{what}: not below a load factor of 1e4")
    if result.lost_factor is not None:
        print(f"no static pose past load factor {result.lost_factor:.4g} (it folds or falls) "
              "while every cable is still taut")
    elif result.slack_factor is None:
        print("no cable slackens below a load factor of 1e4")
    else:
        print(f"first cable to slacken: {result.slack_cable} at load factor "
              f"{result.slack_factor:.4g} (linear estimate {result.slack_linear:.4g})")
    if result.buckle_rod is not None:
        print(f"first rod to buckle: {result.buckle_rod} at load factor "
              f"{result.buckle_factor:.4g}")
    elif result.buckle_factor is not None:
        print(f"no rod buckles before the static pose is lost (it folds or falls) at load "
              f"factor {result.buckle_factor:.4g}")
    elif any(r.section is not None for r in structure.rods):
        print("no rod buckles below a load factor of 1e4")
    else:
        print("rods without a section: no buckling check")
    return 0


def register_members(steps: argparse._SubParsersAction) -> None:
    m = steps.add_parser("members", help="rods against Euler buckling and yield, cables "
                         "against their breaking load, from the prestress or runs' peaks")
    m.add_argument("model", help="preset name or structure .yaml file (rods with a section, "
                   "cables with a breaking_load)")
    m.add_argument("runs", nargs="*", metavar="RUN", help="run folders of this structure "
                   "(trajectory.parquet): check the peaks of their forces instead of the "
                   "prestress")
    m.set_defaults(run=run_members)


def _percent(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.1f}"


def run_members(args: argparse.Namespace) -> int:
    """Prints the member checks; exits 1 when a member fails."""
    import numpy as np

    from tensim.design._bodies import cable_tensions
    from tensim.design.members import (
        bar_forces,
        cable_checks,
        rod_checks,
        section_mass,
        worst_margin,
    )
    from tensim.design.report import table
    from tensim.sim import TimeSeries

    structure = load_model(args.model)
    if args.runs:
        from tensim.design.member_peaks import run_peaks

        tensions = np.zeros(len(structure.cables))
        forces: dict[str, float | None] = {r.name: 0.0 for r in structure.rods}
        for folder in map(Path, args.runs):
            peak, peak_forces = run_peaks(structure, TimeSeries.from_parquet(
                folder / "trajectory.parquet"))
            tensions = np.maximum(tensions, peak)
            for name, force in peak_forces.items():
                held = forces[name]
                forces[name] = None if force is None or held is None else \
                    (force if abs(force) > abs(held) else held)
        print(f"peak forces of {len(args.runs)} run(s)")
    else:
        tensions = cable_tensions(structure)
        forces = bar_forces(structure, tensions)
        print("forces of the prestress (build pose, gravity left out)")
    rods = rod_checks(structure, forces)
    cables = cable_checks(structure, tensions)
    print(table([(r.rod, "-" if r.force is None else f"{r.force:.4g}", r.length,
                  "-" if r.buckling_load is None else f"{r.buckling_load:.4g}",
                  _percent(r.buckling_margin),
                  "-" if r.yield_load is None else f"{r.yield_load:.4g}",
                  _percent(r.yield_margin)) for r in rods],
                ("rod", "force [N]", "length [m]", "buckling [N]", "margin [%]", "yield [N]",
                 "margin [%]")))
    print(table([(c.cable, c.tension, "-" if c.breaking_load is None else
                  f"{c.breaking_load:.4g}", _percent(c.margin)) for c in cables],
                ("cable", "tension [N]", "breaking [N]", "margin [%]")))
    mass, modelled = section_mass(structure)
    print(f"mass with the rods' sections {mass:.4g} kg (as modelled {modelled:.4g} kg)")
    worst = worst_margin(rods, cables)
    if worst < 0:
        print(f"tensim: a member fails: the smallest margin is {100 * worst:.1f} %")
        return 1
    return 0


def register_form(steps: argparse._SubParsersAction) -> None:
    f = steps.add_parser("form", help="form finding: node positions and pretensions from a "
                         "topology file (force density method)")
    f.add_argument("topology", help="topology .yaml file (nodes, rods, cables, groups)")
    f.add_argument("--min-tension", type=positive, default=None, metavar="N",
                   help="smallest cable tension [N] (default: the file's min_tension, else "
                        "the force densities as given, in N/m)")
    f.add_argument("--out", required=True, metavar="FILE.yaml",
                   help="write the formed structure here")
    f.set_defaults(run=run_form)


def run_form(args: argparse.Namespace) -> int:
    import dataclasses

    from tensim.design.form_finding import form
    from tensim.design.report import table
    from tensim.design.topology import load_topology
    from tensim.structure import StructureError, save_structure

    if Path(args.out).resolve() == Path(args.topology).resolve():
        raise ValueError(f"--out {args.out}: is the topology file this command reads; "
                         "give another path")
    topology = load_topology(args.topology)
    if args.min_tension is not None:
        topology = dataclasses.replace(topology, min_tension=args.min_tension)
    try:
        result = form(topology)
    except StructureError as err:  # a rod's or cable's own fields, checked once formed
        raise err.with_source(args.topology) from None
    structure = result.structure
    print(f"{structure.name}: {result.nodes} nodes, {len(structure.rods)} rods, "
          f"{len(structure.cables)} cables; force density matrix of rank {result.rank} (a 3D "
          f"form needs <= {result.nodes - 4}), "
          f"{'super-stable' if result.super_stable else 'not super-stable'}")
    counts = {g: 0 for g in result.force_densities}
    for member in topology.members:
        counts[member.group] += 1
    print(table([(g, counts[g], q, *result.lengths[g], q * result.lengths[g][1])
                 for g, q in result.force_densities.items()],
                ("group", "members", "q [N/m]", "shortest [m]", "longest [m]", "force [N]")))
    save_structure(structure, Path(args.out))
    print(f"wrote {args.out}")
    return 0


def run_prestress(args: argparse.Namespace) -> int:
    from tensim.design import equilibrium, prestressed, self_stress
    from tensim.design.report import table
    from tensim.structure import save_structure

    structure = load_model(args.model)
    if (args.cable is None) != (args.tension is None):
        raise ValueError("--tension needs --cable NAME (and --cable needs --tension)")
    eq = equilibrium(structure)
    print(f"{structure.name}: {len(eq.cables)} cables, {eq.n_dof} degrees of freedom, "
          f"rank(A) = {eq.rank}")
    print(f"states of self-stress s = {eq.s}; mechanisms m = {eq.m} ({eq.n_rigid} rigid-body "
          f"motions, {eq.internal_mechanisms} internal)")
    stress = self_stress(structure, min_tension=args.min_tension, cable=args.cable,
                         tension=args.tension, force_density=args.force_density)
    rest = stress.lengths - stress.tensions / [c.stiffness for c in structure.cables]
    print(table([(n, t, q, L, r) for n, t, q, L, r in zip(
        stress.cables, stress.tensions, stress.force_densities, stress.lengths, rest,
        strict=True)], ("cable", "tension [N]", "q [N/m]", "length [m]", "rest [m]")))
    if stress.rod_forces:
        print(table(sorted(stress.rod_forces.items()), ("rod", "axial force [N]")))
    if args.out:
        save_structure(prestressed(structure, stress), Path(args.out))
        print(f"wrote {args.out}")
    return 0


def run_stiffness(args: argparse.Namespace) -> int:
    from tensim.design.report import modes_figure, save, table
    from tensim.design.stiffness import stable_timestep, stiffness
    from tensim.runs import finish_run, replace_folder

    structure = load_model(args.model)
    result = stiffness(structure)
    print(f"{structure.name}: {len(result.frequencies)} degrees of freedom, {result.rigid} "
          f"rigid-body motions, {result.mechanisms} internal mechanisms, {result.stiffened} "
          "of them stiffened by prestress")
    live = [k for k in range(len(result.frequencies)) if result.frequencies[k] > 1e-6]
    rows = [(k + 1, float(result.frequencies[k])) for k in live[:args.modes]]
    print(table(rows, ("mode", "frequency [Hz]")))
    limit, frequency, zeta = stable_timestep(result)
    print(f"highest frequency {result.frequencies[-1]:.4g} Hz; Euler step stable below "
          f"{limit * 1e3:.4g} ms (bound set by the {frequency:.4g} Hz mode, damping ratio "
          f"{zeta:.3g})")
    if args.out:
        with replace_folder(Path(args.out)) as stage:
            save(modes_figure(structure, result, args.modes), stage / "modes.png")
            finish_run(stage, {"model": args.model, "rigid": result.rigid,
                               "mechanisms": result.mechanisms, "stiffened": result.stiffened,
                               "frequencies_Hz": [round(float(f), 6) for f in
                                                  result.frequencies],
                               "stable_timestep_s": limit})
        print(f"wrote {args.out}/ (modes.png, summary.json)")
    return 0


def register_size(steps: argparse._SubParsersAction) -> None:
    z = steps.add_parser("size", help="motor sizing from run folders: per-cable tension, "
                         "speed, power, work; shaft torque and speed; catalogue pass/fail")
    z.add_argument("runs", nargs="*", metavar="RUN", help="run folders (trajectory.parquet)")
    z.add_argument("--model", default=None, help="instead of run folders: run this preset or "
                   "structure file under --controller on --robots randomised robots")
    z.add_argument("--controller", default=None, help="controller file or shipped name for "
                   "--model (default: the preset's own)")
    z.add_argument("--robots", type=int, default=8, help="randomised robots for --model "
                   "(default 8)")
    z.add_argument("--spread", type=float, default=0.1, help="each robot's stiffness, "
                   "damping, masses and friction scaled by U[1 - s, 1 + s] (default 0.1)")
    z.add_argument("--seed", type=int, default=0, help="seed of the randomisation")
    z.add_argument("--duration", type=positive, default=None, metavar="S",
                   help="simulated time per robot [s] (default: the gait's duration)")
    z.add_argument("--spool-radius", type=positive, required=True, metavar="M",
                   help="spool radius [m]")
    z.add_argument("--gear", type=positive, default=1.0, help="gear ratio N [-] (default 1)")
    z.add_argument("--safety", type=positive, default=1.15,
                   help="safety factor on tension and speed (default 1.15, the paper's)")
    z.add_argument("--period", type=positive, default=None, metavar="S",
                   help="gait cycle [s]: report work per cycle (default: over the run)")
    z.add_argument("--motors", default=None, metavar="FILE.yaml",
                   help="catalogue: motors: [{name, stall_torque [N m], no_load_speed [rad/s]}]")
    output_option(z, "--out", "folder", default="runs/size", help="output folder")
    z.set_defaults(run=run_size)


def run_size(args: argparse.Namespace) -> int:
    """Prints and writes the sizing; exits 1 when no catalogue motor suffices."""
    from tensim.design import motors
    from tensim.design.report import save, sizing_figure, table
    from tensim.runs import STRUCTURE_FILE, check_run_folder, finish_run, replace_folder
    from tensim.sim import TimeSeries
    from tensim.structure import load_structure

    check_run_folder(Path(args.out))
    if bool(args.runs) == bool(args.model):
        raise ValueError("give run folders or --model (with --controller), not both")
    catalogue = motors.load_catalogue(args.motors) if args.motors else []
    if args.model:
        duties = _robot_duties(args)
    else:
        runs = []
        for folder in map(Path, args.runs):
            limits = {}
            if (folder / STRUCTURE_FILE).exists():
                limits = {c.name: (c.motor.max_speed, c.motor.max_tension)
                          for c in load_structure(folder / STRUCTURE_FILE).cables}
            series = TimeSeries.from_parquet(folder / "trajectory.parquet")
            summary = _run_summary(folder)
            tracked = _tracked_peaks(summary)
            if not tracked:  # a run without them: its samples must catch the peaks
                motors.check_sampling(series, _tracked_tensions(summary), str(folder))
            elif note := motors.sampling_note(series, tracked, str(folder)):
                print(f"tensim: note: {note}", file=sys.stderr)
            runs.append(motors.cable_duty(series, limits, tracked))
        duties = motors.merge(runs)
    source = ("tracked at every physics step" if all(d.tracked for d in duties) else
              "from the recorded samples (the runs do not track them)")
    print(f"peak tension, line speed and power: {source}")
    needs = motors.requirements(duties, args.spool_radius, args.gear, args.safety)
    period = args.period
    rows = [(d.cable, d.peak_tension, d.rms_tension, d.peak_speed, d.peak_power, d.mean_power,
             d.work_per_cycle(period) if period else d.work, 100 * d.at_speed_limit,
             100 * d.at_force_limit, n.torque, n.speed) for d, n in zip(duties, needs, strict=True)]
    header = ("cable", "peak T [N]", "rms T [N]", "peak u [m/s]", "peak P [W]", "mean P [W]",
              "W/cycle [J]" if period else "W [J]", "at u lim [%]", "at T lim [%]",
              "tau [N m]", "omega [rad/s]")
    print(table(rows, header))
    print(f"shaft needs (safety {args.safety:g}, spool {args.spool_radius:g} m, gear "
          f"{args.gear:g}): {max(n.torque for n in needs):.4g} N m, "
          f"{max(n.speed for n in needs):.4g} rad/s")
    verdicts = {m.name: min(motors.margin(d, m, args.spool_radius, args.gear, args.safety)
                            for d in duties) for m in catalogue}
    for name, value in verdicts.items():
        print(f"motor {name}: {'pass' if value >= 0 else 'FAIL'}, margin {100 * value:.1f} %")
    with replace_folder(Path(args.out)) as stage:
        save(sizing_figure(duties, catalogue, args.spool_radius, args.gear, args.safety),
             stage / "operating_points.png")
        finish_run(stage, {"runs": [str(r) for r in args.runs], "model": args.model,
                           "robots": args.robots if args.model else None,
                           "safety_factor": args.safety,
                           "peaks_tracked": all(d.tracked for d in duties),
                           "spool_radius_m": args.spool_radius, "gear_ratio": args.gear,
                           "cables": [dict(zip(header, row, strict=True)) for row in rows],
                           "motor_margins": verdicts})
    print(f"wrote {args.out}/ (operating_points.png, summary.json)")
    if catalogue and max(verdicts.values()) < 0:
        best = max(verdicts, key=lambda k: verdicts[k])
        print(f"tensim: no motor in {args.motors} is strong enough; the strongest of them "
              f"({best}) falls short by {-100 * verdicts[best]:.0f} % of its torque-speed line")
        return 1
    return 0


def _run_summary(folder: Path) -> dict[str, object]:
    """A run folder's ``summary.json`` (empty when missing or unreadable)."""
    import json

    try:
        summary = json.loads((folder / "summary.json").read_text())
    except (OSError, ValueError):
        return {}
    return summary if isinstance(summary, dict) else {}


def _tracked_tensions(summary: dict[str, object], key: str = "max_tension_N"
                      ) -> dict[str, float]:
    """Per cable, a peak over every physics step from a run's summary (``key``: tension [N],
    ``max_line_speed_m_s`` or ``max_power_W``; empty when the summary lacks it)."""
    peaks = summary.get(key)
    return {str(k): float(v) for k, v in peaks.items()
            if isinstance(v, (int, float))} if isinstance(peaks, dict) else {}


def _tracked_peaks(summary: dict[str, object]) -> dict[str, TrackedPeaks]:
    """Per cable, the peak tension, line speed and power over every physics step from a run's
    summary (empty unless it has all three: a run of an older tensim has only the tension)."""
    from tensim.design.motors import TrackedPeaks

    tension, speed, power = (_tracked_tensions(summary, key) for key in
                             ("max_tension_N", "max_line_speed_m_s", "max_power_W"))
    if not speed or not (set(tension) == set(speed) == set(power)):
        return {}
    return {c: TrackedPeaks(tension[c], speed[c], power[c]) for c in tension}


def _move(text: str) -> tuple[str, tuple[float, float, float]]:
    """``NODE=DX,DY,DZ`` as (node, displacement [m])."""
    return _node_vector(text, "=", "NODE=DX,DY,DZ in metres")


def register_pull(steps: argparse._SubParsersAction) -> None:
    u = steps.add_parser("pull", help="which cables to pull: rest lengths that hold nodes "
                         "displaced, standing on the ground (inverse statics)")
    u.add_argument("model", help="preset name or structure .yaml file")
    u.add_argument("--move", type=_move, action="append", required=True,
                   metavar="NODE=DX,DY,DZ", help="displace NODE by (DX, DY, DZ) [m]; repeatable")
    u.add_argument("--min-tension", type=positive, default=1.0,
                   help="every cable keeps at least this tension [N] (default 1)")
    u.add_argument("--tolerance", type=positive, default=1e-3,
                   help="distance from a target that counts as reached [m] (default 0.001)")
    u.add_argument("--verify", action="store_true",
                   help="simulate the motors winding there slowly (0.01 m/s) and resting 2 s; "
                        "report each node's distance from the static answer")
    output_option(u, "--out", "folder", default="runs/pull",
                  help="output folder (controller.yaml: the "
                  "commanded rest lengths, for simulate --controller; target.yaml; summary.json)")
    u.set_defaults(run=run_pull)


def run_pull(args: argparse.Namespace) -> int:
    import numpy as np

    from tensim.control import (
        ControllerConfig,
        ImpedanceController,
        RestCommand,
        save_controller,
    )
    from tensim.design.inverse import inverse_statics
    from tensim.design.report import table
    from tensim.design.verify import WIND_SPEED
    from tensim.models import PRESETS
    from tensim.runs import check_run_folder, finish_run, replace_folder
    from tensim.structure import save_structure

    check_run_folder(Path(args.out))
    structure = load_model(args.model)
    moves = dict(args.move)
    result = inverse_statics(structure, moves, min_tension=args.min_tension,
                             tolerance=args.tolerance)
    print(table([(n, r, 1e3 * d, t) for n, r, d, t in zip(
        result.cables, result.rest_lengths, result.change, result.tensions, strict=True)],
        ("cable", "rest [m]", "change [mm]", "tension [N]")))
    print("friction needed at the feet: " + ", ".join(
        f"{n} {v:.2f}" for n, v in result.friction_needed.items()))
    errors: dict[str, float] = {}
    if args.verify:
        from tensim.design.verify import settle_errors

        errors, duration = settle_errors(structure, result)
        print(f"simulated {duration:g} s (motors winding at 0.01 m/s, then resting); distance "
              "from the static answer [mm]: "
              + ", ".join(f"{n} {1e3 * e:.2f}" for n, e in errors.items()))
        creep = max(errors[f] for f in result.feet)
        miss = max(errors[n] for n in moves)
        print(f"the feet crept up to {1e3 * creep:.2f} mm on MuJoCo's soft contacts (the "
              f"statics pins them); the moved nodes missed their targets by up to "
              f"{1e3 * miss:.2f} mm")
    else:
        print("the statics pins the feet; on MuJoCo's soft contacts they creep under sideways "
              "load: --verify simulates by how much, and how far the targets are missed")
    passive = {c.name for c in structure.cables if c.motor.passive}  # keep their rest length
    rest = {n: float(r) for n, r in zip(result.cables, result.rest_lengths, strict=True)
            if n not in passive}
    controller = ControllerConfig(
        ImpedanceController({}), model=args.model if args.model in PRESETS else None,
        description=f"tensim design pull {args.model} "
        + " ".join(f"--move {n}={','.join(f'{v:g}' for v in d)}" for n, d in moves.items())
        + f": the motors wind to these rest lengths at {WIND_SPEED:g} m/s and hold them",
        rest=RestCommand(tuple(rest), tuple(rest.values()), WIND_SPEED))
    with replace_folder(Path(args.out)) as stage:
        save_controller(controller, stage / "controller.yaml")
        save_structure(result.target, stage / "target.yaml")
        finish_run(stage, {"model": args.model,
                           "moves_m": {n: list(d) for n, d in moves.items()},
                           "rest_lengths_m": dict(zip(result.cables,
                                                      map(float, result.rest_lengths),
                                                      strict=True)),
                           "tensions_N": dict(zip(result.cables, map(float, result.tensions),
                                                  strict=True)),
                           "verify_error_m": {n: float(e) for n, e in errors.items()},
                           "feet_creep_m": max(float(errors[f]) for f in result.feet)
                           if errors else None,
                           "max_verify_error_m": float(np.max(list(errors.values())))
                           if errors else None})
    print(f"wrote {args.out}/ (controller.yaml, target.yaml, summary.json)")
    return 0



def _robot_duties(args: argparse.Namespace) -> list[CableDuty]:
    """The cables' worst duties over the gait on --robots randomised robots."""
    from tensim.cli._common import Progress
    from tensim.design.robots import gait_duties, random_scales
    from tensim.model import compile_structure
    from tensim.models import resolve_controller

    structure = load_model(args.model)
    config = resolve_controller(args.model, structure, args.controller)
    if config is None:
        raise ValueError(f"--model {args.model}: no controller; give --controller")
    compiled = compile_structure(structure)
    duration = args.duration or (config.duration if config.gait else 10.0)
    limits = {c.name: (c.motor.max_speed, c.motor.max_tension) for c in structure.cables}
    duties, finished = gait_duties(
        compiled, lambda: config.build(compiled.model.opt.timestep), duration,
        random_scales(args.robots, args.spread, args.seed), limits,
        progress=Progress(f"{args.robots} robots", args.quiet))
    print(f"{finished} of {args.robots} randomised robots ran {duration:g} s "
          f"(spread {args.spread:g}, seed {args.seed})")
    return duties
