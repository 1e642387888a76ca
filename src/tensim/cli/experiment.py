"""``tensim experiment NAME``: the paper's experiments, each writing a run folder."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tensim.cli._common import (
    Progress,
    add_controller_option,
    add_figures_option,
    add_world_options,
    load_model,
    output_option,
    parse_point,
    positive,
    print_summary,
    world_from_args,
)

if TYPE_CHECKING:
    from tensim.structure import Structure
    from tensim.viz.drawing import FigureDrawer, FigurePlan


def _structure(args: argparse.Namespace) -> Structure | None:
    """The ``--robot`` structure file (a Tetraspine3 variant, e.g. fitted by sysid), or None."""
    return load_model(args.robot) if args.robot else None


def _drawer(plans: list[FigurePlan], args: argparse.Namespace) -> FigureDrawer:
    """A drawer of ``plans`` that lays the figures out while the run simulates, where that pays
    (:func:`tensim.viz.drawing.background_pays`); with ``--no-figures``, one that draws
    nothing."""
    from tensim.viz.drawing import FigureDrawer, background_pays

    return FigureDrawer(plans, background=background_pays(), enabled=not args.no_figures)


def _robot_controller(args: argparse.Namespace, structure: Structure | None
                      ) -> tuple[Any, str | None]:
    """The ``--controller`` file for the experiment's robot (None: the experiment's default)."""
    from tensim.models import load_controller, preset

    if args.controller is None:
        return None, None
    return (load_controller(args.controller, structure or preset("tetraspine3").build()),
            args.controller)


def _push(args: argparse.Namespace) -> Any:
    """The disturbance test's :class:`Push` from ``--push``, ``--hold`` and ``--peak-force``."""
    from tensim.experiments.disturbance import PEAK_FORCE, Push

    if args.push is None and args.hold is None and args.peak_force is None:
        return Push()
    holds: tuple[tuple[str, float], ...] = Push().holds
    if args.hold is not None:
        entries = [h.strip() for h in args.hold.split(",") if h.strip()]
        named = [e.partition(":") for e in entries]
        try:
            holds = tuple((node, float(share) if share else 1.0 / len(named))
                          for node, _, share in named)
        except ValueError:
            raise ValueError(f"--hold {args.hold!r}: expected NODE[:SHARE],... with shares as "
                             "numbers, e.g. b0:0.5,b1:0.5") from None
    return Push(args.push or Push().node, holds, peak=args.peak_force or PEAK_FORCE)


def _experiment_robot(args: argparse.Namespace) -> tuple[Structure | None, str | None]:
    """``--robot``'s structure (None: Tetraspine3) and the name the summary gives it."""
    structure = _structure(args)
    return structure, args.robot


def _disturbance(args: argparse.Namespace, out: Path) -> dict[str, Any]:
    import sys

    from tensim.experiments import run_disturbance, write_disturbance
    from tensim.experiments.disturbance import (
        BEFORE,
        DURATION,
        DURING,
        check_disturbance,
        disturbance_figures,
        robot_controller,
    )
    from tensim.models import preset

    duration = args.duration or DURATION
    structure, name = _experiment_robot(args)
    push = _push(args)
    robot = structure or preset("tetraspine3").build()
    for note in check_disturbance(robot, push, duration):  # before anything runs
        print(f"tensim: note: {note}", file=sys.stderr)
    given, label = _robot_controller(args, structure)
    config, label = robot_controller(structure, given, label)
    plans = disturbance_figures() if structure is None else disturbance_figures(
        tuple(c.name for c in robot.cables), robot.name)
    with _drawer(plans, args) as drawer:
        result, summary = run_disturbance(dt=args.dt, world=world_from_args(args),
                                          duration=duration, structure=structure,
                                          progress=Progress("disturbance", args.quiet),
                                          push=push, controller=config, model=name,
                                          controller_label=label)
        write_disturbance(out, result, summary, structure, drawer, config)
    change = summary.get("tension_change_hold_N")
    if change:
        print(f"mean tension change, hold ({DURING[0]:g}-{DURING[1]:g} s) minus before "
              f"({BEFORE[0]:g}-{BEFORE[1]:g} s) [N]:")
        for name, value in change.items():
            print(f"  {name:<16} {value:+8.3f}")
    _print_stance(summary)
    return summary


