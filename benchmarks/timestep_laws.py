"""Time-step study of the cable laws: max tensions and paths at 0.5-10 ms steps against a
0.05 ms run of the explicit law, for robots with soft and with stiff cables.

Cases:
- ``tetraspine3``: the paper's 60 s disturbance test (``tensim experiment disturbance``);
- ``superball``: the SUPERball-scale six-bar (preset ``superball``) pushed sideways at one
  node for 1 s of its 3 s;
- ``three_bar``: a lab's 3-bar prism, built here: 1.376 m, 4 kg bars, cables of 10 kN/m and
  1000 N s/m, two of them wound in by a quarter of their length over 4 s;
- ``twelve_bar`` (with ``--ntrt NTRTSIM_DIR``, a checkout of the original toolkit): its 12-bar
  cube, ``src/dev/mcdaly/12BarTensegrity/12BarCube.yaml``, dropped for 3 s.

Each case runs under each law (``explicit``, ``implicit``, ``implicitfast``; see
docs/architecture.md) at each step; a line gives the worst cable's change of maximum tension
against the reference (per cent of that cable's reference peak), the largest distance of the
centre of mass from the reference's at the same time (mm, and per cent of the distance the
reference's centre of mass travels), and with ``--cpu`` the CPU time per step of the whole
run (it varies with the machine and its load; the other figures do not). A run that fails its
stability check is reported as unstable.

Usage: python benchmarks/timestep_laws.py [--cases NAME,...] [--ntrt NTRTSIM_DIR] [--cpu]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from tensim.control.rest import RestCommand
from tensim.experiments.disturbance import run_disturbance
from tensim.model import WorldOptions, compile_structure
from tensim.models import preset
from tensim.sim import COM, SimulationError, SimulationResult, ramp_hold_release, simulate
from tensim.structure import Cable, Motor, Node, Rod, Structure

STEPS_MS = (0.5, 1.0, 2.0, 4.0, 10.0)
REFERENCE_MS = 0.05
LAWS = ("explicit", "implicit", "implicitfast")
RECORD_DT = 0.02  # s: a whole number of every step above


def three_bar(stiffness: float = 1e4, damping: float = 1e3, rod_length: float = 1.376,
              rod_mass: float = 4.0, force_density: float = 150.0) -> Structure:
    """A lab's 3-bar prism (Snelson's simplex): prism3's shape scaled to ``rod_length`` [m]
    bars of ``rod_mass`` [kg], cables of ``stiffness`` [N/m] and ``damping`` [N s/m],
    prestressed at ``force_density`` [N/m] in the triangles (sqrt 3 of it in the verticals)."""
    radius, height, twist = 0.2, 0.3, math.radians(150.0)
    scale = rod_length / math.dist((radius, 0.0, 0.0), (radius * math.cos(twist),
                                                        radius * math.sin(twist), height))

    def at(angle: float, z: float) -> tuple[float, float, float]:
        return (scale * radius * math.cos(angle), scale * radius * math.sin(angle),
                scale * z + 0.05)

    nodes = tuple(Node(f"b{i}", at(2 * math.pi * i / 3, 0.0)) for i in range(3)) + tuple(
        Node(f"t{i}", at(2 * math.pi * i / 3 + twist, height)) for i in range(3))
    pos = {n.name: np.array(n.position) for n in nodes}
    rods = tuple(Rod(f"rod_{i}", (f"b{i}", f"t{i}"), 0.02, linear_density=rod_mass / rod_length)
                 for i in range(3))
    members = [(f"bottom_{i}", f"b{i}", f"b{(i + 1) % 3}", 1.0) for i in range(3)]
    members += [(f"top_{i}", f"t{i}", f"t{(i + 1) % 3}", 1.0) for i in range(3)]
    members += [(f"vertical_{i}", f"b{i}", f"t{(i + 2) % 3}", math.sqrt(3)) for i in range(3)]
    cables = tuple(
        Cable(name, (a, b), stiffness, damping=damping,
              pretension=force_density * q * float(np.linalg.norm(pos[a] - pos[b])),
              motor=Motor(max_speed=0.2, max_tension=5000.0))
        for name, a, b, q in members)
    return Structure("three_bar", nodes, rods, cables)


Run = Callable[[WorldOptions], SimulationResult]


def _tetraspine3(world: WorldOptions) -> SimulationResult:
    return run_disturbance(dt=world.timestep, world=world)[0]


def _superball(world: WorldOptions) -> SimulationResult:
    structure = preset("superball").build()
    push = ramp_hold_release(structure.nodes[0].name, (0.0, 1.0, 0.0), 150.0, 0.5, 0.2, 0.6,
                             0.2)
    return simulate(compile_structure(structure, world), 3.0, loads=(push,),
                    record_dt=RECORD_DT)


def _three_bar(world: WorldOptions) -> SimulationResult:
    structure = three_bar()
    wound = ("bottom_0", "vertical_1")
    command = RestCommand(wound, tuple(0.75 * structure.rest_length(structure.cable(n))
                                       for n in wound))
    return simulate(compile_structure(structure, world), 4.0, controller=command,
                    record_dt=RECORD_DT)


def _twelve_bar(ntrt: Path) -> Run:
    from tensim.io import import_ntrt

    structure = import_ntrt(ntrt / "src/dev/mcdaly/12BarTensegrity/12BarCube.yaml", "dm",
                            clearance=0.01).structure

    def run(world: WorldOptions) -> SimulationResult:
        return simulate(compile_structure(structure, world), 3.0, record_dt=RECORD_DT)
    return run


def _com(result: SimulationResult) -> tuple[np.ndarray, np.ndarray]:
    ts = result.trajectory
    return ts.time, np.stack([ts[f"pos_{a}/{COM}"] for a in "xyz"], axis=1)


@dataclasses.dataclass(frozen=True)
class Outcome:
    """One run against the reference: worst max-tension change [%], largest distance of the
    centre of mass [m], CPU time per step [us]; ``error`` says why a run did not finish."""

    tension_percent: float = math.nan
    path_m: float = math.nan
    us_per_step: float = math.nan
    error: str | None = None


def compare(result: SimulationResult, reference: SimulationResult) -> tuple[float, float]:
    """(worst cable's max-tension change [%], largest distance of the centre of mass from the
    reference's at the same time [m])."""
    change = 100.0 * (result.peak_tension - reference.peak_tension) / reference.peak_tension
    worst = float(change[np.argmax(np.abs(change))])
    t, com = _com(result)
    t_ref, com_ref = _com(reference)
    at = np.stack([np.interp(t, t_ref, com_ref[:, a]) for a in range(3)], axis=1)
    return worst, float(np.linalg.norm(com - at, axis=1).max())


def travel(result: SimulationResult) -> float:
    """Length of the path of the centre of mass [m]."""
    return float(np.linalg.norm(np.diff(_com(result)[1], axis=0), axis=1).sum())


def timed(run: Run, world: WorldOptions) -> tuple[SimulationResult | None, float, str | None]:
    """The run, its CPU time per step [us], or why it failed."""
    start = time.process_time()
    try:
        result = run(world)
    except SimulationError as err:
        return None, math.nan, str(err).split(":")[0]
    steps = result.duration_s / world.timestep
    return result, (time.process_time() - start) / steps * 1e6, None


def study(name: str, run: Run, cpu: bool = False) -> list[str]:
    """The case's lines: its reference, then one per law and step (``cpu``: with the CPU time
    per step)."""
    reference, _, error = timed(run, WorldOptions(timestep=REFERENCE_MS / 1e3))
    if reference is None:
        return [f"{name}: the reference failed: {error}"]
    moved = travel(reference)
    lines = [f"{name}: reference {REFERENCE_MS} ms explicit: max tension "
             f"{reference.peak_tension.max():.1f} N, centre of mass travels {moved * 1e3:.0f} mm"]
    for law in LAWS:
        for ms in STEPS_MS:
            result, us, error = timed(run, WorldOptions(timestep=ms / 1e3, cable_law=law))
            head = f"  {law:<12} {ms:>4g} ms:"
            if result is None:
                lines.append(f"{head} {error}")
                continue
            tension, path = compare(result, reference)
            lines.append(f"{head} max tension {tension:+7.2f} %, centre of mass "
                         f"{path * 1e3:7.1f} mm ({100 * path / moved:5.1f} % of its travel)"
                         + (f", {us:6.1f} us/step" if cpu else ""))
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", default="tetraspine3,superball,three_bar",
                        help="comma-separated cases (twelve_bar needs --ntrt)")
    parser.add_argument("--ntrt", type=Path, default=None, metavar="NTRTSIM_DIR",
                        help="a checkout of the original toolkit: adds the twelve_bar case")
    parser.add_argument("--cpu", action="store_true", help="also the CPU time per step")
    args = parser.parse_args()
    cases: dict[str, Run] = {"tetraspine3": _tetraspine3, "superball": _superball,
                             "three_bar": _three_bar}
    names = [c.strip() for c in args.cases.split(",") if c.strip()]
    if args.ntrt is not None:
        cases["twelve_bar"] = _twelve_bar(args.ntrt)
        names += [] if "twelve_bar" in names else ["twelve_bar"]
    for name in names:
        if name not in cases:
            parser.error(f"unknown case {name!r}; cases: {', '.join(cases)}")
        print("\n".join(study(name, cases[name], args.cpu)), flush=True)


if __name__ == "__main__":
    main()
