"""A model check: what in a structure makes its runs fail, or lie, and what to change.

Each finding names the item, what is wrong and the change that fixes it:

- time step: the linearised motion of the bodies on the cables, M x'' = -K x - C x' with each
  cable's stiffness and damping as they are (:mod:`tensim.design.stiffness`). MuJoCo's Euler
  step applies the cable forces explicitly; it is stable while the step matrix's spectral
  radius is at most 1 (:func:`~tensim.design.stiffness.step_bound`; for one mode
  x'' = -omega^2 x - 2 zeta omega x' that is dt < 2 (sqrt(1 + zeta^2) - zeta) / omega), and
  above half of that bound it rings and damps wrongly. Under the ``implicitfast`` cable law
  the bound is MuJoCo's ``implicitfast`` step's (each body's own share of the damping
  implicit); under the ``implicit`` law (``discrete``) the linearised step is stable at every
  step, which a note says with the explicit law's bound;
- thin rods: a rod body whose axial inertia is under 1e-4 of its transverse one;
- slack cables at the build pose (rest length at or above the length);
- a build pose far from equilibrium: the cables' net force on a body above twice the robot's
  weight (gravity and the ground cannot hold it: the robot springs to another pose); above
  half the weight, a note (the robot settles into a nearby pose);
- cables whose file gives no motor (a note: they are passive), or a pretension above the
  motor's tension limit;
- sizes that look like centimetres or decimetres (tensim reads metres).
"""

from __future__ import annotations

import dataclasses
import logging
import os
from pathlib import Path

import numpy as np

from tensim._input import load_yaml_file
from tensim.design._blas import one_blas_thread
from tensim.design._bodies import BuildPose, build_pose, cable_tensions
from tensim.design.equilibrium import residuals
from tensim.design.stiffness import LAW_INTEGRATORS, step_bound, stiffness
from tensim.structure import Structure, StructureError, mass_properties

_log = logging.getLogger(__name__)

INERTIA_RATIO = 1e-4  # smallest axial / transverse inertia of a rod body that integrates well
RESIDUAL_NOTE = 0.5  # net cable force on a body, in robot weights, worth a note
RESIDUAL_WEIGHTS = 2.0  # net cable force on a body, in robot weights, that counts as far
GRAVITY = 9.81  # m/s^2
LARGEST_SIZE = 10.0  # m: a robot larger than this was probably written in cm or dm
MAX_DOF = 2000  # the time-step check solves a dense eigenproblem: skipped above this size


@dataclasses.dataclass(frozen=True)
class Finding:
    """One problem the check found.

    Attributes:
        severity: ``error`` (runs fail or are wrong), ``warning`` (runs may mislead) or
            ``note`` (true of the robot, worth knowing, harmless).
        item: the part concerned, e.g. ``cable 'top_0'`` or ``timestep``.
        message: what is wrong, with the numbers.
        fix: what to change.
    """

    severity: str
    item: str
    message: str
    fix: str

    def __str__(self) -> str:
        return f"{self.severity}: {self.item}: {self.message}; {self.fix}"


def nice_step(limit: float) -> float:
    """The largest of 1, 2, 5 x 10^k that is at most ``limit`` [s]."""
    exponent = np.floor(np.log10(limit))
    for mantissa in (5.0, 2.0, 1.0):
        if mantissa * 10**exponent <= limit:
            return float(mantissa * 10**exponent)
    return float(10 ** (exponent - 1) * 5)