def _timestep(args: argparse.Namespace, out: Path) -> dict[str, Any]:
    from tensim.experiments.disturbance import DURATION
    from tensim.experiments.timestep import run_timestep_study, write_timestep_study

    bar = Progress("timestep study", args.quiet)
    summary = run_timestep_study(bar.note, duration=args.duration or DURATION, progress=bar)
    write_timestep_study(out, summary)
    for hz, value in summary["max_change_percent"].items():
        print(f"  {hz:>5} Hz: worst cable's max-tension change {value:.2f} % vs 1000 Hz")
    for tc, value in summary["contact_max_change_percent"].items():
        print(f"  contact time constant {tc} s: worst change {value:.2f} %")
    return summary


def _laws(args: argparse.Namespace, out: Path) -> dict[str, Any]:
    from tensim.experiments.laws import CASES, LAWS, format_law_study, run_law_study
    from tensim.runs import finish_run

    cases = tuple(c.strip() for c in args.cases.split(",") if c.strip()) if args.cases \
        else CASES + (("twelve_bar",) if args.ntrt else ())
    bar = Progress("cable-law study", args.quiet)
    laws = tuple(c.strip() for c in args.laws.split(",") if c.strip()) if args.laws else LAWS
    summary = run_law_study(cases, Path(args.ntrt) if args.ntrt else None, bar.note, laws,
                            **({"split_margin": args.split_margin} if args.split_margin else {}))
    finish_run(out, summary)
    print("\n".join(format_law_study(summary, args.cpu)))
    return summary


def _gait(name: str, default: str) -> Callable[[argparse.Namespace, Path], dict[str, Any]]:
    def run(args: argparse.Namespace, out: Path) -> dict[str, Any]:
        from tensim.experiments.gait import (
            draw_velocity_input,
            gait_figures,
            run_gait,
            write_gait,
        )
        from tensim.models import preset

        structure = _structure(args)
        cables = [c.name for c in (structure or preset("tetraspine3").build()).cables]
        with _drawer(gait_figures(name, cables), args) as drawer:
            result, summary, config = run_gait(
                name, args.controller or default, model=args.robot or "tetraspine3",
                structure=structure,
                duration=args.duration, world=world_from_args(args),
                progress=Progress(name, args.quiet),
                # V* is known before the run: drawn while it simulates
                before=lambda config, duration, dt: draw_velocity_input(
                    drawer, config, duration, dt, out))
            write_gait(out, result, summary, config, structure, drawer)
        print(f"moved {summary['planar_displacement_m']:.3f} m toward "
              f"{summary['direction']} ({summary['direction_deg']:.0f} deg from +x)")
        if "body_sideways_m" in summary:
            side = summary["body_sideways_m"]
            print(f"in the robot's own frame: {summary['body_forward_m']:.3f} m forward, "
                  f"{abs(side):.3f} m to its {'left' if side > 0 else 'right'}; heading "
                  f"turned {summary['heading_change_deg']:.0f} deg")
        return summary

    return run


def _drag(args: argparse.Namespace, out: Path) -> dict[str, Any]:
    from tensim.experiments.disturbance import robot_controller
    from tensim.experiments.drag import DragSettings, check_drag, run_drag, write_drag
    from tensim.models import preset

    structure, name = _experiment_robot(args)
    settings = DragSettings(node=args.tow) if args.tow else DragSettings()
    check_drag(structure or preset("tetraspine3").build(), settings)  # before anything runs
    given, label = _robot_controller(args, structure)
    config, label = (None, None) if structure is None and given is None else \
        robot_controller(structure, given, label)
    result, summary = run_drag(settings=settings, world=world_from_args(args),
                               duration=args.duration, structure=structure,
                               progress=Progress("drag", args.quiet), controller=config,
                               name=name, controller_label=label)
    write_drag(out, result, summary, structure, config)
    print(f"steady drag force {summary['drag_force_N']:.3f} N "
          f"(mu m g = {summary['coulomb_force_N']:.3f} N); "
          f"effective friction {summary['effective_friction']:.4f}")
    _print_stance(summary)
    return summary


def _print_stance(summary: dict[str, Any]) -> None:
    """Says, after a protocol's figures, that they mean nothing when the robot left its stance."""
    problems = summary.get("stance_problems") or []
    if problems:
        print("NOT VALID: the robot left its stance, so the figures above do not measure "
              f"what the {summary.get('experiment', 'experiment')} test measures:")
        for problem in problems:
            print(f"  {problem}")


def _scenario_args(args: argparse.Namespace, name: str) -> dict[str, Any]:
    """The 12-segment scenarios' common arguments; no --terrain keeps the scenario's own."""
    world = world_from_args(args)
    return {"terrain": world.terrain if args.terrain else None, "controller": args.controller,
            "duration": args.duration, "world": world,
            "progress": Progress(name, args.quiet)}


