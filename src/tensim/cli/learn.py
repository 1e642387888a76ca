"""``tensim learn``: learn a gait (CPG or sine) for a robot, in parallel, resumable."""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tensim.cli._common import (
    Progress,
    add_terrain_option,
    count,
    finite,
    load_model,
    natural,
    nonnegative,
    output_option,
    parse_point,
    positive,
    world_from_args,
)

if TYPE_CHECKING:
    from tensim.learn import TrialProblem

# options that define a run; a resumed run takes them from its folder
_PROBLEM_OPTIONS = ("model", "controller", "base_controller", "optimizer", "trial_duration",
                    "seed", "segment", "direction", "energy_weight", "settle", "max_tilt",
                    "penalty", "dt", "cable_law", "record_dt", "terrain", "target", "step",
                    "batch", "rolling", "start",
                    "monte_carlo", "randomize", "robots", "robust")
_DEFAULTS: dict[str, Any] = {
    "model": "tetraspine3", "controller": "cpg", "optimizer": "ntrt", "evaluations": 100,
    "trial_duration": 10.0, "seed": 0, "segment": "com",
    "energy_weight": 0.0, "settle": 0.0, "max_tilt": 90.0, "penalty": -1.0, "dt": 1e-3,
    "cable_law": "explicit", "record_dt": 0.01, "monte_carlo": 48, "out": "runs/learn",
}


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "learn", help="learn a gait (CPG or sine) for a robot, in parallel and resumable",
        description="Searches a controller family's parameters for the gait that carries the "
        "robot furthest in simulated trials. Every evaluation is appended to "
        "DIR/evaluations.jsonl as it finishes and the optimizer is checkpointed, so an "
        "interrupted run continues with `tensim learn --resume DIR`. Writes "
        "learning_curve.png, best_controller.yaml and summary.json.")
    d = _DEFAULTS
    problem = p.add_argument_group("problem (taken from DIR when resuming)")
    problem.add_argument("--model", help=f"preset or structure .yaml file (default {d['model']})")
    problem.add_argument("--controller", choices=("cpg", "sine", "sine-pattern", "wave", "roll"),
                         help="controller family, on any robot with motorised cables: CPG "
                         "coupled by shared rigid bodies (116 parameters for Tetraspine3; "
                         "kind_<name> tags share parameters), per-cable sine waves, the paper's "
                         "4-number Tetraspine sine pattern, or a travelling wave (of joint "
                         "bending along a Tetraspine, else along the cables in wave_<k> tag or "
                         "build-pose order), or a rolling wave of contraction around a rolling "
                         "robot's axis (5 parameters; see docs/rolling.md) (default "
                         f"{d['controller']}; see docs/any_robot.md)")
    problem.add_argument("--base-controller", metavar="FILE|NAME",
                         help="controller file whose impedance laws the gait drives (default: "
                         "the shipped tetraspine3_cpg / tetraspine3_sine for tetraspine3, "
                         "else the preset's own impedance controller, else laws that hold the "
                         "build pose, as `tensim controller init` writes)")
    problem.add_argument("--trial-duration", type=positive, metavar="S",
                         help=f"simulated time of one trial [s] (default {d['trial_duration']})")
    problem.add_argument("--segment", help="rigid body whose centre of mass is scored, or com "
                         "for the whole robot (default com)")
    problem.add_argument("--direction", help="any (planar distance), forward (+x), backward, "
                         "left (+y), right, sideways (either side), or an angle in degrees "
                         "from +x toward +y (default any)")
    problem.add_argument("--target", metavar="X,Y",
                         help="score the progress toward this point [m] instead of a "
                         "displacement (goal-directed locomotion; not with --direction; write "
                         "--target=-2,1 for a negative X)")
    problem.add_argument("--rolling", action="store_true", default=None,
                         help="count the distance along --direction only as far as the robot "
                         "rolled it (its turn about the horizontal axis across the direction "
                         "times its centre of mass's height), so that a crawl or a slide "
                         "scores about 0; for rolling robots (see docs/rolling.md)")
    problem.add_argument("--energy-weight", type=nonnegative, metavar="M_PER_J",
                         help="subtract this times the motor work [m/J] (default 0)")
    problem.add_argument("--settle", type=nonnegative, metavar="S",
                         help="seconds before the displacement counts (default 0)")
    problem.add_argument("--max-tilt", type=positive, metavar="DEG",
                         help="a body tilted further from upright has flipped over; 180 turns "
                         "the check off (default 90)")
    problem.add_argument("--penalty", type=finite,
                         help="score of a failed trial (flipped, unstable, gait error; "
                         "default -1)")
    problem.add_argument("--dt", type=positive, help="physics step [s] (default 0.001)")
    problem.add_argument("--cable-law", choices=("explicit", "implicit", "implicitfast"),
                         help="the cable law of the trials, as for `tensim simulate` "
                         "(default explicit; implicit holds stiff, damped cables at 1-10 ms, "
                         "see docs/speed.md)")
    problem.add_argument("--record-dt", type=positive, help="trial recording period [s] "
                         "(default 0.01)")
    add_terrain_option(problem)
    search = p.add_argument_group("search (taken from DIR when resuming)")
    search.add_argument("--optimizer", choices=("ntrt", "cma", "nelder-mead"),
                        help="ntrt: Monte Carlo then Gaussian hill climbing (the original "
                        "toolkit); cma: CMA-ES; nelder-mead (default ntrt)")
    search.add_argument("--seed", type=natural, help="random seed (default 0)")
    search.add_argument("--step", type=positive, help="unit-cube step: ntrt mutation deviation "
                        "(0.03), cma initial sigma (0.2), nelder-mead simplex edge (0.1)")
    search.add_argument("--batch", type=count, help="points per generation for ntrt (8) and "
                        "cma (4 + 3 ln N); independent of --workers, so results are too")
    search.add_argument("--monte-carlo", type=natural, metavar="N",
                        help=f"ntrt: random samples before hill climbing (default "
                        f"{d['monte_carlo']})")
    search.add_argument("--start", metavar="NAME=VALUE,...",
                        help="start the search with these parameters of the gait family at "
                        "these values (the rest at the base gait's or the family's nominal "
                        "ones), e.g. amplitude/a=1.5,frequency=0.15 for --controller roll")
    robust = p.add_argument_group("robust gaits (domain randomisation)")
    robust.add_argument("--randomize", metavar="NAME=LO:HI,...",
                        help="score each candidate on randomised robots: multipliers of "
                        "friction, stiffness, damping, mass, motor_speed, e.g. "
                        "friction=0.7:1.3,stiffness=0.9:1.1 (the draws follow --seed)")
    robust.add_argument("--robots", type=count, metavar="K",
                        help="robots per candidate (default 8 with --randomize, else 1)")
    robust.add_argument("--robust", choices=("mean", "worst"),
                        help="a candidate's score over its robots: the mean (default) or the "
                        "worst")
    run = p.add_argument_group("running")
    run.add_argument("--evaluations", type=count, metavar="N",
                     help=f"evaluation budget (default {d['evaluations']}); with --resume, "
                     "a new budget to continue or extend the run")
    run.add_argument("--workers", type=natural, default=None, metavar="W",
                     help="threads of the batch engine, which simulates each generation's "
                     "trials together in this process (default: every core); with "
                     "--processes or --ray, worker processes; 0 runs trials one by one")
    run.add_argument("--processes", action="store_true",
                     help="one trial per task on a pool of worker processes instead")
    run.add_argument("--backend", choices=("cpu", "warp"), default="cpu",
                     help="cpu: MuJoCo's batch engine (default); warp: MuJoCo Warp, a whole "
                     "generation per call on a GPU (pip install 'tensim[gpu]')")
    run.add_argument("--ray", action="store_true",
                     help="run trials on Ray (a local Ray is started unless --ray-address)")
    run.add_argument("--ray-address", metavar="ADDR",
                     help="address of a running Ray cluster, e.g. ray://head:10001")
    output_option(run, "--out", "folder", help=f"new run folder (default {d['out']})")
    run.add_argument("--resume", metavar="DIR", help="continue the run in DIR")
    p.set_defaults(run=run_learn)


