"""``tensim bench``: speed against MuJoCo alone on identical inputs."""

from __future__ import annotations

import argparse
from pathlib import Path

from tensim.cli._common import count, positive


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="speed benchmark against MuJoCo alone")
    p.add_argument("--json", default=None, help="also write the figures to this JSON file")
    p.add_argument("--duration", type=positive, default=10.0, help="simulated time per case [s]")
    p.add_argument("--repeats", type=count, default=3, help="best of this many runs")
    p.add_argument("--learning", action="store_true", help="also learning throughput: "
                   "CMA-ES evaluations/s of Tetraspine3 CPG trials on 2 threads, against "
                   "mujoco.rollout and a process pool")
    p.add_argument("--batch", type=int, default=0, metavar="N",
                   help="also N Tetraspine3 CPG trials per batch on 1 and 2 threads, against "
                   "mujoco.rollout (e.g. 64)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from tensim._files import write_json
    from tensim.bench import run_benchmarks
    from tensim.limits import check_run

    check_run(args.duration, 1e-3, 0.01, force=args.force)  # the cases' step and recording
    report = run_benchmarks(args.duration, args.repeats)
    print(f"{'case':<34} {'tensim x real time':>19} {'MuJoCo alone':>13} {'ratio':>7} "
          f"{'us/step':>8} {'engine us/step':>15}")
    for case in report["cases"]:
        print(f"{case['name']:<34} {case['real_time_factor']:>19.1f} "
              f"{case['engine_alone_real_time_factor']:>13.1f} {case['ratio_to_engine']:>7.2f} "
              f"{case['us_per_step']:>8.1f} {case['engine_us_per_step']:>15.1f}")
    if args.learning:
        from tensim.learn.bench import bench_learning, format_learning

        report["learning"] = bench_learning(args.duration)
        print(format_learning(report["learning"]))
    if args.batch:
        from tensim.bench_batch import bench_batch, format_batch

        report["batch"] = bench_batch(args.batch, args.duration, args.repeats)
        print(format_batch(report["batch"]))
    if args.json:
        write_json(Path(args.json), report)
    return 0