def _climb(args: argparse.Namespace, out: Path) -> dict[str, Any]:
    from tensim.experiments.climb import run_climb, write_climb

    result, summary, config, terrain = run_climb(**_scenario_args(args, "climb"))
    write_climb(out, result, summary, config, terrain)
    print(f"segments rose up to {summary['height_reached_m']:.3f} m"
          + (f" (wall {summary['wall_height_m']} m): {summary['segments_on_wall']} on the wall, "
             f"{summary['segments_past_wall']} past it" if "wall_height_m" in summary else "")
          + f"; moved {summary['planar_displacement_m']:.3f} m toward {summary['direction']}")
    return summary


def _sidewind(args: argparse.Namespace, out: Path) -> dict[str, Any]:
    from tensim.experiments.sidewind import run_sidewind, write_sidewind

    result, summary, config, terrain = run_sidewind(**_scenario_args(args, "sidewind"))
    write_sidewind(out, result, summary, config, terrain)
    side = summary["body_sideways_m"]
    print(f"moved {summary['planar_displacement_m']:.3f} m toward {summary['direction']}; in "
          f"its own frame {summary['body_forward_m']:.3f} m forward, {abs(side):.3f} m to its "
          f"{'left' if side > 0 else 'right'} (sideways share {summary['sideways_share']:.2f}), "
          f"heading turned {summary['heading_change_deg']:.0f} deg")
    return summary


def _goal(args: argparse.Namespace, out: Path) -> dict[str, Any]:
    from tensim.experiments.goal import GOAL_TARGET, run_goal, write_goal

    target = GOAL_TARGET if args.target is None else parse_point(args.target, "--target")
    result, summary, config, terrain = run_goal(target_xy=target,
                                                **_scenario_args(args, "goal"))
    write_goal(out, result, summary, config, terrain)
    print(f"target {tuple(summary['target_xy_m'])} m: distance {summary['start_distance_m']:.3f}"
          f" -> {summary['final_distance_m']:.3f} m (progress {summary['goal_progress_m']:.3f} m"
          f", closest {summary['closest_distance_m']:.3f} m, "
          + (f"reached at {summary['reached_time_s']:.1f} s)" if summary["reached"]
             else "not reached)"))
    return summary


def _roll(args: argparse.Namespace, out: Path) -> dict[str, Any]:
    import dataclasses
    import math

    from tensim.control.rolling import default_settings, searched
    from tensim.experiments.roll import ROLL_DURATION, play, roll, write_roll
    from tensim.models import load_controller

    if args.model is None:
        raise ValueError("roll: give the robot, a preset or a structure file: tensim experiment "
                         "roll MODEL|FILE")
    if args.heading is not None and not math.isfinite(args.heading):
        raise ValueError(f"--heading {args.heading!r}: expected a finite angle in degrees")
    structure = load_model(args.model)
    goal = parse_point(args.goal, "--goal") if args.goal is not None else None
    if args.turn is not None and (args.controller is not None or goal is not None
                                  or args.heading is not None):
        raise ValueError("--turn: turning in place takes no --heading, --goal or --controller")
    if args.turn is not None and not math.isfinite(args.turn):
        raise ValueError(f"--turn {args.turn!r}: expected a finite angle in degrees")
    for flag in ("cached_plans", "searched_tips"):
        if getattr(args, flag) and args.controller is not None:
            raise ValueError(f"--{flag.replace('_', '-')} is for the statics gait, not a "
                             "--controller file")
    if args.controller is None:
        settings = default_settings(structure)
        if args.cached_plans:
            settings = dataclasses.replace(settings, cache=True)
        if args.searched_tips:
            settings = searched(settings)
        result, summary = roll(structure, args.duration or ROLL_DURATION,
                               heading_deg=args.heading or 0.0, goal=goal,
                               world=world_from_args(args), turn_deg=args.turn,
                               settings=settings, progress=Progress("roll", args.quiet))
    else:  # a controller file's gait, played open loop (a learned roll gait)
        result, summary = play(structure, load_controller(args.controller, structure),
                               args.duration or ROLL_DURATION, heading_deg=args.heading or 0.0,
                               goal=goal, world=world_from_args(args),
                               progress=Progress("roll", args.quiet))
    summary = {"experiment": "roll", "model": args.model, "controller": args.controller,
               **summary}
    write_roll(out, result, summary, structure)
    if args.turn is None:
        print(f"rolled {summary['distance_m']:.3f} m along the heading in "
              f"{summary['duration_s']:g} s: {summary['body_lengths_per_s']:.3f} body lengths/s"
              " (body length "
              f"{summary['body_length_m']:.3f} m), " + (
                  "no net displacement" if summary["heading_error_deg"] is None else
                  f"heading error {summary['heading_error_deg']:.1f} deg") + (
                  "" if summary["rolls"] is None else
                  f", {summary['rolls']} rolls over {summary['faces_visited']} faces"))
    else:
        print(f"turned {summary['yaw_deg']:.1f} deg of {args.turn:g} in "
              f"{summary['duration_s']:.2f} s, centre of mass moved "
              f"{summary['displacement_m']:.3f} m ({summary['displacement_body_lengths']:.2f} "
              f"body lengths), {summary['rolls']} rolls")
    if goal is not None:
        before, after = summary["goal_distance_m"]
        print(f"goal ({goal[0]:g}, {goal[1]:g}) m: distance {before:.3f} -> {after:.3f} m")
    if args.turn is None and summary["rolls"] is not None:
        first = summary["first_roll_s"]
        print(f"{summary['rocks_back']} of the {summary['rolls']} rolls went back to the face "
              "before; first roll after " + ("none" if first is None else f"{first:.2f} s")
              + ("" if summary["plans"] is None else
                 f"; {summary['plans']} plans ({summary['plans_made']} made from statics)")
              + f"; {summary['ends_on_ground']} of {summary['ends']} rod ends on the ground")
        print(f"turned {summary['roll_rad']:.2f} rad about the rolling axis, "
              f"{summary['rolled_m']:.3f} m rolled (as `tensim learn --rolling` counts it)")
    return summary