def _problem(args: argparse.Namespace) -> TrialProblem:
    from tensim.learn import Objective, TrialProblem, default_base, parse_direction
    from tensim.models import load_controller

    structure = load_model(args.model)
    base = (load_controller(args.base_controller, structure) if args.base_controller
            else default_base(args.model, args.controller, structure))
    if args.target is not None and args.direction is not None:
        raise ValueError("give --direction or --target, not both")
    direction, either_way = parse_direction(args.direction or "any")
    target = parse_point(args.target, "--target") if args.target is not None else None
    objective = Objective(args.segment, None if target else direction, either_way,
                          args.energy_weight, args.settle, args.max_tilt, target,
                          bool(args.rolling))
    randomize = parse_randomize(args.randomize) if args.randomize else ()
    robots = args.robots if args.robots is not None else (8 if randomize else 1)
    start = parse_start(args.start) if args.start else ()
    return TrialProblem(structure, base, args.controller, args.trial_duration, objective,
                        world_from_args(args), args.record_dt, args.penalty, args.model,
                        randomize, robots, args.robust or "mean", args.seed, start)


def parse_start(text: str) -> tuple[tuple[str, float], ...]:
    """``amplitude/a=1.5,frequency=0.15`` as ((name, value), ...).

    Raises:
        ValueError: a malformed entry, naming it.
    """
    out = []
    for item in text.split(","):
        name, _, value = item.partition("=")
        try:
            number = float(value)
        except ValueError:
            number = math.nan
        if not name.strip() or not math.isfinite(number):
            raise ValueError(f"--start entry {item!r}: expected NAME=VALUE with a finite "
                             "number, e.g. frequency=0.15")
        out.append((name.strip(), number))
    return tuple(out)