@one_blas_thread
def check_structure(structure: Structure, timestep: float = 1e-3,
                    source: str | os.PathLike[str] | None = None,
                    integrator: str | None = None, cable_law: str = "explicit"
                    ) -> list[Finding]:
    """Every finding for ``structure`` simulated with the physics step ``timestep`` [s].

    Args:
        structure: the structure.
        timestep: the physics step to check [s].
        source: the YAML file it was read from, if any: cables whose motor the file leaves out
            (so they are passive) are then named in a note.
        integrator: how the step sees the cable forces, ``euler`` (explicit), ``implicitfast``
            (each body's share of their damping implicit) or ``discrete`` (their stiffness and
            damping implicit); see :func:`~tensim.design.stiffness.step_bound`. None: the
            integrator of ``cable_law``.
        cable_law: the cable law the runs use (``explicit``, ``implicit``, ``implicitfast``:
            ``WorldOptions.cable_law``), when ``integrator`` is None.

    Raises:
        ValueError: an unknown cable law or integrator.
    """
    if integrator is None:
        if cable_law not in LAW_INTEGRATORS:
            raise ValueError(f"cable_law must be one of {', '.join(LAW_INTEGRATORS)}, got "
                             f"{cable_law!r}"[:200])
        integrator = LAW_INTEGRATORS[cable_law]
    findings = (_units(structure) + _slack(structure) + _motors(structure, source)
                + _thin(structure))
    try:
        pose = build_pose(structure)  # once: every dynamic check reads it
    except StructureError as err:  # wrapped cables: the analyses need straight paths
        return [*findings, Finding("warning", "structure", f"dynamic checks skipped: {err}",
                                   "check the time step with `tensim experiment timestep`")]
    return findings + _timestep(structure, timestep, pose, integrator) \
        + _equilibrium(structure, pose)


def _timestep(structure: Structure, timestep: float, pose: BuildPose,
              integrator: str) -> list[Finding]:
    if not structure.cables:
        return []
    if pose.bodies.n_dof > MAX_DOF:
        return [Finding("warning", "timestep", f"not checked: more than {MAX_DOF} degrees of "
                        "freedom", "compare runs at two values of --dt")]
    result = stiffness(structure, count=False, pose=pose)
    bound = step_bound(result, integrator)
    limit = bound.limit
    if integrator == "discrete":
        return _any_step(step_bound(result, "euler").limit)
    if not np.isfinite(limit):
        return []
    needed = nice_step(limit / 2)
    step = "Euler" if integrator == "euler" else integrator
    text = (f"its hardest mode to integrate is at {bound.frequency:.4g} Hz (damping ratio "
            f"{bound.damping_ratio:.3g}); the {step} step is stable below {limit * 1e3:.4g} ms")
    if timestep >= limit:
        return [Finding("error", "timestep", f"{text}, and {timestep * 1e3:g} ms blows up",
                        f"use --dt {needed:g} or softer / heavier parts")]
    if timestep > limit / 2:
        return [Finding("warning", "timestep", f"{text}; {timestep * 1e3:g} ms rings and "
                        "damps wrongly", f"use --dt {needed:g}")]
    return []


def _any_step(explicit: float) -> list[Finding]:
    """The implicit law's note: its linearised step is stable at every step (trapezoidal in
    the cables' stiffness and damping); the explicit law's bound beside it."""
    if not np.isfinite(explicit):
        return []
    return [Finding("note", "timestep", "under the implicit cable law (MuJoCo's discrete "
                    "step) the linearised motion is stable at any step; the explicit law's "
                    f"Euler step is stable below {explicit * 1e3:.4g} ms",
                    "a long step is stable, not exact: docs/speed.md gives the error at "
                    "0.5-10 ms")]


def _thin(structure: Structure) -> list[Finding]:
    out = []
    for group in structure.rigid_groups():
        if len(group.rods) != 1 or len(group.nodes) != 2:
            continue
        moments = mass_properties(structure, group).principal_moments()
        ratio = moments[0] / moments[2]
        if ratio < INERTIA_RATIO:
            rod = next(r for r in structure.rods if r.name == group.rods[0])
            length = structure.distance(*rod.nodes)
            out.append(Finding(
                "warning", f"rod {rod.name!r}",
                f"its axial inertia is {ratio:.2g} of its transverse inertia (radius "
                f"{rod.radius:g} m on {length:.3g} m)",
                f"use a radius of at least {length * np.sqrt(INERTIA_RATIO / 6):.2g} m or put "
                "point masses at its ends"))
    return out


def _slack(structure: Structure) -> list[Finding]:
    return [Finding("warning", f"cable {c.name!r}",
                    f"slack at the build pose (rest length {structure.rest_length(c):.4g} m >= "
                    f"length {structure.cable_length(c):.4g} m)",
                    "give it a pretension > 0 N, or run `tensim design prestress`")
            for c in structure.cables
            if structure.rest_length(c) >= structure.cable_length(c)]


