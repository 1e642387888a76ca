"""``tensim design``: self-stress, stiffness, inverse statics and motor sizing of a structure."""

from __future__ import annotations

import argparse
from pathlib import Path

from tensim.cli._common import load_model, positive


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("design", help="design a structure: prestress, stiffness, which cable to "
                       "pull, motor sizing (see docs/design.md)")
    steps = p.add_subparsers(dest="step", required=True)
    q = steps.add_parser("prestress", help="states of self-stress and mechanisms; write an "
                         "all-tension prestressed structure")
    q.add_argument("model", help="preset name or structure .yaml file")
    level = q.add_mutually_exclusive_group(required=True)
    level.add_argument("--min-tension", type=positive, metavar="N",
                       help="smallest cable tension [N]")
    level.add_argument("--tension", type=positive, metavar="N",
                       help="tension of the cable named by --cable [N]")
    level.add_argument("--force-density", type=positive, metavar="Q",
                       help="mean cable force density t/L [N/m]")
    q.add_argument("--cable", default=None, help="the cable that --tension sets")
    q.add_argument("--out", default=None, metavar="FILE.yaml",
                   help="write the prestressed structure here")
    q.set_defaults(run=run_prestress)
    s = steps.add_parser("stiffness", help="tangent stiffness, mechanisms stiffened by "
                         "prestress, natural frequencies and the softest modes")
    s.add_argument("model", help="preset name or structure .yaml file")
    s.add_argument("--modes", type=int, default=4, help="softest modes to list and draw")
    s.add_argument("--out", default=None, help="output folder (modes.png, stiffness.json)")
    s.set_defaults(run=run_stiffness)


def run_prestress(args: argparse.Namespace) -> int:
    from tensim.design import equilibrium, prestressed, self_stress
    from tensim.design.report import table
    from tensim.structure import save_structure

    structure = load_model(args.model)
    if (args.cable is None) != (args.tension is None):
        raise ValueError("--tension needs --cable NAME (and --cable needs --tension)")
    eq = equilibrium(structure)
    print(f"{structure.name}: {len(eq.cables)} cables, {eq.n_dof} degrees of freedom, "
          f"rank(A) = {eq.rank}")
    print(f"states of self-stress s = {eq.s}; mechanisms m = {eq.m} ({eq.n_rigid} rigid-body "
          f"motions, {eq.internal_mechanisms} internal)")
    stress = self_stress(structure, min_tension=args.min_tension, cable=args.cable,
                         tension=args.tension, force_density=args.force_density)
    rest = stress.lengths - stress.tensions / [c.stiffness for c in structure.cables]
    print(table([(n, t, q, L, r) for n, t, q, L, r in zip(
        stress.cables, stress.tensions, stress.force_densities, stress.lengths, rest,
        strict=True)], ("cable", "tension [N]", "q [N/m]", "length [m]", "rest [m]")))
    if stress.rod_forces:
        print(table(sorted(stress.rod_forces.items()), ("rod", "axial force [N]")))
    if args.out:
        save_structure(prestressed(structure, stress), Path(args.out))
        print(f"wrote {args.out}")
    return 0


def run_stiffness(args: argparse.Namespace) -> int:
    from tensim.design.report import modes_figure, save, table
    from tensim.design.stiffness import stable_timestep, stiffness
    from tensim.runs import finish_run, replace_folder

    structure = load_model(args.model)
    result = stiffness(structure)
    print(f"{structure.name}: {len(result.frequencies)} degrees of freedom, {result.rigid} "
          f"rigid-body motions, {result.mechanisms} internal mechanisms, {result.stiffened} "
          "of them stiffened by prestress")
    live = [k for k in range(len(result.frequencies)) if result.frequencies[k] > 1e-6]
    rows = [(k + 1, float(result.frequencies[k])) for k in live[:args.modes]]
    print(table(rows, ("mode", "frequency [Hz]")))
    limit, frequency, zeta = stable_timestep(result)
    print(f"highest frequency {result.frequencies[-1]:.4g} Hz; Euler step stable below "
          f"{limit * 1e3:.4g} ms (bound set by the {frequency:.4g} Hz mode, damping ratio "
          f"{zeta:.3g})")
    if args.out:
        with replace_folder(Path(args.out)) as stage:
            save(modes_figure(structure, result, args.modes), stage / "modes.png")
            finish_run(stage, {"model": args.model, "rigid": result.rigid,
                               "mechanisms": result.mechanisms, "stiffened": result.stiffened,
                               "frequencies_Hz": [round(float(f), 6) for f in
                                                  result.frequencies],
                               "stable_timestep_s": limit})
        print(f"wrote {args.out}/ (modes.png, summary.json)")
    return 0
