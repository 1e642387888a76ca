"""Robust gaits: a CPG gait learned on the nominal robot and one learned on randomised robots,
both scored on held-out perturbed robots. Prints the figures docs/learning.md quotes and, with
``--figure``, draws them (docs/figures/robust_gaits.png).

    python examples/robust_gaits.py [--evaluations 60] [--robots 4] [--held-out 32] [--out DIR]
        [--figure PNG]

Both runs use ``tensim learn`` (CMA-ES, Tetraspine3 CPG, 10 s trials, sideways) from the same
start; the randomised one scores each candidate by the mean over ``--robots`` robots drawn
from RANDOMIZE. The held-out robots are drawn from the same ranges with another seed, so
neither gait has seen them.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from tensim.control import load_controller
from tensim.learn import Objective, TrialProblem, parse_direction
from tensim.models import preset

RANDOMIZE = "friction=0.5:1.5,stiffness=0.85:1.15,mass=0.85:1.15,motor_speed=0.7:1.3"


def _learn(out: Path, evaluations: int, extra: list[str]) -> Path:
    command = [sys.executable, "-c", "import sys; from tensim.cli import main; "
               "sys.exit(main(sys.argv[1:]))", "--quiet", "learn", "--model", "tetraspine3",
               "--controller", "cpg", "--optimizer", "cma", "--evaluations", str(evaluations),
               "--trial-duration", "10", "--settle", "1", "--direction", "sideways",
               "--step", "0.05", "--seed", "0", "--out", str(out), *extra]
    subprocess.run(command, check=True)
    return out / "best_controller.yaml"


def _held_out(controller: Path, robots: int) -> np.ndarray:
    """The gait's sideways distance [m] on each held-out robot (failures score -1)."""
    from tensim.cli.learn import parse_randomize
    from tensim.model import compile_structure
    from tensim.sim import Trial, run_batch

    structure = preset("tetraspine3").build()
    compiled = compile_structure(structure)
    gait = load_controller(controller, structure).with_duration(10.0).build(
        compiled.model.opt.timestep)
    direction, either = parse_direction("sideways")
    objective = Objective("com", direction, either, settle_s=1.0)
    problem = TrialProblem(structure, load_controller(controller, structure), "cpg", 10.0,
                           objective, randomize=parse_randomize(RANDOMIZE), robots=robots,
                           randomize_seed=12345)  # only for its draws
    results = run_batch(compiled, [Trial(gait, physics=p) for p in problem.physics], 10.0,
                        threads=2)
    bodies = tuple(g.name for g in structure.rigid_groups())
    return np.array([objective.score(r.result.trajectory, bodies)[0] if r.ok else -1.0
                     for r in results])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--evaluations", type=int, default=60)
    parser.add_argument("--robots", type=int, default=4)
    parser.add_argument("--held-out", type=int, default=32)
    parser.add_argument("--out", type=Path, default=None, help="keep the two runs here")
    parser.add_argument("--figure", type=Path, default=None, help="draw the scores here (.png)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        root = args.out or Path(scratch)
        nominal = _learn(root / "nominal", args.evaluations, [])
        robust = _learn(root / "randomized", args.evaluations,
                        ["--randomize", RANDOMIZE, "--robots", str(args.robots)])
        scores = {"learned on the nominal robot": _held_out(nominal, args.held_out),
                  f"learned on {args.robots} randomised robots": _held_out(robust, args.held_out)}
    for label, values in scores.items():
        print(f"{label}: held-out sideways distance in 10 s: mean {values.mean():.3f} m, "
              f"worst {values.min():.3f} m, best {values.max():.3f} m "
              f"({len(values)} robots, {RANDOMIZE})")
    if args.figure is not None:
        _plot(scores, args.figure)
    return 0


def _plot(scores: dict[str, np.ndarray], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tensim.viz.plots import save_figure

    fig, ax = plt.subplots(figsize=(7, 3.6))
    labels = list(scores)
    ax.boxplot([scores[k] for k in labels], orientation="horizontal", widths=0.5)
    for i, k in enumerate(labels, start=1):
        ax.plot(scores[k], np.full(scores[k].size, i), "k.", alpha=0.5)
    ax.set_yticks(range(1, len(labels) + 1), labels)
    ax.set_xlabel("sideways distance in 10 s on a held-out perturbed robot [m]")
    ax.set_title("Tetraspine3 CPG gaits on held-out robots\n"
                 "(friction x0.5-1.5, stiffness and mass x0.85-1.15, motor speed x0.7-1.3)",
                 fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)


if __name__ == "__main__":
    raise SystemExit(main())
