"""Cable physics in running simulations, against closed-form mechanics.

Each model is built inline and small, so every expected number follows from a line of
mechanics: a mass on a spring, a held cable, self-stressed structures.
"""

from __future__ import annotations

import re

import mujoco
import numpy as np
import pytest

from statics import self_stress
from tensim.control import ImpedanceController, ImpedanceGains
from tensim.model import WorldOptions, compile_structure
from tensim.models import prism3, six_bar
from tensim.sim import NodeLoad, Simulation, SimulationError, compiled_available, simulate
from tensim.structure import Cable, Motor, Node, PointMass, Rod, Structure

G = 9.81
BACKENDS = [
    "python",
    pytest.param("compiled", marks=pytest.mark.skipif(
        not compiled_available(), reason="compiled cable callback not built for this MuJoCo")),
]


# -- a point mass on one cable -------------------------------------------------------------------

MASS, K, REST, TOP = 0.8, 120.0, 0.5, 2.0  # kg, N/m, m, m (anchor height)
STATIC = MASS * G / K  # static stretch [m]
AMPLITUDE = 0.03  # m; smaller than STATIC (0.065 m), so the cable stays taut throughout


def _hanging(damping: float, dt: float = 1e-3):
    start = TOP - (REST + STATIC + AMPLITUDE)  # released from rest, AMPLITUDE below equilibrium
    s = Structure(
        "pendulum",
        (Node("top", (0.0, 0.0, TOP), fixed=True), Node("bob", (0.0, 0.0, start))),
        cables=(Cable("c", ("top", "bob"), K, damping=damping, rest_length=REST),),
        point_masses=(PointMass("bob", MASS),),
    )
    return compile_structure(s, WorldOptions(timestep=dt, ground=False))


