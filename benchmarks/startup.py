"""Prints how long the first hour's commands take: start-up, an argument error, the main job.

Each command runs as a fresh process, several times, the commands taking turns so that a load
on a shared machine falls on all of them alike; for each the table gives the best and median
wall time and the CPU time (user + system, child processes included) of the same runs. The
main job's two commands (the 60 s disturbance test and the 60 s CPG gait, written to a
temporary folder) also report the share of their wall time spent simulating (the summary's
``wall_s``).

Targets: ``tensim --help`` and an argument error under 0.5 s, ``import tensim`` under 0.6 s,
simulation at least 60 % of the main job's wall time.

The commands run as an installed package does, with Python's compiled bytecode at hand, as
``tensim bench --process`` runs them (:mod:`tensim.benchmarks.process`): in a temporary folder
(``PYTHONPYCACHEPREFIX``, whatever ``PYTHONDONTWRITEBYTECODE`` says), filled by one untimed run
of each command first.

Usage: python benchmarks/startup.py [--repeats N] [--no-main-job]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tensim.benchmarks.process import with_bytecode

TENSIM = [sys.executable, "-c", "import sys; from tensim.cli import main; sys.exit(main())"]


def _commands(folder: Path, main_job: bool) -> dict[str, list[str]]:
    commands = {
        "import tensim": [sys.executable, "-c", "import tensim"],
        "tensim --help": [*TENSIM, "--help"],
        "tensim simulate (argument error)": [*TENSIM, "simulate"],
    }
    if main_job:  # the README's first command: the disturbance test, then the CPG gait
        for name in ("disturbance", "cpg"):
            commands[f"tensim experiment {name}"] = [*TENSIM, "--quiet", "experiment", name,
                                                     "--out", str(folder / name)]
    return commands


def _timed(command: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU time [s] of one run of ``command`` as a child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False,
                   env=env)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--no-main-job", action="store_true",
                        help="only start-up and argument errors")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="tensim-startup-"))
    try:
        commands = _commands(folder, not args.no_main_job)
        walls: dict[str, list[float]] = {name: [] for name in commands}
        cpus: dict[str, list[float]] = {name: [] for name in commands}
        simulated: dict[str, list[float]] = {}
        env = with_bytecode(str(folder / "bytecode"))
        for command in commands.values():  # untimed: compiles the bytecode
            _timed(command, env)
        for _ in range(args.repeats):
            for name, command in commands.items():
                wall, cpu = _timed(command, env)
                walls[name].append(wall)
                cpus[name].append(cpu)
                if name.startswith("tensim experiment"):
                    run = folder / name.rpartition(" ")[2]
                    summary = json.loads((run / "summary.json").read_text())
                    simulated.setdefault(name, []).append(summary["wall_s"] / wall)
        print(f"{os.cpu_count()} CPUs; {args.repeats} runs of each, taking turns")
        print(f"{'command':<34} {'wall best':>9} {'median':>7} {'cpu best':>9} {'median':>7}")
        for name in commands:
            print(f"{name:<34} {min(walls[name]):>8.2f}s {statistics.median(walls[name]):>6.2f}s"
                  f" {min(cpus[name]):>8.2f}s {statistics.median(cpus[name]):>6.2f}s")
        for name, shares in simulated.items():
            print(f"{name} simulates for {100 * statistics.median(shares):.0f} % of its wall "
                  "time (median)")
    finally:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