# name -> (one-line help, runner(args, out) -> summary)
EXPERIMENTS: dict[str, tuple[str, Callable[[argparse.Namespace, Path], dict[str, Any]]]] = {
    "disturbance": ("steady push on the front segment, held by the others (paper Fig. 3)",
                    _disturbance),
    "timestep": ("disturbance test at 250/1000/4000 Hz and three contact time constants",
                 _timestep),
    "laws": ("the cable laws at 0.5-10 ms steps against a 0.05 ms explicit run (Tetraspine3, "
             "SUPERball, a stiff 3-bar)", _laws),
    "sine": ("hand-tuned style sine gait on V* (paper Fig. 4)",
             _gait("sine", "tetraspine3_sine")),
    "cpg": ("simulator-tuned CPG gait, sideways locomotion (paper Fig. 5)",
            _gait("cpg", "tetraspine3_cpg")),
    "drag": ("quasi-static drag at steady velocity: the friction force (paper IV-A)", _drag),
    "climb": ("12-segment Tetraspine crawls at a wall and over it (paper Fig. 1)", _climb),
    "sidewind": ("12-segment Tetraspine sidewinding gait (paper Fig. 1)", _sidewind),
    "goal": ("12-segment Tetraspine toward a target point across rough ground", _goal),
    "roll": ("a 3-bar, 6-bar or other closed robot rolls toward --heading or --goal "
             "(punctuated statics gait, or --controller FILE played open loop)", _roll),
}


# the experiments whose figures go through a drawer, which --no-figures turns off
FIGURELESS = ("disturbance", "sine", "cpg")


