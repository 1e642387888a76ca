"""The cable laws' time-step study: max tensions and paths at 0.5-10 ms steps against a
0.05 ms run of the explicit law, for robots with soft and with stiff cables
(``tensim experiment laws``).

Cases:
- ``tetraspine3``: the paper's 60 s disturbance test (``tensim experiment disturbance``);
- ``superball``: the SUPERball-scale six-bar (preset ``superball``) pushed sideways at one
  node for 1 s of its 3 s;
- ``three_bar``: a lab's 3-bar prism, built here: 1.376 m, 4 kg bars, cables of 10 kN/m and
  1000 N s/m, two of them wound in by a quarter of their length over 4 s;
- ``twelve_bar`` (given ``ntrt``, a checkout of the original toolkit): its 12-bar cube,
  ``src/dev/mcdaly/12BarTensegrity/12BarCube.yaml``, dropped for 3 s;
- ``tetraspine3_soft`` and ``tetraspine3_free_motors`` (asked for by name): the disturbance
  test with the impedance laws' damping gains B divided by 5, and with motors of 10 m/s
  instead of 0.07 m/s, reference included: what sets its error at long steps
  (docs/speed.md).

Each case runs under each law (``explicit``, ``implicit``, ``implicitfast``; see
docs/architecture.md) at each step, and where asked for (``laws``) under ``split``: the
implicit law split by cable at ``WorldOptions.split_margin`` 4 or as asked (its lines also say
how many cables are handed to the integrator at that step); a line gives the worst cable's
change of maximum tension against the reference (per cent of that cable's reference peak),
the largest distance of the centre of mass from the reference's at the same time (mm, and per
cent of the distance the reference's centre of mass travels), and the CPU time per step of
the whole run (it varies with the machine and its load; the other figures do not). A run that
fails its stability check is reported as unstable.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tensim.control import ControllerConfig
from tensim.control.impedance import ImpedanceController
from tensim.control.rest import RestCommand
from tensim.experiments.disturbance import run_disturbance
from tensim.model import WorldOptions, compile_structure
from tensim.model._law_layout import CABLE_LAWS, LAW_IMPLICIT, implicit
from tensim.model._split import MARGIN
from tensim.models import preset
from tensim.sim import COM, SimulationError, SimulationResult, ramp_hold_release, simulate
from tensim.structure import Cable, Motor, Node, Rod, Structure

STEPS_MS = (0.5, 1.0, 2.0, 4.0, 10.0)
REFERENCE_MS = 0.05
LAWS = CABLE_LAWS
SPLIT = "split"  # the implicit law split by cable (at split_margin MARGIN unless asked)
ROWS = (*CABLE_LAWS, SPLIT)


def row_world(law: str, timestep: float, split_margin: float = MARGIN) -> WorldOptions:
    """The world of a row of the study (a name of ``ROWS``) at ``timestep`` [s]."""
    if law == SPLIT:
        return WorldOptions(timestep=timestep, cable_law=LAW_IMPLICIT, split_margin=split_margin)
    return WorldOptions(timestep=timestep, cable_law=law)
CASES = ("tetraspine3", "superball", "three_bar")  # twelve_bar: with a checkout of the toolkit
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


def _tetraspine3_variant(damping_scale: float = 1.0, max_speed: float | None = None,
                         stiffness_scale: float = 1.0) -> Run:
    """The disturbance test with the impedance laws' B scaled by ``damping_scale``, every
    motor's speed limit set to ``max_speed`` [m/s] (None: as built) and every cable's stiffness
    scaled by ``stiffness_scale``."""
    model = preset("tetraspine3")
    structure = model.build()
    if stiffness_scale != 1.0:
        structure = dataclasses.replace(structure, cables=tuple(
            dataclasses.replace(c, stiffness=c.stiffness * stiffness_scale)
            for c in structure.cables))
    if max_speed is not None:
        structure = dataclasses.replace(structure, cables=tuple(
            dataclasses.replace(c, motor=dataclasses.replace(c.motor, max_speed=max_speed))
            for c in structure.cables))
    laws = model.controller()
    if not isinstance(laws, ImpedanceController):
        raise TypeError("tetraspine3's controller is no longer its impedance laws")
    laws = dataclasses.replace(laws, gains={
        name: dataclasses.replace(g, damping_gain=damping_scale * g.damping_gain)
        for name, g in laws.gains.items()})

    def run(world: WorldOptions) -> SimulationResult:
        return run_disturbance(dt=world.timestep, world=world, structure=structure,
                               controller=ControllerConfig(laws), model="tetraspine3")[0]
    return run


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
    structure = _twelve_bar_structure(ntrt)

    def run(world: WorldOptions) -> SimulationResult:
        return simulate(compile_structure(structure, world), 3.0, record_dt=RECORD_DT)
    return run


def _com(result: SimulationResult) -> tuple[np.ndarray, np.ndarray]:
    ts = result.trajectory
    return ts.time, np.stack([ts[f"pos_{a}/{COM}"] for a in "xyz"], axis=1)


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


def handed_over(structure: Structure, world: WorldOptions) -> int:
    """How many of ``structure``'s cables MuJoCo's integrator is handed in ``world``."""
    compiled = compile_structure(structure, world)
    return int(implicit(compiled.model)[:compiled.n_cables].sum())


def study(name: str, run: Run, announce: Callable[[str], None] | None = None,
          laws: tuple[str, ...] = LAWS, structure: Structure | None = None,
          split_margin: float = MARGIN) -> dict[str, Any]:
    """One case under each of ``laws`` (names of ``ROWS``) and step, against its reference
    (JSON-ready); ``structure``, the case's robot, for the split's count of cables, and the
    split's ``split_margin``.

    Returns:
        ``reference`` (max tension [N], the centre of mass's travel [m]) and ``runs``: per law
        and step [ms], the worst cable's max-tension change [%], the largest distance of the
        centre of mass [m] and the CPU time per step [us], or the run's ``error``; the split
        also the cables handed to the integrator and the cables.
    """
    if announce:
        announce(f"{name}: the {REFERENCE_MS} ms reference")
    reference, _, error = timed(run, WorldOptions(timestep=REFERENCE_MS / 1e3))
    if reference is None:
        raise SimulationError(f"{name}: the reference failed: {error}")
    moved = travel(reference)
    runs: dict[str, dict[str, dict[str, Any]]] = {}
    for law in laws:
        for ms in STEPS_MS:
            if announce:
                announce(f"{name}: {law} at {ms:g} ms")
            world = row_world(law, ms / 1e3, split_margin)
            count = {} if law != SPLIT or structure is None else {
                "handed_over": handed_over(structure, world), "cables": len(structure.cables)}
            result, us, error = timed(run, world)
            if result is None:
                runs.setdefault(law, {})[f"{ms:g}"] = {"error": error, **count}
                continue
            tension, path = compare(result, reference)
            runs.setdefault(law, {})[f"{ms:g}"] = {
                "max_tension_change_percent": round(tension, 4), "com_distance_m": round(path, 6),
                "cpu_us_per_step": round(us, 2), **count}
    return {"reference": {"max_tension_N": round(float(reference.peak_tension.max()), 4),
                          "com_travel_m": round(moved, 6)}, "runs": runs}


def _twelve_bar_structure(ntrt: Path) -> Structure:
    from tensim.io import import_ntrt

    return import_ntrt(ntrt / "src/dev/mcdaly/12BarTensegrity/12BarCube.yaml", "dm",
                       clearance=0.01).structure


def run_law_study(cases: tuple[str, ...] = CASES, ntrt: Path | None = None,
                  announce: Callable[[str], None] | None = None,
                  laws: tuple[str, ...] = LAWS, split_margin: float = MARGIN) -> dict[str, Any]:
    """The study over ``cases`` (``twelve_bar`` needs ``ntrt``) and ``laws`` (names of
    ``ROWS``; ``split`` at ``split_margin``); its summary, JSON-ready.

    Raises:
        ValueError: an unknown case or law, or twelve_bar without ``ntrt``.
    """
    for law in laws:
        if law not in ROWS:
            raise ValueError(f"unknown law {law!r}; laws: {', '.join(ROWS)}")
    runners: dict[str, Run] = {"tetraspine3": _tetraspine3, "superball": _superball,
                               "three_bar": _three_bar,
                               "tetraspine3_soft": _tetraspine3_variant(damping_scale=0.2),
                               "tetraspine3_free_motors": _tetraspine3_variant(max_speed=10.0)}
    if ntrt is not None:
        runners["twelve_bar"] = _twelve_bar(ntrt)
    for name in cases:
        if name not in runners:
            raise ValueError(f"unknown case {name!r}; cases: {', '.join(runners)}"
                             + ("" if ntrt else " (twelve_bar with a checkout of the toolkit)"))
    tetraspine3 = preset("tetraspine3").build
    structures: dict[str, Callable[[], Structure]] = {
        "tetraspine3": tetraspine3, "tetraspine3_soft": tetraspine3,
        "tetraspine3_free_motors": tetraspine3, "superball": preset("superball").build,
        "three_bar": three_bar}
    if ntrt is not None:
        structures["twelve_bar"] = lambda: _twelve_bar_structure(ntrt)
    counted = SPLIT in laws
    WorldOptions(cable_law=LAW_IMPLICIT, split_margin=split_margin)  # refuses a bad margin
    return {"experiment": "laws", "reference_ms": REFERENCE_MS, "steps_ms": list(STEPS_MS),
            "laws": list(laws), **({"split_margin": split_margin} if counted else {}),
            "cases": {name: study(name, runners[name], announce, laws,
                                  structures[name]() if counted else None, split_margin)
                      for name in cases}}


def format_law_study(summary: dict[str, Any], cpu: bool = False) -> list[str]:
    """The study's lines: per case its reference, then one per law and step (``cpu``: with
    the CPU time per step)."""
    lines = []
    for name, case in summary["cases"].items():
        moved = case["reference"]["com_travel_m"]
        lines.append(f"{name}: reference {summary['reference_ms']} ms explicit: max tension "
                     f"{case['reference']['max_tension_N']:.1f} N, centre of mass travels "
                     f"{moved * 1e3:.0f} mm")
        for law, steps in case["runs"].items():
            for ms, run in steps.items():
                head = f"  {law:<12} {float(ms):>4g} ms:"
                handed = f", {run['handed_over']} of {run['cables']} cables handed over" \
                    if "handed_over" in run else ""
                if "error" in run:
                    lines.append(f"{head} {run['error']}{handed}")
                    continue
                path = run["com_distance_m"]
                lines.append(f"{head} max tension {run['max_tension_change_percent']:+7.2f} %, "
                             f"centre of mass {path * 1e3:7.1f} mm "
                             f"({100 * path / moved:5.1f} % of its travel)"
                             + (f", {run['cpu_us_per_step']:6.1f} us/step" if cpu else "")
                             + handed)
    return lines
