"""``tensim import-ntrt``, ``tensim import-mjcf`` and ``tensim export-mjcf``: bring models in
from the original toolkit's YAML files and from MuJoCo MJCF, send compiled models out as
MJCF."""

from __future__ import annotations

import argparse
from pathlib import Path

from tensim.cli._common import (
    add_world_options,
    load_model,
    nonnegative,
    output_option,
    positive,
    world_from_args,
)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("import-ntrt", help="convert an NTRTsim YAML structure to a tensim one",
                       description="Reads an NTRTsim (original toolkit) YAML structure file and "
                       "its substructure files, converts lengths, forces and densities to SI "
                       "and the Y-up frame to Z-up, and writes a tensim structure file.")
    p.add_argument("file", help="the NTRTsim .yaml structure file")
    p.add_argument("--units", required=True, choices=["m", "dm", "cm", "mm"],
                   help="the file's length unit (the application's gravity tells: 9.81 m, "
                        "98.1 dm, 981 cm)")
    p.add_argument("--up", default="y", choices=["y", "z"],
                   help="the file's up axis (default y, the toolkit's)")
    p.add_argument("--clearance", type=nonnegative, default=0.01,
                   help="place the lowest rod or sphere surface this far above the ground [m] "
                        "(default 0.01)")
    p.add_argument("--keep-position", action="store_true",
                   help="keep the file's positions (no --clearance placement)")
    p.add_argument("--name", default=None, help="structure name (default: the file's stem)")
    output_option(p, "--out", "file", required=True, help="tensim structure .yaml to write")
    p.set_defaults(run=run_import)

    p = sub.add_parser("import-mjcf", help="convert a tensegrity's MuJoCo MJCF file to a tensim "
                       "structure",
                       description="Reads an MJCF file with MuJoCo: bodies with capsule, "
                       "cylinder and sphere geoms become rods, end caps and point masses (mass "
                       "and inertia kept), the sites of spatial tendons nodes, the tendons "
                       "cables, their actuators motors. Prints how each actuator maps and "
                       "every difference from the file's semantics, and writes them as comments "
                       "atop the structure file.")
    p.add_argument("file", help="the MJCF .xml file")
    p.add_argument("--name", default=None, help="structure name (default: the file's model name)")
    output_option(p, "--out", "file", required=True, help="tensim structure .yaml to write")
    p.add_argument("--compare", type=positive, default=None, metavar="SECONDS",
                   help="also run the file in MuJoCo and its import in tensim for this long "
                        "(passive, the file's initial controls) and print how far apart the "
                        "nodes get")
    p.set_defaults(run=run_import_mjcf)

    p = sub.add_parser("export-mjcf", help="write a preset or structure as MuJoCo MJCF",
                       description="Compiles the model and writes it as MJCF for other MuJoCo "
                       "tools: bodies, geoms, the cables' tendons and actuators, and (unless "
                       "--no-springs) tendon springs standing in for the cable law.")
    p.add_argument("model", help="preset name or structure .yaml file")
    add_world_options(p)
    p.add_argument("--no-springs", action="store_true",
                   help="leave the tendons without springs (tensim applies cable tension "
                        "through the actuators)")
    output_option(p, "--out", "file", required=True, help="MJCF .xml file to write")
    p.set_defaults(run=run_export)


def run_import(args: argparse.Namespace) -> int:
    from tensim.io import import_ntrt
    from tensim.structure import save_structure

    result = import_ntrt(args.file, args.units, up=args.up, name=args.name,
                         clearance=None if args.keep_position else args.clearance)
    s = result.structure
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    save_structure(s, out)
    print(f"read {len(result.files)} file(s); wrote {out}: {len(s.nodes)} nodes, {len(s.rods)} "
          f"rods in {len(s.rigid_groups())} rigid bodies, {len(s.cables)} cables, "
          f"{s.total_mass():.4g} kg")
    for note in result.notes:
        print(f"note: {note}")
    return 0


def run_import_mjcf(args: argparse.Namespace) -> int:
    from tensim.io import import_mjcf, save_import

    result = import_mjcf(args.file, name=args.name, warn=False)
    s = result.structure
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    save_import(result, out)
    motors = sum(not c.motor.passive for c in s.cables)
    print(f"wrote {out}: {len(s.nodes)} nodes, {len(s.rods)} rods in "
          f"{len(s.rigid_groups())} rigid bodies, {len(s.cables)} cables ({motors} with "
          f"motors), {s.total_mass():.4g} kg")
    for line in result.header()[1:]:
        print(line)
    if args.compare is not None:
        from tensim.io import compare_with_mujoco

        agreement = compare_with_mujoco(args.file, args.compare)
        print(f"compared with MuJoCo's own run of the file over {agreement.duration:g} s (the "
              f"file's rod inertia kept): nodes within {agreement.max_difference:.2g} m "
              f"({agreement.final_difference:.2g} m at the end); they moved up to "
              f"{agreement.max_displacement:.2g} m")
    return 0


def run_export(args: argparse.Namespace) -> int:
    from tensim.io import save_mjcf
    from tensim.model import compile_structure

    compiled = compile_structure(load_model(args.model), world_from_args(args))
    out = save_mjcf(compiled, args.out, springs=not args.no_springs)
    m = compiled.model
    print(f"wrote {out}: {m.nbody - 1} bodies, {m.ngeom} geoms, {m.ntendon} tendons, "
          f"{m.nu} actuators" + ("" if args.no_springs else ", tendon springs for the cables"))
    return 0
