"""``tensim bench``: speed against MuJoCo alone on identical inputs."""

from __future__ import annotations

import argparse
import contextlib
from pathlib import Path
from typing import Any

from tensim._input import InputError
from tensim.cli._common import count, natural, output_option, positive, split_margin


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="speed benchmark against MuJoCo alone")
    output_option(p, "--json", "file", default=None,
                  help="also write the figures to this JSON file")
    p.add_argument("--duration", type=positive, default=10.0, help="simulated time per case [s]")
    p.add_argument("--repeats", type=count, default=5,
                   help="runs of each loop, tensim and MuJoCo alone taking turns")
    p.add_argument("--learning", action="store_true", help="also learning throughput: "
                   "CMA-ES evaluations/s of Tetraspine3 CPG trials on 2 threads, against "
                   "mujoco.rollout and a process pool")
    p.add_argument("--evaluations", type=count, default=20, metavar="N",
                   help="CMA-ES evaluations of the learning case (default 20)")
    p.add_argument("--batch", type=natural, default=0, metavar="N",
                   help="also N Tetraspine3 CPG trials per batch on 1 and 2 threads, against "
                   "mujoco.rollout (e.g. 64)")
    p.add_argument("--process", action="store_true",
                   help="also whole commands as processes (experiment disturbance and cpg, "
                   "with and without figures): CPU time, peak memory, the figures' share")
    p.add_argument("--no-cases", dest="cases_run", action="store_false",
                   help="skip the single-run cases: only --learning, --batch or --process")
    p.add_argument("--busy", action="store_true",
                   help="run a busy loop on every core beside the benchmark, so that its "
                   "figures are taken on a loaded machine")
    p.add_argument("--cable-laws", action="store_true",
                   help="instead of the cases: the cost of a step under each cable law "
                   "(explicit, implicit, implicitfast, the implicit law split by cable), "
                   "Tetraspine3 under impedance control at 1 ms, the laws taking turns")
    p.add_argument("--laws-model", default="tetraspine3", metavar="PRESET",
                   help="--cable-laws: the preset (default tetraspine3, under its impedance "
                   "controller where it has one)")
    p.add_argument("--laws-dt", type=positive, default=1e-3, metavar="S",
                   help="--cable-laws: the physics step [s] (default 0.001)")
    p.add_argument("--split-margin", type=split_margin, default=None, metavar="MARGIN",
                   help="--cable-laws: the margin of the implicit law's row split by cable "
                   "(default 4; WorldOptions.split_margin)")
    p.add_argument("--rl", action="store_true",
                   help="instead of the cases: env steps per CPU second of the rolling 3-bar "
                   "(the three_bar preset as `tensim rl train --task roll` trains it) in the "
                   "raw batch engine, TensegrityVectorEnv, SB3VecEnv, TensegrityEnv and a "
                   "plain MuJoCo Gymnasium env of the exported MJCF, taking turns (needs "
                   "tensim[rl])")
    p.add_argument("--envs", default="16,64", metavar="N,N,...",
                   help="robots stepped together in --rl (default 16,64)")
    p.add_argument("--periods", type=count, default=100, metavar="N",
                   help="control periods per run of --rl (default 100)")
    p.add_argument("--backend", choices=("cpu", "warp"), default="cpu",
                   help="warp: aggregate steps/s of batches of worlds on MuJoCo Warp (a GPU "
                   "where there is one) beside the CPU batch engine on every core")
    p.add_argument("--worlds", default="256,1024,4096,16384", metavar="N,N,...",
                   help="batch sizes of --backend warp")
    p.add_argument("--record-dt", type=positive, default=0.01, metavar="S",
                   help="recording period of --backend warp [s] (default 0.01)")
    p.add_argument("--cases", default=None, metavar="NAME,...",
                   help="cases of --backend warp (default: tetraspine3_cpg, "
                   "tetraspine_sidewind, three_bar_roll, superball_roll; also superball and "
                   "prism3, their rest lengths held)")
    p.add_argument("--no-alone", dest="alone", action="store_false",
                   help="--backend warp: skip timing MuJoCo Warp alone beside each batch")
    p.add_argument("--device", default=None, help="the Warp device of --backend warp "
                   "(default: a GPU where there is one, e.g. cuda:0 or cpu)")
    p.set_defaults(run=run)


def _worlds(text: str, option: str = "--worlds", example: str = "256,1024") -> list[int]:
    try:
        worlds = [int(w) for w in text.split(",")]
    except ValueError:
        worlds = []
    if not worlds or min(worlds) < 1:
        raise InputError(f"{option}: expected batch sizes such as {example}, got {text!r}")
    return worlds


