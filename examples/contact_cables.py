"""Figures of docs/cables.md: contact cables against closed forms, and their bead-mass bound.

Usage: python examples/contact_cables.py [--climb [SECONDS]]

``--climb`` also runs the first SECONDS (default 75, the whole scenario; a few minutes) of the
12-segment Tetraspine's wall climb with straight cables and with its lowest cables as contact
cables, at two timesteps.
"""

from __future__ import annotations

import dataclasses
import sys

import mujoco
import numpy as np

from tensim.model import CompiledModel, WorldOptions, _beads, compile_structure
from tensim.model._beads import BEAD_BIT, stable_inertia
from tensim.models import preset
from tensim.sim import Simulation, SimulationError
from tensim.structure import Cable, CableContact, Node, PointMass, Structure
from tensim.terrain import Wall

R = 0.005  # bead radius [m]
G = 9.81  # m/s^2
WALL = Wall(height=0.3, distance=-0.1, thickness=0.1)  # a block whose top edge is x = 0, z = 0.3


def over_edge(mass: float = 0.001, damping: float = 20.0) -> Structure:
    """A 1 kg mass on a 1000 N/m cable from the block's top, released beside its edge."""
    return Structure(
        "edge", (Node("a", (-0.08, 0.0, R), fixed=True), Node("b", (0.15, 0.0, R))),
        point_masses=(PointMass("b", 1.0, 0.002),),
        cables=(Cable("c", ("a", "b"), 1000.0, damping=damping, rest_length=0.2,
                      contact=CableContact(spacing=0.02, radius=R, mass=mass)),))


def bead_force(m: mujoco.MjModel, d: mujoco.MjData) -> np.ndarray:
    """(3,) the beads' push on the world [N]."""
    total = np.zeros(3)
    for i in range(d.ncon):
        contact, force = d.contact[i], np.zeros(6)
        if m.geom_bodyid[contact.geom[1]] < 2 and m.geom_bodyid[contact.geom[0]] < 2:
            continue  # not a bead
        mujoco.mj_contactForce(m, d, i, force)
        sign = -1 if m.geom_bodyid[contact.geom[0]] == 0 else 1
        total += sign * force[:3] @ contact.frame.reshape(3, 3)
    return total


def edge_figures() -> None:
    compiled = compile_structure(over_edge(), WorldOptions(terrain=WALL))
    with Simulation(compiled) as sim:
        sim.run(3.0)
        m, d = sim.model, sim.data
        push, pull, steps = np.zeros(3), np.zeros(3), 1000
        for _ in range(steps):  # averaged over 1 s: the mass still swings a little
            sim.step(1)
            path = d.wrap_xpos.reshape(-1, 3)[d.ten_wrapadr[0]:d.ten_wrapadr[0]
                                              + d.ten_wrapnum[0]]
            ends = [(path[0] - path[1]), (path[-1] - path[-2])]
            pull += -d.actuator_force[0] * sum(e / np.linalg.norm(e) for e in ends) / steps
            push += bead_force(m, d) / steps
        beads = compiled.index.bead
        inertia = m.body_mass[beads[0]] + m.dof_armature[m.body_dofadr[beads[0]]]
        print(f"over a block edge: {beads.size} beads of {m.body_mass[beads[0]] * 1e3:.3g} g "
              f"(inertia {inertia * 1e3:.3g} g), tension {-d.actuator_force[0]:.3f} N")
        print(f"  push on the block {np.round(push, 3)} N, vector sum of the tensions "
              f"{np.round(pull, 3)} N, bead weight {G * m.body_mass[beads].sum():.3f} N")
        edge = np.array([0.0, 0.0, 0.3])
        closed = sum(np.linalg.norm(p - edge) for p in (path[0], path[-1]))
        print(f"  path {d.ten_length[0]:.4f} m, over the edge {closed:.4f} m")