def _crossings(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Times where y changes sign, by linear interpolation between samples."""
    i = np.nonzero(np.sign(y[:-1]) != np.sign(y[1:]))[0]
    return t[i] - y[i] * (t[i + 1] - t[i]) / (y[i + 1] - y[i])


@pytest.mark.parametrize("backend", BACKENDS)
def test_undamped_mass_oscillates_at_spring_period(backend):
    compiled = _hanging(damping=0.0)
    period = 2 * np.pi * np.sqrt(MASS / K)  # 0.513 s
    ts = simulate(compiled, 4 * period, record_dt=1e-3, backend=backend).trajectory
    z = ts["pos_z/bob"]
    z_eq = TOP - REST - STATIC
    crossings = _crossings(ts.time, z - z_eq)
    assert crossings.size >= 7
    measured = 2 * np.diff(crossings)  # successive crossings are half a period apart
    # MuJoCo's Euler step is semi-implicit (symplectic): it shortens the period by
    # (w dt)^2 / 24 = 6e-6 relative, well inside 1e-4
    np.testing.assert_allclose(measured, period, rtol=1e-4)
    # ... and exactly so: the discrete oscillator q'' = -w^2 q stepped this way has
    # frequency (2/dt) asin(w dt / 2). Linear interpolation of the crossings on 1 ms samples
    # leaves ~4e-8 relative, hence 1e-6.
    dt = compiled.world.timestep
    w = np.sqrt(K / MASS)
    np.testing.assert_allclose(measured, 2 * np.pi / (2 / dt * np.arcsin(w * dt / 2)), rtol=1e-6)
    # the oscillation is centred on the static stretch m g / k below the rest length; the
    # sampled extremes miss the true ones by up to A (w * 1 ms)^2 / 8 = 6e-7 m, and the
    # symplectic step changes the amplitude by ~(w dt)^2 / 12 = 1e-5 relative
    assert 0.5 * (z.max() + z.min()) == pytest.approx(z_eq, abs=2e-6)
    assert z.max() - z.min() == pytest.approx(2 * AMPLITUDE, rel=1e-4)
    # the cable length channel tells the same story, and it never went slack
    length = ts["length/c"]
    np.testing.assert_allclose(length, TOP - z, atol=1e-12)  # same geometry; rounding only
    assert np.all(ts["tension/c"] > 0)
    # the load cell reads Hooke's law k (x - l) throughout (rounding of a product)
    np.testing.assert_allclose(ts["tension/c"], K * (length - REST), rtol=1e-12)


@pytest.mark.parametrize("backend", BACKENDS)
def test_damped_mass_settles_at_static_stretch(backend):
    damping = 6.0  # N s/m: damping ratio b / (2 sqrt(k m)) = 0.31, decay time 2m/b = 0.27 s
    ts = simulate(_hanging(damping), 5.0, backend=backend).trajectory
    # after 5 s = 19 decay times the transient is below 1e-8 of its 0.03 m start
    stretch = ts["length/c"][-1] - REST
    assert stretch == pytest.approx(STATIC, abs=1e-9)
    assert ts["tension/c"][-1] == pytest.approx(MASS * G, abs=2e-7)  # k x 1e-9 m = 1.2e-7 N
    assert ts["pos_z/bob"][-1] == pytest.approx(TOP - REST - STATIC, abs=1e-9)


# -- prism3 and six_bar: statics by the force-density method -----------------------------------


def _node_positions(compiled, ts, k: int) -> dict[str, np.ndarray]:
    """World positions of every node at sample k, from the recorded body poses."""
    out = {}
    for body in compiled.index.bodies:
        pos = np.array([ts[f"pos_{a}/{body}"][k] for a in "xyz"])
        quat = np.array([ts[f"quat_{a}/{body}"][k] for a in "wxyz"])
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, quat)
        group = next(g for g in compiled.structure.rigid_groups() if g.name == body)
        for node in group.nodes:
            out[node] = pos + rot.reshape(3, 3) @ compiled.index.node_local[node]
    return out


@pytest.mark.parametrize("build", [prism3, lambda: six_bar(standing=False)],
                         ids=["prism3", "six_bar"])
def test_self_stressed_preset_holds_in_zero_gravity(build):
    structure = build()
    members, q = self_stress(structure)
    n_rods = len(structure.rods)
    lengths = np.array([structure.distance(*m) for m in members])
    forces = q * lengths  # member forces of the unit self-stress, tension positive
    cable_forces = forces[n_rods:]
    # scale the self-stress to the preset's pretension level (least squares on the cables)
    pretension = np.array([c.pretension for c in structure.cables])
    scale = cable_forces @ pretension / (cable_forces @ cable_forces)
    predicted = scale * cable_forces
    assert np.all(predicted > 0) and np.all(scale * forces[:n_rods] < 0)  # cables pull, rods push
    # the preset's pretensions are that self-stress (rounding of its sqrt(3) and cos/sin)
    np.testing.assert_allclose(pretension, predicted, rtol=1e-9)

    compiled = compile_structure(structure, WorldOptions(gravity=(0.0, 0.0, 0.0), ground=False))
    ts = simulate(compiled, 2.0).trajectory
    start, end = _node_positions(compiled, ts, 0), _node_positions(compiled, ts, -1)
    moved = max(np.linalg.norm(end[n] - start[n]) for n in start)
    # an equilibrium up to rounding stays put (rounding drives ~1e-15 m); a wrong anchor,
    # force direction or rest length would move nodes by millimetres within 2 s
    assert moved < 1e-9
    tensions = ts.matrix("tension", compiled.index.cables)
    # the statics prediction holds over the run: the two ends of a cable moving by 1e-9 m
    # each change its tension by at most 2e-9 m x 1000 N/m (the stiffest cables) = 2e-6 N
    np.testing.assert_allclose(tensions, np.broadcast_to(predicted, tensions.shape),
                               rtol=0, atol=2e-6)


# -- motor limits on a held cable -----------------------------------------------------------------


def _held(stiffness: float = 100.0, pretension: float = 5.0, motor: Motor | None = None,
          dt: float = 1e-3):
    """One cable between two world-fixed nodes 0.5 m apart (rest 0.5 - T/k)."""
    s = Structure(
        "held",
        (Node("a", (0.0, 0.0, 1.0), fixed=True), Node("b", (0.5, 0.0, 1.0), fixed=True)),
        cables=(Cable("c", ("a", "b"), stiffness, pretension=pretension,
                      motor=motor or Motor()),),
    )
    return compile_structure(s, WorldOptions(timestep=dt, ground=False))


@pytest.mark.parametrize("backend", BACKENDS)
def test_motor_reels_in_at_max_speed_until_max_tension(backend):
    speed, t_max, k = 0.05, 20.0, 100.0
    compiled = _held(k, 5.0, Motor(max_speed=speed, max_tension=t_max))
    floor = 0.5 - t_max / k  # rest length where k (x - l) = max_tension: 0.3 m
    with Simulation(compiled, backend=backend) as sim:
        sim.drive.rest_command[0] = 0.05  # far below anything reachable
        ts = sim.run(4.0)  # 0.45 -> 0.30 m at 0.05 m/s takes 3 s
    rest, tension = ts["rest_length/c"], ts["tension/c"]
    moving = rest[1:] > floor + 1e-9
    assert moving.sum() >= 250
    # exactly max_speed: ten steps of 5e-5 m per sample; rounding of the running sum ~1e-16 m
    np.testing.assert_allclose(np.diff(rest)[moving], -speed * 0.01, rtol=0, atol=1e-12)
    # then it stops at the force limit, which it never exceeds (rounding of k (x - l) only)
    assert rest[-1] == pytest.approx(floor, abs=1e-12)
    assert tension.max() <= t_max + 1e-9
    assert tension[-1] == pytest.approx(t_max, abs=1e-9)


@pytest.mark.parametrize("backend", BACKENDS)
def test_motor_lets_out_at_max_speed_and_stops_on_target(backend):
    compiled = _held(motor=Motor(max_speed=0.1))
    with Simulation(compiled, backend=backend) as sim:
        sim.drive.rest_command[0] = 0.62
        ts = sim.run(2.0)  # 0.45 -> 0.62 m at 0.1 m/s takes 1.7 s
    rest = ts["rest_length/c"]
    moving = rest[1:] < 0.62 - 1e-9
    assert moving.sum() >= 160
    np.testing.assert_allclose(np.diff(rest)[moving], 0.1 * 0.01, rtol=0, atol=1e-12)  # rounding
    assert rest[-1] == pytest.approx(0.62, abs=1e-14)  # lands on the target (one rounding)
    # past 0.5 m the held cable is slack and reads exactly zero
    assert np.all(ts["tension/c"][rest > 0.5] == 0.0)


@pytest.mark.parametrize("backend", BACKENDS)
def test_motor_floors(backend):
    # the cable (0.5 m) is at or below min_length: no reeling in at all
    compiled = _held(motor=Motor(max_speed=0.1, min_length=0.5))
    with Simulation(compiled, backend=backend) as sim:
        sim.drive.rest_command[0] = 0.1
        ts = sim.run(0.5)
    assert np.all(ts["rest_length/c"] == 0.45)  # exact: the motor holds its rest length
    # a rest-length floor of 0.4 m stops the reel-in there (max_tension far away)
    compiled = _held(motor=Motor(max_speed=0.1, max_tension=1e3, min_rest_length=0.4))
    with Simulation(compiled, backend=backend) as sim:
        sim.drive.rest_command[0] = 0.1
        ts = sim.run(1.0)
    rest = ts["rest_length/c"]
    assert rest.min() == 0.4  # exact: the floor is applied by max(., 0.4)
    assert rest[-1] == 0.4
    assert ts["tension/c"][-1] == pytest.approx(100.0 * 0.1, abs=1e-9)  # k (0.5 - 0.4); rounding


# -- impedance control on a held cable ----------------------------------------------------------


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize(
    ("t0", "gain_k", "target_length"),
    [(10.0, 50.0, 0.45),  # T_set = 10 + 50 (0.5 - 0.45) = 12.5 N
     (3.0, 200.0, 0.47),  # T_set = 3 + 200 (0.5 - 0.47) = 9 N
     (1.0, 50.0, 0.60)],  # 1 + 50 (0.5 - 0.6) = -4 N: clamped, the cable goes slack
)
def test_impedance_steady_state_on_held_cable(backend, t0, gain_k, target_length):
    length = 0.5
    compiled = _held(motor=Motor(max_speed=0.07))
    gains = ImpedanceGains(t0, gain_k, 10.0, target_length)
    ts = simulate(compiled, 2.0, controller=ImpedanceController({"c": gains}),
                  backend=backend).trajectory
    expected = max(0.0, t0 + gain_k * (length - target_length))  # V = V* = 0 on a held cable
    # the motor needs at most (12.5 - 5) / 100 / 0.07 = 1.1 s; then it lands on the rest length
    # that realises the setpoint exactly, up to rounding of l - (T_set - T)/k
    assert ts["tension/c"][-1] == pytest.approx(expected, abs=1e-9)
    assert ts["setpoint/c"][-1] == pytest.approx(expected, abs=1e-12)  # rounding only
    assert ts["rest_length/c"][-1] == pytest.approx(length - expected / 100.0, abs=1e-12)


# -- instability -----------------------------------------------------------------------------------


def test_blow_up_raises_a_helpful_simulation_error():
    # k = 1e5 N/m on 10 g: w = 3162 rad/s, so w dt = 32 >> 2 at dt = 10 ms; Euler diverges
    s = Structure(
        "stiff",
        (Node("top", (0.0, 0.0, 1.0), fixed=True), Node("bob", (0.0, 0.0, 0.5))),
        cables=(Cable("spring", ("top", "bob"), 1e5, rest_length=0.45),),
        point_masses=(PointMass("bob", 0.01),),
    )
    compiled = compile_structure(s, WorldOptions(timestep=0.01, ground=False))
    with pytest.raises(SimulationError) as info:
        simulate(compiled, 2.0)
    message = str(info.value)
    assert "'spring'" in message or "'bob'" in message
    assert "smaller timestep" in message
    found = re.search(r"t = ([0-9.]+) s", message)
    assert found is not None
    assert 0.0 < float(found.group(1)) < 2.0  # it names when, within the run


def test_a_mujoco_reset_is_reported_with_the_body_and_the_tension_before_it():
    # bob hangs on a k = 100 N/m cable (5 N at build time) and is pulled down with 50 N, so the
    # cable holds >= 50 N; then gravity of 1e300 makes its acceleration non-finite and MuJoCo
    # resets the state (activations, peak tensions and clock included)
    s = Structure(
        "hanging",
        (Node("top", (0.0, 0.0, 1.0), fixed=True), Node("bob", (0.0, 0.0, 0.5))),
        cables=(Cable("spring", ("top", "bob"), 100.0, rest_length=0.45),),
        point_masses=(PointMass("bob", 0.01),),
    )
    compiled = compile_structure(s, WorldOptions(timestep=1e-3, ground=False))
    load = NodeLoad("bob", np.array([0.0, 0.2]), np.array([[0, 0, 0], [0, 0, -50.0]]))
    with Simulation(compiled, loads=[load]) as sim:
        sim.run(0.4)
        sim.model.opt.gravity[2] = -1e300
        with pytest.raises(SimulationError) as info:
            sim.run(0.2)
    message = str(info.value)
    assert "reset" in message and "body 'bob'" in message and "after t = 0.400 s" in message
    found = re.search(r"reached 'spring' at ([0-9.e+]+) N", message)
    assert found is not None and float(found.group(1)) >= 50.0  # not the reset state's


# -- external node loads --------------------------------------------------------------------------


def _euler_positions(accel: np.ndarray, dt: float) -> np.ndarray:
    """Positions after n semi-implicit Euler steps from rest: v += a dt, then x += v dt."""
    velocity = dt * np.cumsum(accel)
    return dt * np.cumsum(velocity)


@pytest.mark.parametrize("backend", BACKENDS)
def test_ramped_node_load_accelerates_a_free_mass(backend):
    mass, force, rise, dt = 0.4, 2.0, 0.1, 1e-3
    s = Structure("puck", (Node("p", (0.0, 0.0, 1.0)),), point_masses=(PointMass("p", mass),))
    compiled = compile_structure(s, WorldOptions(timestep=dt, gravity=(0.0, 0.0, 0.0),
                                                 ground=False))
    load = NodeLoad("p", [0.0, rise], [[0.0, 0.0, 0.0], [0.0, force, 0.0]])
    ts = simulate(compiled, 0.3, loads=[load], record_dt=dt, backend=backend).trajectory
    # Newton: a(t) = F(t) / m with F ramping linearly to 2 N over 0.1 s, then held
    n = ts.time.size
    accel = force / mass * np.minimum(np.arange(n) * dt / rise, 1.0)
    expected = np.concatenate([[0.0], _euler_positions(accel, dt)[:-1]])
    # sample k holds the state after k steps; rounding of ~300 sums of O(1) terms
    np.testing.assert_allclose(ts["pos_y/p"], expected, rtol=1e-9, atol=1e-12)
    # and the continuous answer, 0.5 a t^2 past the ramp shifted by its a rise^2 / 6 deficit,
    # within the Euler step's O(a t dt) offset
    t = ts.time[-1]
    a = force / mass
    continuous = a * rise**2 / 6 + a * rise / 2 * (t - rise) + 0.5 * a * (t - rise) ** 2
    assert ts["pos_y/p"][-1] == pytest.approx(continuous, abs=a * t * dt)
    np.testing.assert_allclose(ts["pos_x/p"], 0.0, atol=0)  # exact: no force along x


@pytest.mark.parametrize("backend", BACKENDS)
def test_node_load_off_centre_spins_a_dumbbell(backend):
    """A force at a rod's end node both pushes the centre of mass and turns the body."""
    length, end_mass, force, dt = 1.0, 0.5, 0.1, 1e-3
    s = Structure(
        "dumbbell",
        (Node("a", (-length / 2, 0.0, 1.0)), Node("b", (length / 2, 0.0, 1.0))),
        (Rod("bar", ("a", "b"), 0.01, linear_density=0.1, tags=("bar",)),),
        point_masses=(PointMass("a", end_mass, 0.02), PointMass("b", end_mass, 0.02)),
    )
    # (its tiny axial moment gets regularized; the spin here is about a transverse principal
    # axis, which that leaves alone)
    compiled = compile_structure(s, WorldOptions(timestep=dt, gravity=(0.0, 0.0, 0.0),
                                                 ground=False))
    load = NodeLoad("b", [0.0], [[0.0, 0.0, force]])  # constant, along +z, at x = +L/2
    ts = simulate(compiled, 0.2, loads=[load], record_dt=dt, backend=backend).trajectory
    rod = 0.1 * length
    total = rod + 2 * end_mass
    # moment of inertia about y through the centre: rod + two spheres + parallel axis
    inertia = (rod * (3 * 0.01**2 + length**2) / 12
               + 2 * (0.4 * end_mass * 0.02**2 + end_mass * (length / 2) ** 2))
    n = ts.time.size
    lift = np.concatenate([[0.0], _euler_positions(np.full(n, force / total), dt)[:-1]])
    # F / M on the centre of mass, whatever the rotation: rounding of ~200 sums
    np.testing.assert_allclose(ts["pos_z/bar"] - 1.0, lift, rtol=1e-9, atol=1e-14)
    # torque r x F = (L/2) F about -y; the angle follows the same Euler sums with alpha = tau/I
    spin = np.concatenate([[0.0], _euler_positions(np.full(n, force * length / 2 / inertia),
                                                   dt)[:-1]])
    qw, qy = ts["quat_w/bar"], ts["quat_y/bar"]
    angle = -2 * np.arctan2(qy, qw)
    # the world-fixed force turns with the body by at most 4e-3 rad here, so the torque
    # falls short by 1 - cos(angle) < 1e-5 relative
    np.testing.assert_allclose(angle, spin, rtol=1e-5, atol=1e-12)
    np.testing.assert_allclose(ts["quat_x/bar"], 0.0, atol=1e-15)  # no torque about x
    np.testing.assert_allclose(ts["quat_z/bar"], 0.0, atol=1e-15)  # nor about z


# -- inputs: the V* table ---------------------------------------------------------------------


class _TableController:
    """Impedance gains on every cable plus a V* table (the test's own, not a gait's)."""

    def __init__(self, gains: ImpedanceGains, table: np.ndarray, table_dt: float):
        self.gains, self.table, self.table_dt = gains, table, table_dt

    def configure(self, sim: Simulation) -> None:
        ImpedanceController({c: self.gains for c in sim.index.cables}).configure(sim)
        sim.drive.set_target_velocity(self.table, self.table_dt)


def test_a_vstar_step_takes_effect_exactly_at_its_row_time():
    # held cable at its pretension (5 N = T0): the motor rests until V* steps to 0.01 m/s at
    # row 37 (t = 0.37 s); then T_set = 5 - 10 * 0.01 < 5 and the motor lets out at 0.07 m/s
    compiled = _held(100.0, 5.0, Motor(max_speed=0.07))
    table = np.zeros((100, 1))
    table[37:] = 0.01
    controller = _TableController(ImpedanceGains(5.0, 0.0, 10.0, 0.5), table, 0.01)
    ts = simulate(compiled, 0.5, controller=controller, record_dt=1e-3).trajectory
    rest = ts["rest_length/c"]
    step = int(np.argmax(np.abs(np.diff(rest)) > 1e-9)) + 1  # first sample that moved
    assert ts.time[step] == pytest.approx(0.37, abs=1e-12)
    assert rest[step] - rest[step - 1] == pytest.approx(0.07e-3, rel=1e-9)  # max speed


@pytest.mark.parametrize("vstar", [0.02, -0.02])
def test_impedance_damping_tracks_the_target_velocity(vstar):
    # a hanging mass under T_set = m g + B (V - V*): the force balance holds only at V = V*, so
    # the cable must lengthen (the mass descend) at V* itself; a sign error in B (V - V*)
    # would move it the other way
    compiled = _hanging(damping=0.0)
    gains = ImpedanceGains(MASS * G, 0.0, 20.0, 0.5)
    ts = simulate(compiled, 3.0, controller=_TableController(gains, np.array([[vstar]]), 1.0),
                  record_dt=1e-3).trajectory
    late = ts.time > 2.0
    rate = np.polyfit(ts.time[late], ts["length/c"][late], 1)[0]
    assert rate == pytest.approx(vstar, rel=0.05)


def test_a_node_load_past_what_mujoco_accepts_is_refused():
    with pytest.raises(ValueError, match="past 1e"):
        NodeLoad("bob", np.array([0.0, 1.0]), np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 2e9]]))