def _run_warp(args: argparse.Namespace) -> int:
    from tensim._files import write_json
    from tensim.benchmarks.warp import ALL_CASES, CASES, bench_warp, format_row
    from tensim.sim._warp_batch import warp_available

    worlds = _worlds(args.worlds)
    if not warp_available():
        raise InputError("--backend warp needs MuJoCo Warp: pip install 'tensim[gpu]'")
    cases = CASES if args.cases is None else tuple(args.cases.split(","))
    unknown = sorted(set(cases) - set(ALL_CASES))
    if unknown:
        raise InputError(f"--cases: unknown case {unknown[0]!r}; expected some of "
                         f"{', '.join(ALL_CASES)}")
    report = bench_warp(worlds, args.duration, cases, device=args.device,
                        record_dt=args.record_dt, alone=args.alone,
                        report=lambda row: print(format_row(row), flush=True))
    print(f"device: {report['device']}; CPU engine on {report['host_cores']} cores")
    if args.json:
        write_json(Path(args.json), report)
    return 0


def _run_rl(args: argparse.Namespace) -> int:
    from tensim._files import write_json
    from tensim.benchmarks._machine import machine_note

    envs = _worlds(args.envs, "--envs", "16,64")
    try:
        from tensim.benchmarks.rl import bench_rl, format_rl
    except ImportError as err:
        raise InputError(f"--rl needs the RL extra (pip install 'tensim[rl]'): {err}") from err
    report = bench_rl(envs=tuple(envs), periods=args.periods, repeats=args.repeats)
    print(format_rl(report))
    print(machine_note(report["core_share"], report["load_average_before"]))
    if args.json:
        write_json(Path(args.json), {"rl": report})
    return 0


def run(args: argparse.Namespace) -> int:
    if args.backend == "warp":
        return _run_warp(args)
    from tensim._files import write_json
    from tensim.benchmarks._machine import busy
    from tensim.limits import check_run

    if args.rl:
        return _run_rl(args)
    check_run(args.duration, 1e-3, 0.01, force=args.force)  # the cases' step and recording
    if args.cable_laws:
        from tensim.benchmarks._machine import load_average, machine_note
        from tensim.benchmarks.engine import bench_laws, format_laws

        load = load_average()
        laws = bench_laws(args.duration, args.repeats, args.laws_model, args.laws_dt,
                          **({} if args.split_margin is None
                             else {"split_margin": args.split_margin}))
        print(format_laws(laws))
        print(machine_note({"cable laws": laws["core_share"]}, load))
        if args.json:
            write_json(Path(args.json), {"cable_laws": laws})
        return 0
    with contextlib.ExitStack() as stack:
        loops = stack.enter_context(busy()) if args.busy else 0
        if loops:
            print(f"busy mode: {loops} busy-loop process(es) beside the benchmark")
        report = _run(args)
        report["busy_loops"] = loops
    if args.json:
        write_json(Path(args.json), report)
    return 0


def _run(args: argparse.Namespace) -> dict[str, Any]:
    from tensim.benchmarks._machine import machine_note
    from tensim.benchmarks.engine import run_benchmarks

    if not args.cases_run and not (args.learning or args.batch or args.process):
        raise InputError("--no-cases leaves nothing to run: add --learning, --batch N or "
                         "--process")
    report: dict[str, Any] = {}
    if args.cases_run:
        report = run_benchmarks(args.duration, args.repeats)
        print(format_table(report["cases"], args.repeats))
        print(machine_note(report["core_share"], report["load_average_before"]))
    if args.learning:
        from tensim.benchmarks.learning import bench_learning, format_learning

        report["learning"] = bench_learning(args.duration, args.evaluations)
        print(format_learning(report["learning"]))
    if args.batch:
        from tensim.benchmarks.batch import bench_batch, format_batch

        report["batch"] = bench_batch(args.batch, args.duration, args.repeats)
        print(format_batch(report["batch"]))
    if args.process:
        from tensim.benchmarks.process import bench_process, format_process

        report["process"] = bench_process(args.repeats)
        print(format_process(report["process"]))
    return report


def format_table(cases: list[dict[str, Any]], repeats: int) -> str:
    """The benchmark table: CPU time per step best / median, wall best, real-time factors."""
    lines = [f"us per physics step, {repeats} runs each, tensim and MuJoCo alone taking turns; "
             "x real time and ratio from the best CPU time",
             f"{'case':<48} {'tensim cpu best/median':>22} {'wall best':>9} "
             f"{'engine cpu best/median':>22} {'wall best':>9} {'x real time':>12} {'ratio':>6}"]
    for c in cases:
        tensim, engine = (f"{c[f'{w}cpu_us_per_step_best']:>11.1f} / "
                          f"{c[f'{w}cpu_us_per_step_median']:<8.1f} "
                          f"{c[f'{w}wall_us_per_step_best']:>9.1f}" for w in ("", "engine_"))
        lines.append(f"{c['name']:<48} {tensim} {engine} {c['real_time_factor']:>5.1f}/"
                     f"{c['engine_real_time_factor']:<6.1f} {c['ratio_to_engine']:>6.2f}")
    return "\n".join(lines)
