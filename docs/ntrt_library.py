"""Imports every YAML model of the original toolkit, simulates each 5 s and draws the robots.

Usage (from the repository root, with a checkout of the original toolkit's source)::

    python docs/ntrt_library.py NTRTSIM_DIR [--figures docs/figures/ntrt] [--duration 5]

For each ``.yaml`` file under ``NTRTSIM_DIR/resources/YamlStructures`` and ``NTRTSIM_DIR/src/dev``
it prints one line: the counts of the import (nodes, rods, rigid bodies, cables, spheres, mass)
and of a passive simulation in the world the toolkit's application gave it (whether it ran
stably, its peak tension, how far its centre of mass moved), or why it does not import. Every
composite robot (a file with substructures), and this project's own example, gets a picture of
its imported pose, ``<figures>/<folder>_<name>.png``, rendered offscreen by tensim.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import mujoco
import numpy as np
import PIL.Image

from tensim.io import import_ntrt
from tensim.model import WorldOptions, compile_structure
from tensim.sim import SimulationError, simulate
from tensim.structure import Structure, StructureError
from tensim.viz.render import OffscreenRenderer

UNITS = "dm"  # the toolkit's YAML application (BuildTensegrityModel) sets gravity 98.1 dm/s^2
# the applications that ran a file in another world: AppSpineKinematicsTest (no gravity,
# 0.1 ms steps)
WORLDS = {"SpineKinematicsTest": WorldOptions(timestep=1e-4, gravity=(0.0, 0.0, 0.0))}
EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "ntrt" / "prism_tower.yaml"


@dataclasses.dataclass(frozen=True)
class Outcome:
    """What became of one file: its import, its simulation, its picture."""

    name: str
    line: str
    composite: bool


def world_for(path: Path) -> WorldOptions:
    """The world the toolkit's application simulated ``path`` in (SI)."""
    return next((w for folder, w in WORLDS.items() if folder in path.parts), WorldOptions())


def picture(structure: Structure, world: WorldOptions, out: Path) -> None:
    """Renders the imported pose (cables at their pretension) as a small PNG."""
    compiled = compile_structure(structure, world)
    data = mujoco.MjData(compiled.model)
    mujoco.mj_forward(compiled.model, data)
    tension = np.array([c.pretension or 0.0 for c in structure.cables])
    with OffscreenRenderer(compiled, 320, 240) as renderer:
        image = renderer.render(data, tension, compiled.rest_length, structure.name)
    out.parent.mkdir(parents=True, exist_ok=True)
    # 128 colours keep a picture near 20 kB
    PIL.Image.fromarray(image).quantize(128).save(out, format="png", optimize=True)


def picture_name(path: Path) -> str:
    """``<folder>_<file>.png``: unique, as two folders hold a TetrahedralSpine.yaml."""
    return f"{path.parent.name}_{path.stem}.png"


def run_one(path: Path, root: Path, figures: Path | None, duration: float) -> Outcome:
    """Imports, simulates and (for composite robots) draws one file."""
    name = str(path.relative_to(root)) if path.is_relative_to(root) else path.name
    composite = any(line.startswith("substructures:") for line in path.read_text().splitlines())
    try:
        result = import_ntrt(path, UNITS, clearance=0.01)
    except StructureError as err:
        return Outcome(name, f"{name}: does not import: {err.detail}", composite)
    s, world = result.structure, world_for(path)
    counts = (f"{len(s.nodes)} nodes, {len(s.rods)} rods in {len(s.rigid_groups())} bodies, "
              f"{len(s.cables)} cables, {len(s.point_masses)} spheres, {s.total_mass():.3g} kg")
    try:
        run = simulate(compile_structure(s, world), duration, record_dt=0.05)
    except SimulationError as err:
        return Outcome(name, f"{name}: {counts}; UNSTABLE: {err}", composite)
    series = run.trajectory
    com = np.stack([series[f"pos_{k}/com"] for k in "xyz"], axis=1)
    stable = bool(np.all(np.isfinite(com)))
    peak = float(run.peak_tension.max()) if s.cables else 0.0
    line = (f"{name}: {counts}; {duration:g} s {'stable' if stable else 'NOT FINITE'} "
            f"(g = {abs(world.gravity[2]):g} m/s^2, dt = {world.timestep:g} s), peak tension "
            f"{peak:.1f} N, centre of mass moved {np.linalg.norm(com[-1] - com[0]):.2f} m")
    if figures is not None and (composite or path == EXAMPLE):
        picture(s, world, figures / picture_name(path))
    return Outcome(name, line, composite)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("ntrtsim", type=Path, help="a checkout of NTRTsim's source")
    parser.add_argument("--figures", type=Path, default=Path("docs/figures/ntrt"),
                        help="folder for the pictures (default docs/figures/ntrt)")
    parser.add_argument("--no-figures", action="store_true", help="draw nothing")
    parser.add_argument("--duration", type=float, default=5.0, help="simulated time [s]")
    args = parser.parse_args()
    root = args.ntrtsim.resolve()
    files = sorted([*(root / "resources" / "YamlStructures").rglob("*.yaml"),
                    *(root / "src" / "dev").rglob("*.yaml")])
    if not files:
        raise SystemExit(f"no .yaml files under {root}/resources/YamlStructures or src/dev")
    figures = None if args.no_figures else args.figures
    outcomes = [run_one(f, root, figures, args.duration) for f in [*files, EXAMPLE]]
    for outcome in outcomes:
        print(("* " if outcome.composite else "  ") + outcome.line)
    imported = [o for o in outcomes[:-1] if "does not import" not in o.line]
    stable = [o for o in imported if " stable " in o.line]
    print(f"{len(files)} files of the toolkit: {len(imported)} import, {len(stable)} of them "
          f"simulate {args.duration:g} s stably (* = composite robot)")


if __name__ == "__main__":
    main()
