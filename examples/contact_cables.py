"""Figures of docs/cables.md: contact cables against closed forms, and their bead-mass bound.

Usage: python examples/contact_cables.py [--climb]

``--climb`` also runs the 12-segment Tetraspine's 75 s wall climb with straight cables and with
its lowest cables as contact cables, at two timesteps (a few minutes).
"""

from __future__ import annotations

import dataclasses
import sys

import mujoco
import numpy as np

from tensim.model import WorldOptions, compile_structure
from tensim.model._beads import BEAD_BIT, stable_bead_mass
from tensim.models import preset
from tensim.sim import Simulation, SimulationError
from tensim.structure import Cable, CableContact, Node, PointMass, Structure
from tensim.terrain import Wall

R = 0.005  # bead radius [m]
WALL = Wall(height=0.3, distance=-0.1, thickness=0.1)  # a block whose top edge is x = 0, z = 0.3


def over_edge(mass: float | None = None, damping: float = 20.0) -> Structure:
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
        sim.run(4.0)
        m, d = sim.model, sim.data
        t = -d.actuator_force[0]
        edge = np.array([0.0, 0.0, 0.3])
        ends = [d.site_xpos[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "c_0")], d.xpos[1]]
        pull = t * sum((p - edge) / np.linalg.norm(p - edge) for p in ends)
        closed = sum(np.linalg.norm(p - edge) for p in ends)
        print(f"over a block edge: {m.nbody - 2} beads of {m.body_mass[2] * 1e3:.3g} g, "
              f"tension {t:.3f} N")
        print(f"  push on the block {np.round(bead_force(m, d), 3)} N, "
              f"vector sum of the tensions {np.round(pull, 3)} N, "
              f"bead weight {(m.nbody - 2) * m.body_mass[2] * 9.81:.3f} N")
        print(f"  path {d.ten_length[0]:.4f} m, over the edge {closed:.4f} m")


def stability_scan() -> None:
    print("the edge case's first 2 s by bead mass and cable damping (dt 1 ms):")
    for damping in (0.0, 5.0, 20.0):
        row = []
        default = compile_structure(over_edge(damping=damping), WorldOptions(terrain=WALL))
        for grams in (1, 2, 4, 8, 16, None):
            name = f"{grams} g" if grams else f"default {default.model.body_mass[2] * 1e3:.3g} g"
            try:
                with Simulation(compile_structure(over_edge(grams and grams / 1e3, damping),
                                                  WorldOptions(terrain=WALL))) as sim:
                    sim.run(2.0)
                row.append(f"{name} ok")
            except SimulationError:
                row.append(f"{name} unstable")
        print(f"  b = {damping:g} N s/m: {', '.join(row)}")


def preset_masses() -> None:
    cable = preset("tetraspine").build().cables[0]
    for dt in (1e-3, 2.5e-4):
        print(f"Tetraspine cable (k {cable.stiffness:g} N/m, b {cable.damping:g} N s/m) at "
              f"dt {dt * 1e3:g} ms: beads of {stable_bead_mass(cable, 0.04, dt) * 1e3:.3g} g")


def climb(contact: CableContact | None, dt: float, touching: bool = True) -> str:
    """The climb scenario's outcome with the lowest cables as contact cables (None: straight);
    ``touching=False`` keeps the beads but lets them pass through the world."""
    from tensim.bench import CONTACT_TAGS
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
    beads = compiled.model.body_mass[compiled.index.bead]
    controller = climb_controller(CLIMB_DURATION).build(dt)
    what = f"{beads.size} beads, {beads.sum():.2f} kg" if beads.size else "straight cables"
    what += "" if touching else " touching nothing"
    try:
        with Simulation(compiled, controller=controller) as sim:
            series = sim.run(CLIMB_DURATION)
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
        print("wall climb, 75 s (robot 10.57 kg):")
        for contact, dt in ((None, 1e-3), (CableContact(), 1e-3), (CableContact(), 2.5e-4),
                            (CableContact(mass=0.02), 2.5e-4)):
            print(" ", climb(contact, dt))
        print(" ", climb(CableContact(mass=0.02), 2.5e-4, touching=False))
