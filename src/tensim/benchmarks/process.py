"""Whole commands as processes: what a user waits for, start-up, figures and files included.

Each command runs in a fresh interpreter, with its figures and with ``--no-figures``, the two
taking turns (A B A B ...), so a load on a shared machine falls on both alike. A run's CPU time
and peak resident memory are the kernel's account of the process and every process it waited
for (its figure-drawing and OpenGL-trial children), read by ``os.wait4`` as ``/usr/bin/time``
does, in a small launcher process (so the peak is not this process's). The figures' share of
a command is 1 - (CPU without figures) / (CPU with figures), from the best runs.

The commands run as an installed package does, with Python's compiled bytecode at hand: an
environment that turns its writing off (``PYTHONDONTWRITEBYTECODE``) would make every run
compile tensim's modules from source in each of its processes, which no installed copy does.
So the runs keep their bytecode in a temporary folder (``PYTHONPYCACHEPREFIX``), filled by one
untimed run of each command first; the user's source tree gets none.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from tensim.benchmarks._machine import load_average, machine_note

# the README's main jobs, as typed (each writes its run folder into a temporary directory)
COMMANDS = (("experiment", "disturbance"), ("experiment", "cpg"))
_MAIN = "import sys; from tensim.cli import main; sys.exit(main(sys.argv[1:]))"


# A small launcher runs the command and reports its child's account. The kernel carries a
# process's peak memory across exec, and a child started from this process (whose libraries
# are loaded) would start from this process's peak; the launcher's own is a few MiB.
_LAUNCHER = """
import os, subprocess, sys
child = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL)
_, status, usage = os.wait4(child.pid, 0)
print(usage.ru_utime + usage.ru_stime, usage.ru_maxrss, os.waitstatus_to_exitcode(status))
"""


def with_bytecode(bytecode: str | None) -> dict[str, str]:
    """This process's environment for a timed run whose Python reads and writes its compiled
    bytecode in the folder ``bytecode`` (``PYTHONPYCACHEPREFIX``; a
    ``PYTHONDONTWRITEBYTECODE`` removed: see the module's notes); None: unchanged."""
    env = dict(os.environ)
    if bytecode is not None:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = bytecode
    return env


def run_process(args: list[str], bytecode: str | None = None) -> tuple[float, float, float]:
    """Runs ``tensim ARGS`` in a fresh interpreter (this process's tensim).

    ``bytecode``: a folder where the run's Python keeps its compiled bytecode (read and
    written there, as ``PYTHONPYCACHEPREFIX`` does, whatever the environment says); None: as
    the environment says.

    Returns:
        (CPU time [s], wall time [s], peak resident memory [MiB]) of the process and the
        children it waited for.

    Raises:
        RuntimeError: the command failed.
    """
    here = str(Path(__file__).resolve().parents[2])
    path = os.pathsep.join(p for p in (here, os.environ.get("PYTHONPATH")) if p)
    env = {**with_bytecode(bytecode), "PYTHONPATH": path}
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", _LAUNCHER, sys.executable, "-c", _MAIN, *args],
                          capture_output=True, text=True, check=False, env=env)
    wall = time.perf_counter() - start
    fields = done.stdout.split()
    if done.returncode or len(fields) != 3 or fields[2] != "0":
        raise RuntimeError(f"tensim {' '.join(args)} failed:\n{done.stderr[-2000:]}")
    return float(fields[0]), wall, int(fields[1]) / 1024


def bench_process(repeats: int = 3, commands: tuple[tuple[str, ...], ...] = COMMANDS
                  ) -> dict[str, Any]:
    """Each command with and without figures, ``repeats`` times, interleaved, after an untimed
    run of each that compiles the bytecode they all use (see the module's notes).

    Returns:
        per command: best and median CPU [s], best wall [s] and peak memory [MiB] of each
        variant, and the figures' share of the command's CPU time; the load average before.
    """
    load = load_average()
    runs: dict[tuple[str, bool], list[tuple[float, float, float]]] = {}
    with tempfile.TemporaryDirectory(prefix="tensim-bench-") as tmp:
        bytecode = str(Path(tmp) / "bytecode")
        for command in commands:  # untimed: compiles the bytecode
            run_process([*command, "--out", str(Path(tmp) / "warm-up")], bytecode)
        for k in range(repeats):
            for command in commands:
                for figures in (True, False):
                    out = Path(tmp) / f"{'-'.join(command)}-{figures}-{k}"
                    args = [*command, "--out", str(out), *(() if figures else ("--no-figures",))]
                    runs.setdefault((" ".join(command), figures), []).append(
                        run_process(args, bytecode))
    report: dict[str, Any] = {"load_average_before": load, "repeats": repeats, "commands": []}
    for command in commands:
        name = " ".join(command)
        row: dict[str, Any] = {"command": f"tensim {name}"}
        for figures, key in ((True, "with_figures"), (False, "no_figures")):
            cpu, wall, rss = zip(*runs[(name, figures)], strict=True)
            row[key] = {"cpu_best_s": min(cpu), "cpu_median_s": statistics.median(cpu),
                        "wall_best_s": min(wall), "peak_MiB": max(rss),
                        "core_share": statistics.median(c / w for c, w in zip(cpu, wall,
                                                                              strict=True))}
        row["figures_share"] = 1 - row["no_figures"]["cpu_best_s"] / \
            row["with_figures"]["cpu_best_s"]
        report["commands"].append(row)
    return report


def format_process(report: dict[str, Any]) -> str:
    """The whole-process figures as a few printed lines."""
    lines = [f"whole commands as processes, {report['repeats']} runs each, with and without "
             "figures taking turns; CPU time of the process and its children, best / median"]
    for row in report["commands"]:
        a, b = row["with_figures"], row["no_figures"]
        lines.append(f"  {row['command']:<28} {a['cpu_best_s']:.2f} / {a['cpu_median_s']:.2f} s "
                     f"CPU, peak {a['peak_MiB']:.0f} MiB; --no-figures {b['cpu_best_s']:.2f} / "
                     f"{b['cpu_median_s']:.2f} s, peak {b['peak_MiB']:.0f} MiB; figures "
                     f"{row['figures_share']:.0%} of the command")
    shares = {f"{row['command']}": min(row["with_figures"]["core_share"],
                                        row["no_figures"]["core_share"])
              for row in report["commands"]}
    lines.append("  " + machine_note(shares, report["load_average_before"]))
    return "\n".join(lines)
