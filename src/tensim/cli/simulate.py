"""``tensim simulate``: run a preset or structure file, optionally under a controller file."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tensim.cli._common import (
    Progress,
    add_controller_option,
    add_figures_option,
    add_world_options,
    gains_summary,
    load_model,
    motor_summary,
    output_option,
    positive,
    print_summary,
    world_from_args,
)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("simulate", help="simulate a preset or structure file")
    p.add_argument("model", help="preset name or structure .yaml file")
    p.add_argument("--duration", type=positive, default=None,
                   help="simulated time [s] (default: the controller's gait duration, or 10)")
    add_world_options(p)
    add_controller_option(p)
    p.add_argument("--velocity-input", default=None, metavar="FILE",
                   help="play back an exported V* table (from export-trajectory) instead of "
                        "the controller's gait")
    p.add_argument("--load", action="append", default=[], metavar="NODE:FX,FY,FZ@T0-T1",
                   help="push NODE with the force (FX, FY, FZ) [N] from T0 to T1 [s], ramped "
                        "over 0.1 s at each end (append /RAMP for another ramp [s]); repeat for "
                        "more loads, e.g. --load t0:5,0,0@1-3")
    p.add_argument("--loads", default=None, metavar="FILE",
                   help="loads file (YAML: a 'loads' list; see tensim.loads), e.g. the "
                        "loads.yaml of an earlier run folder")
    p.add_argument("--record-dt", type=positive, default=0.01, help="recording period [s]")
    output_option(p, "--out", "folder", default="runs/simulate", help="output folder")
    add_figures_option(p)
    p.add_argument("--timings", action="store_true",
                   help="print the CPU time of each stage of the command at its end")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from tensim.cli._stages import StageClock

    clock = StageClock()
    with clock.stage("imports of the command's modules"):
        from tensim.control import load_velocity_table
        from tensim.control.files import check_table_columns
        from tensim.control.velocity_table import VelocityFileError
        from tensim.design.check import warn_findings
        from tensim.limits import check_run
        from tensim.loads import check_loads, load_loads, loads_to_dict, parse_push, save_loads
        from tensim.model import compile_structure
        from tensim.models import resolve_controller
        from tensim.runs import (
            check_run_folder,
            prepare_outputs,
            replace_folder,
            world_record,
            write_run,
        )
        from tensim.sim import simulate
        from tensim.viz.drawing import FigureDrawer, FigurePlan, background_pays
    if not args.no_figures:
        prepare_outputs()  # the GL trial for frame.png runs while the simulation does
    with clock.stage("load the structure"):
        structure = load_model(args.model)
    with clock.stage("pre-run check (tensim check)"):
        warn_findings(structure, args.dt, args.model,  # tensim check's findings, as warnings
                      getattr(args, "cable_law", None) or "explicit")
    config = resolve_controller(args.model, structure, args.controller)
    if args.velocity_input:
        if config is None:
            raise ValueError("--velocity-input needs impedance laws: give --controller")
        table = load_velocity_table(args.velocity_input)
        try:
            check_table_columns(table, config.impedance)
            config = config.with_gait(table)
        except ValueError as err:  # the table does not fit the controller
            raise VelocityFileError(f"{args.velocity_input}: {err}") from None
    if config is not None and config.gait is not None and args.duration \
            and not args.velocity_input:
        config = config.with_duration(args.duration)  # the gait runs as long as asked
    duration = args.duration or (config.duration if config and config.gait else 10.0)
    check_run(duration, args.dt, args.record_dt, force=args.force)
    check_run_folder(Path(args.out))
    loads = [*(load_loads(args.loads) if args.loads else []), *map(parse_push, args.load)]
    for note in check_loads(loads, structure, duration):
        print(f"tensim: note: {note}", file=sys.stderr)
    with clock.stage("compile"):
        compiled = compile_structure(structure, world_from_args(args))
    controller = config.build(compiled.model.opt.timestep) if config else None
    cables = list(compiled.index.cables)
    plans = [FigurePlan("path.png", "path", {"items": list(compiled.index.bodies)})]
    if cables:
        tags = {c.name: c.tags for c in structure.cables}  # many cables: panels by tag
        plans[:0] = [FigurePlan("tensions.png", "tensions",
                                {"cables": cables, "title": f"{args.model}: cable tensions",
                                 "tags": tags}),
                     FigurePlan("lengths.png", "lengths", {"cables": cables, "tags": tags})]
    out = Path(args.out)
    with FigureDrawer(plans, background=background_pays(),
                      enabled=not args.no_figures) as drawer:
        with clock.stage("simulate"):
            result = simulate(compiled, duration, controller=controller, loads=loads,
                              record_dt=args.record_dt,
                              progress=Progress(args.model, args.quiet))
        summary = {"model": args.model, "controller": _controller_label(args, config),
                   "motors": motor_summary(structure),
                   "gains": gains_summary(structure, config), **result.summary(),
                   **world_record(compiled.world)}
        if loads:
            summary["loads"] = loads_to_dict(loads)["loads"]
        with replace_folder(out) as stage:
            if loads:
                save_loads(loads, stage / "loads.yaml")
            with clock.stage("figures (handed to the drawing process)" if drawer.background
                             else "figures (in this process)"):
                for plan in plans:
                    drawer.draw(plan.file, result.trajectory, stage)
            with clock.stage("trajectory.parquet, structure.yaml, report, frame.png"):
                write_run(stage, result, {**summary, "figures": [p.file for p in plans
                                                                 if drawer.enabled]},
                          structure=structure, controller=config, drawer=drawer,
                          compiled=compiled)
    print_summary(summary, out, moved=True, figures=not args.no_figures)
    if args.timings:
        print("\n".join(clock.lines()))
    return 0


def _controller_label(args: argparse.Namespace, config: object) -> str:
    """What drove the cables, for the summary (the file itself is saved as controller.yaml)."""
    if config is None:
        return "none (passive cables)"
    label = args.controller or f"the {args.model} preset's impedance laws"
    return f"{label}, V* from {args.velocity_input}" if args.velocity_input else label