def parse_randomize(text: str) -> tuple[tuple[str, float, float], ...]:
    """``friction=0.7:1.3,stiffness=0.9:1.1`` as ((name, low, high), ...).

    Raises:
        ValueError: a malformed entry, naming it.
    """
    out = []
    for item in text.split(","):
        name, _, bounds = item.partition("=")
        low, _, high = bounds.partition(":")
        try:
            entry = (name.strip(), float(low), float(high))
        except ValueError:
            entry = (name, math.nan, math.nan)
        if not (math.isfinite(entry[1]) and math.isfinite(entry[2])):
            raise ValueError(f"--randomize entry {item!r}: expected NAME=LOW:HIGH with finite "
                             "numbers, e.g. friction=0.7:1.3")
        out.append(entry)
    return tuple(out)


class _LearningProgress:
    """The progress bar with the best score so far and the failed trials."""

    def __init__(self, quiet: bool, resumed: int):
        label = "learn" if not resumed else f"learn (resumed after {resumed})"
        self.bar = Progress(label, quiet, unit="evals", rate_label=" evals/s")

    def __call__(self, done: int, total: int, best: float | None, failed: int) -> None:
        self.bar.extra = ("no score yet" if best is None else f"best {best:.4f}") + (
            f", {failed} failed" if failed else "")
        self.bar(done, total)