def _without_motor(source: str | os.PathLike[str] | None) -> list[str]:
    """Cables of a structure file that give no motor, here or in the file's defaults (they are
    passive: :func:`tensim.structure.motor_sources`)."""
    path = Path(source) if source is not None else None
    if path is None or path.suffix not in (".yaml", ".yml") or not path.is_file():
        return []
    data = load_yaml_file(path)
    defaults = (data.get("defaults") or {}).get("cable") or {}
    if "motor" in defaults:
        return []
    return [c.get("name", "?") for c in data.get("cables") or []
            if isinstance(c, dict) and "motor" not in c]


def _motors(structure: Structure, source: str | os.PathLike[str] | None) -> list[Finding]:
    passive = _without_motor(source)
    out = []
    if passive:
        names = ", ".join(passive[:4]) + (" ..." if len(passive) > 4 else "")
        out.append(Finding(
            "note", f"{len(passive)} cable(s)",
            f"{names} give no motor, so they are passive (their rest lengths never change)",
            "give a cable a motor if a controller should drive it"))
    for cable, tension in zip(structure.cables, cable_tensions(structure), strict=True):
        if cable.motor.passive or tension <= cable.motor.max_tension:
            continue
        if cable.motor.saturate:  # a force cap: the motor pays out to it at once
            out.append(Finding(
                "note", f"cable {cable.name!r}",
                f"its build tension {tension:.4g} N is above its motor's force cap "
                f"{cable.motor.max_tension:.4g} N: the motor pays out at the start until the "
                "cable pulls the cap (Motor.saturate)",
                "lower the pretension if the robot should start at rest"))
        else:
            out.append(Finding(
                "error", f"cable {cable.name!r}",
                f"its build tension {tension:.4g} N exceeds its motor's max_tension "
                f"{cable.motor.max_tension:g} N", "raise max_tension or lower the pretension"))
    return out


def _equilibrium(structure: Structure, pose: BuildPose) -> list[Finding]:
    # judged against the robot's weight: a net cable force of the order of the weight is taken
    # up by gravity and the ground, and the robot settles near where it stands (Tetraspine3's
    # end segments, pulled inward by 1.45 weights, slide 4 cm and stay down): a note; one
    # several times the weight springs it into another pose (a prism3 cable at 2x its
    # pretension, 3.8 weights, lifts a rod 6 mm; at 6x, 19 weights, 35 mm): a warning
    weight = structure.total_mass() * GRAVITY
    if weight <= 0:
        return []
    forces = residuals(structure, pose=pose)
    if not forces:  # every body is held by the world
        return []
    name, (force, _) = max(forces.items(), key=lambda kv: kv[1][0])
    if force <= RESIDUAL_NOTE * weight:
        return []
    text = (f"the cables' net force on it at the build pose (gravity left out) is {force:.4g} N, "
            f"{force / weight:.3g} times the robot's weight {weight:.4g} N")
    fix = "run `tensim design prestress` for pretensions that balance"
    if force <= RESIDUAL_WEIGHTS * weight:
        return [Finding("note", f"body {name!r}", f"{text}: the build pose is not an "
                        "equilibrium, and the robot settles into a nearby one when released",
                        fix)]
    return [Finding("warning", f"body {name!r}", f"{text}: the build pose is far from "
                    "equilibrium, more than gravity and the ground can hold, so the robot "
                    "springs to another pose when released", fix)]


def _units(structure: Structure) -> list[Finding]:
    points = np.array([n.position for n in structure.nodes])
    size = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    if size <= LARGEST_SIZE:
        return []
    return [Finding("warning", "structure",
                    f"it spans {size:.4g} m, which looks like centimetres or decimetres",
                    "positions are in metres: scale the file (imports take --units)")]


def warn_findings(structure: Structure, timestep: float,
                  source: str | os.PathLike[str] | None = None,
                  cable_law: str = "explicit") -> None:
    """Logs every finding as a warning, notes at INFO (``simulate`` runs the check before it
    starts, for its cable law)."""
    for finding in check_structure(structure, timestep, source, cable_law=cable_law):
        level = logging.INFO if finding.severity == "note" else logging.WARNING
        _log.log(level, "%s: %s; %s", finding.item, finding.message, finding.fix)