def stability_scan() -> None:
    print("the edge case's first 2 s by bead inertia (mass, no armature) and cable damping "
          "(dt 1 ms):")
    for damping in (0.0, 5.0, 20.0):
        row = []
        for grams in (1, 2, 4, 8, 16):
            _beads.SAFETY, safety = 0.0, _beads.SAFETY  # no armature: the mass alone
            try:
                compiled = compile_structure(over_edge(grams / 1e3, damping),
                                             WorldOptions(terrain=WALL))
            finally:
                _beads.SAFETY = safety
            row.append(f"{grams} g {'ok' if runs(compiled) else 'unstable'}")
        default = compile_structure(over_edge(damping=damping), WorldOptions(terrain=WALL))
        m, bead = default.model, default.index.bead[0]
        inertia = m.body_mass[bead] + m.dof_armature[m.body_dofadr[bead]]
        row.append(f"default {inertia * 1e3:.3g} g {'ok' if runs(default) else 'unstable'}")
        print(f"  b = {damping:g} N s/m: {', '.join(row)}")


def runs(compiled: CompiledModel, duration: float = 2.0) -> bool:
    """Whether ``duration`` seconds of it run without a SimulationError."""
    try:
        with Simulation(compiled) as sim:
            sim.run(duration)
    except SimulationError:
        return False
    return True


def preset_masses() -> None:
    cable = preset("tetraspine").build().cables[0]
    for dt in (1e-3, 2.5e-4):
        print(f"Tetraspine cable (k {cable.stiffness:g} N/m, b {cable.damping:g} N s/m) at "
              f"dt {dt * 1e3:g} ms: bead inertia {stable_inertia(cable, 0.04, dt) * 1e3:.3g} g")


def climb(contact: CableContact | None, dt: float, touching: bool = True,
          duration: float | None = None) -> str:
    """The climb scenario's outcome after ``duration`` seconds (None: the whole scenario) with
    the lowest cables as contact cables (None: straight); ``touching=False`` keeps the beads but
    lets them pass through the world."""
    from tensim.benchmarks.engine import CONTACT_TAGS
    from tensim.experiments.climb import (
        CLIMB_DURATION,
        CLIMB_TERRAIN,
        climb_controller,
        wall_progress,
    )

    structure = preset("tetraspine").build()
    structure = dataclasses.replace(structure, cables=tuple(
        dataclasses.replace(c, contact=contact) if set(c.tags) & set(CONTACT_TAGS) else c
        for c in structure.cables))
    compiled = compile_structure(structure, WorldOptions(terrain=CLIMB_TERRAIN, timestep=dt))
    if not touching:  # the world's geoms lose the bit that beads touch
        compiled.model.geom_contype[compiled.model.geom_bodyid == 0] &= ~BEAD_BIT
    m, bead = compiled.model, compiled.index.bead
    beads = m.body_mass[bead] + m.dof_armature[m.body_dofadr[bead]]
    controller = climb_controller(CLIMB_DURATION).build(dt)
    what = f"{beads.size} beads, {m.body_mass[bead].sum():.3f} kg, inertia {beads.sum():.2f} kg" \
        if beads.size else "straight cables"
    what += "" if touching else " touching nothing"
    try:
        with Simulation(compiled, controller=controller) as sim:
            if not touching:  # its cables pass through the wall, as the check would report
                sim._contact = None
            series = sim.run(duration or CLIMB_DURATION)
    except SimulationError as err:
        return f"dt {dt * 1e3:g} ms, {what}: {str(err)[:80]}..."
    progress = wall_progress(series, CLIMB_TERRAIN)
    return (f"dt {dt * 1e3:g} ms, {what}: {progress['segments_past_wall']} of 12 segments past "
            f"the wall, front rose {progress['front_height_reached_m']:.3f} m")


if __name__ == "__main__":
    edge_figures()
    stability_scan()
    preset_masses()
    if "--climb" in sys.argv[1:]:
        rest = sys.argv[sys.argv.index("--climb") + 1:]
        seconds = float(rest[0]) if rest else 75.0
        print(f"wall climb, first {seconds:g} s (robot 10.57 kg):")
        for contact, dt in ((None, 1e-3), (CableContact(), 1e-3), (CableContact(), 2.5e-4)):
            print(" ", climb(contact, dt, duration=seconds))
        print(" ", climb(CableContact(), 2.5e-4, touching=False, duration=seconds))