def register(sub: argparse._SubParsersAction) -> None:
    lines = "\n".join(f"  {name:<12} {text}" for name, (text, _) in EXPERIMENTS.items())
    p = sub.add_parser("experiment", help="run one of the paper's experiments",
                       description=f"experiments:\n{lines}",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("name", choices=list(EXPERIMENTS), metavar="NAME",
                   help=f"one of: {', '.join(EXPERIMENTS)}")
    p.add_argument("model", nargs="?", default=None, metavar="MODEL|FILE",
                   help="roll: the robot, a preset (e.g. three_bar) or a structure file")
    p.add_argument("--heading", type=float, default=None, metavar="DEG",
                   help="roll: direction to roll, counter-clockwise from +x [deg] (default 0)")
    p.add_argument("--goal", default=None, metavar="X,Y",
                   help="roll: a goal point [m] to roll toward instead of a heading "
                        "(write --goal=-2,1 for a negative X)")
    p.add_argument("--turn", type=float, default=None, metavar="DEG",
                   help="roll: turn in place by this yaw, counter-clockwise [deg] (the run ends "
                        "once turned; --duration is the longest it may take)")
    p.add_argument("--cached-plans", action="store_true",
                   help="roll: make each tip plan once per support face and edge and share it "
                        "through the robot's symmetry (RollSettings(cache=True))")
    p.add_argument("--searched-tips", action="store_true",
                   help="roll: where statics cannot plan a tip (a 3-bar's far edges), use the "
                        "quickest of constant commands tried in simulation, cached through the "
                        "symmetry; rest on each face until the cables are back at their built "
                        "rest lengths (tensim.control.rolling.searched)")
    add_world_options(p)
    add_controller_option(p)
    p.add_argument("--robot", default=None, metavar="FILE.yaml",
                   help="disturbance, sine, cpg, drag: the robot instead of the tetraspine3 "
                        "preset (e.g. the fitted_structure.yaml of `tensim sysid`; sine and cpg "
                        "need Tetraspine3's cable names, disturbance and drag take any robot "
                        "with --push/--hold or --tow)")
    p.add_argument("--push", default=None, metavar="NODE",
                   help="disturbance: the pushed node (default s0_tip)")
    p.add_argument("--hold", default=None, metavar="NODE[:SHARE],...",
                   help="disturbance: nodes that take the push back, each its share (default "
                        "s1_tip:0.45,s2_tip:0.55; no share: equal shares)")
    p.add_argument("--peak-force", type=positive, default=None, metavar="N",
                   help="disturbance: the push's plateau [N] (default 22.56)")
    p.add_argument("--tow", default=None, metavar="NODE",
                   help="drag: the towed node (default s0_tip)")
    p.add_argument("--duration", type=positive, default=None,
                   help="simulated time [s] (default: the experiment's own)")
    p.add_argument("--target", default=None, metavar="X,Y",
                   help="goal: the target point in the world frame [m] (default 1.5,0, "
                        "2.7 m ahead of the robot; write --target=-2,1 for a negative X)")
    p.add_argument("--cases", default=None, metavar="NAME,...",
                   help="laws: tetraspine3, superball, three_bar, twelve_bar (default all "
                        "but twelve_bar), tetraspine3_soft, tetraspine3_free_motors")
    p.add_argument("--laws", default=None, metavar="LAW,...",
                   help="laws: explicit, implicit, implicitfast (the default: all three), "
                        "split (the implicit law split by cable at --split-margin, default 4; "
                        "the explicit reference runs whatever is asked)")
    p.add_argument("--ntrt", default=None, metavar="NTRTSIM_DIR",
                   help="laws: a checkout of the original toolkit, for its 12-bar cube")
    p.add_argument("--cpu", action="store_true", help="laws: print the CPU time per step")
    output_option(p, "--out", "folder", default=None, help="output folder (default runs/NAME)")
    add_figures_option(p, "disturbance, sine, cpg: ")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    for flag in ("cached_plans", "searched_tips"):
        if getattr(args, flag) and args.name != "roll":
            raise ValueError(f"--{flag.replace('_', '-')} is for the roll experiment, not "
                             f"{args.name!r}")
    for option in ("model", "heading", "goal", "turn"):
        if getattr(args, option) is not None and args.name != "roll":
            what = "a robot argument" if option == "model" else f"--{option}"
            raise ValueError(f"{what} is for the roll experiment, not {args.name!r}")
    if args.heading is not None and args.goal is not None:
        raise ValueError("roll: give --heading or --goal, not both")
    if args.target is not None and args.name != "goal":
        raise ValueError(f"--target is for the goal experiment, not {args.name!r}")
    for option, names in (("push", ("disturbance",)), ("hold", ("disturbance",)),
                          ("peak_force", ("disturbance",)), ("tow", ("drag",)),
                          ("cases", ("laws",)), ("ntrt", ("laws",)), ("laws", ("laws",))):
        if getattr(args, option) is not None and args.name not in names:
            raise ValueError(f"--{option.replace('_', '-')} is for the {names[0]} experiment, "
                             f"not {args.name!r}")
    if args.no_figures and args.name not in FIGURELESS:
        raise ValueError(f"--no-figures is for the {', '.join(FIGURELESS)} experiments, not "
                         f"{args.name!r}")
    from tensim.limits import check_run
    from tensim.runs import prepare_outputs, replace_folder

    if args.duration is not None:
        check_run(args.duration, args.dt, force=args.force)
    out = Path(args.out or f"runs/{args.name}")
    if not args.no_figures:
        prepare_outputs()  # the GL trial for frame.png runs while the simulation does
    with replace_folder(out) as stage:
        summary = EXPERIMENTS[args.name][1](args, stage)
    if "duration_s" in summary and args.name != "timestep":
        print_summary(summary, out, figures=not args.no_figures)
    else:
        print(f"wrote {out}/")
    return 0