def run_learn(args: argparse.Namespace) -> int:
    from tensim.learn import (
        ClusterError,
        LearningSettings,
        OptimizerSettings,
        RunStore,
        create_run,
        discard_unstarted,
        make_executor,
        resume,
    )
    from tensim.limits import check_run

    if args.backend == "warp" and (args.processes or args.ray or args.ray_address):
        raise ValueError("--backend warp runs in this process: drop --ray and --processes")
    workers = (os.cpu_count() or 1) if args.workers is None else args.workers
    if workers < 0:
        raise ValueError(f"--workers must be >= 0, got {workers}")
    if args.resume:
        given = [f"--{o.replace('_', '-')}" for o in _PROBLEM_OPTIONS
                 if getattr(args, o) is not None]
        if given or args.out:
            raise ValueError(f"--resume takes the run's configuration from "
                             f"{args.resume}/config.json; drop {given or ['--out']} (only "
                             "--evaluations, --workers, --processes, --backend, --ray and "
                             "--ray-address may change)")
        out = Path(args.resume)
    else:
        for name, value in _DEFAULTS.items():
            if getattr(args, name, None) is None:
                setattr(args, name, value)
        out = Path(args.out)
        existed = out.is_dir()
        settings = LearningSettings(
            OptimizerSettings(args.optimizer, args.step, args.batch, args.monte_carlo),
            args.evaluations, args.seed)
        check_run(args.trial_duration, args.dt, args.record_dt, force=args.force)
        create_run(out, _problem(args), settings)
        if args.optimizer == "ntrt" and (args.batch or 8) < workers:
            print(f"note: ntrt asks {args.batch or 8} trials at a time, so at most that many "
                  f"of the {workers} workers are busy; raise --batch", file=sys.stderr)
    already = len(RunStore(out).evaluations())
    fresh = discard_unstarted(out, existed) if not args.resume else contextlib.nullcontext()
    try:
        with fresh:
            result = resume(out, args.evaluations,
                            progress=_LearningProgress(args.quiet, already),
                            executor=lambda p: make_executor(p, workers, ray=args.ray,
                                                             ray_address=args.ray_address,
                                                             processes=args.processes,
                                                             engine=args.backend))
    except KeyboardInterrupt:
        end = "\n" if sys.stderr.isatty() and not args.quiet else ""  # the progress bar's
        print(f"{end}tensim: interrupted; every finished evaluation is in "
              f"{out}/evaluations.jsonl; continue with: tensim learn --resume {out}",
              file=sys.stderr)
        return 130
    except ClusterError as err:
        if not RunStore(out).exists():  # a fresh run that never started left no folder
            print(f"tensim: {err}; the run never started, so no run folder was left",
                  file=sys.stderr)
            return 1
        print(f"tensim: {err}; every finished evaluation is in {out}/evaluations.jsonl; "
              f"continue with: tensim learn --resume {out}", file=sys.stderr)
        return 1
    return _report(out, result.summary)


def _report(out: Path, summary: dict[str, Any]) -> int:
    """Prints the run's outcome; returns the exit status (1: no trial succeeded)."""
    config = summary["config"]
    problem = config["problem"]
    print(f"wrote {out}/ (evaluations.jsonl, learning_curve.png, summary.json"
          + (", best_controller.yaml)" if "best_controller" in summary else ")"))
    if "dimension" in problem:
        print(f"{problem['family']} gait of {problem['dimension']} parameters")
    if summary["evaluations"] and summary["best_status"] != "ok":
        failed = ", ".join(f"{n} {status}" for status, n in summary["failed"].items())
        print(f"tensim: learn: every one of the {summary['evaluations']} trials failed "
              f"({failed}; reasons in {out}/evaluations.jsonl): nothing was learned",
              file=sys.stderr)
        return 1
    if summary["best_score"] is not None:
        what = problem.get("objective_text", "score")
        unit = " m" if problem.get("kind") == "trial" else ""  # a trial's score is a distance
        print(f"best score {summary['best_score']:.4f}{unit} (evaluation "
              f"{summary['best_index']} of "
              f"{summary['evaluations']}; {what})")
    print(f"{summary['evaluations']} evaluations in {summary['wall_s']:.1f} s "
          f"({summary['evaluations_per_s'] or 0:.2f} per s); {summary['stop_reason'] or 'stopped'}")
    if summary["failed"]:
        failed = ", ".join(f"{n} {status}" for status, n in summary["failed"].items())
        print(f"failed trials: {failed} (reasons in evaluations.jsonl)")
    if "best_controller" in summary:
        print(f"try it: {_try_command(problem, out / 'best_controller.yaml')}")
    if not summary["finished"]:
        print(f"continue with: tensim learn --resume {out}", file=sys.stderr)
    return 0


def _try_command(problem: dict[str, Any], controller: Path) -> str:
    """The command that runs a learned controller as the matching experiment."""
    model, family = problem.get("model"), problem.get("family")
    terrain = problem.get("terrain", "flat")
    if model == "tetraspine3" and terrain == "flat" and family in ("cpg", "sine"):
        return f"tensim experiment {family} --controller {controller}"
    if model == "tetraspine" and problem.get("objective", {}).get("target_xy") is not None:
        x, y = problem["objective"]["target_xy"]
        return (f"tensim experiment goal --controller {controller} --target={x:g},{y:g} "
                f"--terrain '{terrain}'")
    return (f"tensim simulate {model} --controller {controller}"
            + ("" if terrain == "flat" else f" --terrain '{terrain}'"))
