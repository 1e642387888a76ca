"""CPG gait generator (paper eq. 4-6): dynamics, guards, spine coupling rule, parameter layout."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from tensim.control import (
    Bounds,
    Coupling,
    CPGController,
    CPGNetwork,
    GaitError,
    SolverSettings,
    _cpg_native,
    integrate,
    shared_body_pairs,
    solve,
    spine_network,
    spine_parameters,
)
from tensim.model import compile_structure
from tensim.models import tetraspine, tetraspine3
from tensim.models.tetraspine import impedance_controller
from tensim.sim import MODE_IMPEDANCE, Simulation


def upward_crossings(t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Times where v crosses zero going up, linearly interpolated between samples."""
    k = np.flatnonzero((v[:-1] < 0) & (v[1:] >= 0))
    return t[k] - v[k] * (t[k + 1] - t[k]) / (v[k + 1] - v[k])


def wrap(angle: float) -> float:
    """Angle wrapped to (-π, π]."""
    return float(np.angle(np.exp(1j * angle)))


def consistent_network(psi: tuple[float, ...], frequency: float, weight: float,
                       amplitude: float) -> CPGNetwork:
    """All-to-all network with φ_ij = ψ_j − ψ_i: antisymmetric and consistent around loops."""
    couplings = [Coupling(i, j, weight, psi[j] - psi[i])
                 for i, j in itertools.permutations(range(len(psi)), 2)]
    return CPGNetwork(tuple(f"o{i}" for i in range(len(psi))), frequency, amplitude, 20.0,
                      tuple(couplings))


# -- dynamics ------------------------------------------------------------------------------------


def test_amplitude_follows_the_critically_damped_closed_form():
    # with ν = 0 and no coupling θ stays at 0, so V = r cos 0 = r exactly; eq. 5 with
    # r(0) = dr/dt(0) = 0 is critically damped: r = R (1 − (1 + a t/2) e^{−a t/2})
    R, a = 0.03, 8.0
    net = CPGNetwork(("c",), 0.0, R, a)
    t, v = integrate(net, 3.0, 0.001)
    expected = R * (1 - (1 + a * t / 2) * np.exp(-a * t / 2))
    # rtol = atol = 1e-10 per step; the global error stays ~1e-11 m/s here, 1e-9 leaves margin
    # while a forward-Euler scheme at 1 ms would be off by ~1e-5 m/s
    np.testing.assert_allclose(v[:, 0], expected, rtol=0, atol=1e-9)


def test_amplitude_closed_form_holds_with_coupling_and_rotation():
    # eq. 5 does not involve θ, so coupled rotating oscillators follow the same r(t)
    R, a = 0.5, 12.0
    net = consistent_network((0.0, 1.0, -2.0), 0.8, 1.5, R)
    net = CPGNetwork(net.names, net.frequency, R, a, net.couplings)
    traj = solve(net, 2.0, 0.01, initial_phase=(0.3, 2.0, -1.0))
    t = traj.times[:, None]
    expected = R * (1 - (1 + a * t / 2) * np.exp(-a * t / 2))
    np.testing.assert_allclose(traj.amplitude, np.broadcast_to(expected, traj.amplitude.shape),
                               rtol=0, atol=1e-9)  # same solver accuracy as above


def test_three_oscillators_lock_to_the_prescribed_lags_at_the_common_frequency():
    # with equal ν and φ_ij = ψ_j − ψ_i every coupling term vanishes at θ_j − θ_i = φ_ij, so
    # the network locks there (a Kuramoto sync state in θ − ψ) and turns at exactly ν
    psi, nu, R = (0.0, 1.0, -2.0), 0.8, 0.5
    net = consistent_network(psi, nu, 1.5, R)
    t, v = integrate(net, 25.0, 0.001, initial_phase=(0.3, 2.0, -1.0))
    late = t >= 15.0  # coupling rate w R = 0.75 rad/s: locked to ~1e-5 rad within ~15 s
    ups = [upward_crossings(t[late], v[late, i]) for i in range(3)]
    for crossings in ups:
        frequency = (crossings.size - 1) / (crossings[-1] - crossings[0])
        # crossing times are interpolated from 1 ms samples of a sine near its inflection
        # (error ~1e-9 s); over ~8 periods that bounds the frequency error far below 1e-6 Hz
        assert frequency == pytest.approx(nu, abs=1e-6)
    for i, j in itertools.permutations(range(3), 2):
        # j leads i by φ_ij, so i crosses zero φ_ij / (2π ν) after j
        lag = wrap(2 * np.pi * nu * (ups[i][0] - ups[j][0]))
        # residual lock error e^{-λ 15 s} and crossing interpolation both < 1e-5 rad
        assert lag == pytest.approx(wrap(psi[j] - psi[i]), abs=1e-5)
    # amplitude of V = r cos θ after r has converged to R; 1 ms samples miss the peak by at
    # most R (1 − cos(π ν 1 ms)) ~ 3e-6 R
    assert np.abs(v[late]).max(axis=0) == pytest.approx([R] * 3, rel=1e-5)


def test_two_detuned_oscillators_lock_at_the_mean_frequency_with_arcsin_lag():
    # symmetric coupling w, φ = 0: ψ = θ2 − θ1 obeys dψ/dt = 2π Δν − 2 w R sin ψ, which locks at
    # sin ψ* = π Δν / (w R); the coupling terms cancel in the sum, so both turn at the mean ν
    nu1, nu2, w, R = 0.9, 1.1, 2.0, 1.0
    net = CPGNetwork(("a", "b"), (nu1, nu2), R, 20.0, ((0, 1, w, 0.0), (1, 0, w, 0.0)))
    t, v = integrate(net, 30.0, 0.001)
    late = t >= 20.0  # decay rate 2 w R cos ψ* ~ 3.8 1/s: locked to ~1e-30 by 20 s
    ups = [upward_crossings(t[late], v[late, i]) for i in range(2)]
    mean = (nu1 + nu2) / 2
    for crossings in ups:
        # same crossing-interpolation argument as above
        assert (crossings.size - 1) / (crossings[-1] - crossings[0]) == pytest.approx(
            mean, abs=1e-6)
    lag = wrap(2 * np.pi * mean * (ups[0][0] - ups[1][0]))  # b leads a by ψ*
    assert lag == pytest.approx(math.asin(math.pi * (nu2 - nu1) / (w * R)), abs=1e-5)


def test_samples_do_not_depend_on_the_sampling_period():
    net = consistent_network((0.0, 2.0, -1.0), 1.3, 3.0, 0.04)
    t1, v1 = integrate(net, 5.0, 0.001, initial_phase=(1.0, 0.0, 0.5))
    t10, v10 = integrate(net, 5.0, 0.01, initial_phase=(1.0, 0.0, 0.5))
    np.testing.assert_allclose(t1[::10], t10, rtol=0, atol=1e-12)
    # both read the dense output of the same adaptive step sequence, so only round-off can
    # differ; a fixed-step integrator at 10 ms vs 1 ms would differ by ~1e-3 of the amplitude
    np.testing.assert_allclose(v1[::10], v10, rtol=0, atol=1e-12)


# -- validation and guards ----------------------------------------------------------------------


@pytest.mark.parametrize("kwargs, message", [
    ({"convergence": 0.0}, "convergence"),
    ({"convergence": -3.0}, "convergence"),
    ({"frequency": float("nan")}, "finite"),
    ({"amplitude": float("inf")}, "finite"),
    ({"amplitude": -0.1}, "amplitude"),
    ({"frequency": (1.0, 1.0)}, "one value per oscillator"),
    ({"couplings": ((0, 3, 1.0, 0.0),)}, "outside"),
    ({"couplings": ((1, 1, 1.0, 0.0),)}, "itself"),
    ({"couplings": ((0, -1, 1.0, 0.0),)}, "index"),
    ({"couplings": ((0, 1, float("nan"), 0.0),)}, "finite"),
    ({"couplings": ((0, 1, 1.0, 0.0), (0, 1, 2.0, 0.5))}, "twice"),
    ({"names": ("a", "a", "c")}, "unique"),
])
def test_invalid_networks_are_refused(kwargs, message):
    args = {"names": ("a", "b", "c"), "frequency": 1.0, "amplitude": 0.1, "convergence": 20.0,
            "couplings": ()} | kwargs
    with pytest.raises(ValueError, match=message):
        CPGNetwork(**args)


@pytest.mark.parametrize("duration, sample_dt, phase", [
    (0.0, 0.01, None), (1.0, -0.01, None), (float("inf"), 0.01, None), (1.0, 0.01, (0.0,)),
])
def test_invalid_integration_arguments_are_refused(duration, sample_dt, phase):
    net = CPGNetwork(("a", "b"), 1.0, 0.1)
    with pytest.raises(ValueError):
        integrate(net, duration, sample_dt, initial_phase=phase)


def test_invalid_settings_and_bounds_are_refused():
    with pytest.raises(ValueError, match="method"):
        SolverSettings(method="Radau")
    with pytest.raises(ValueError, match="rtol"):
        SolverSettings(rtol=0.0)
    with pytest.raises(ValueError, match="low < high"):
        Bounds(1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="outside"):
        Bounds(0.0, 1.0, 2.0)


# the guards hold on both integrators: the compiled DOP853 and scipy's
BACKENDS = [pytest.param("compiled", marks=pytest.mark.skipif(
    not _cpg_native.available(), reason="compiled CPG integrator not built")), "scipy"]


@pytest.mark.parametrize("backend", BACKENDS)
def test_stiff_runaway_coupling_is_stopped_by_the_evaluation_guard(backend):
    # w R = 1e6 rad/s makes the phase equations stiff: an explicit method needs steps of
    # ~1e-6 s, i.e. millions of evaluations for 10 s, instead of hanging it must stop
    net = CPGNetwork(("a", "b"), 1.0, 1.0, 20.0, ((0, 1, 1e6, 0.5), (1, 0, 1e6, -0.5)))
    with pytest.raises(GaitError, match="evaluations"):
        integrate(net, 10.0, 0.01, settings=SolverSettings(backend=backend,
                                                           max_evaluations=20_000))


@pytest.mark.parametrize("backend", BACKENDS)
def test_amplitude_bound_and_wall_time_guards(backend):
    net = CPGNetwork(("a",), 1.0, 0.05, 20.0)
    with pytest.raises(GaitError, match="amplitude"):
        integrate(net, 2.0, 0.01, settings=SolverSettings(backend=backend, max_amplitude=0.02))
    # the wall clock is read on the first evaluation; any real work takes more than 1 ns
    with pytest.raises(GaitError, match="wall time"):
        integrate(net, 2.0, 0.01, settings=SolverSettings(backend=backend, max_wall_s=1e-9))


# -- spines --------------------------------------------------------------------------------------


def _segments(structure, cable_name: str) -> set[int]:
    """Segments a cable attaches to, read from its node names ``s<k>_...``."""
    return {int(node.split("_")[0][1:]) for node in structure.cable(cable_name).nodes}


def test_spine_coupling_links_only_cables_that_share_a_segment():
    spine = tetraspine(4)  # joints 1..3; joint j joins segments j-1 and j
    names = [c.name for c in spine.cables]
    expected = {(i, j) for i, j in itertools.permutations(range(len(names)), 2)
                if _segments(spine, names[i]) & _segments(spine, names[j])}
    pairs = shared_body_pairs(spine)
    assert set(pairs) == expected and len(pairs) == len(set(pairs))
    # 6 cables per joint: 3 joints x 6 x 5 within a joint + 2 adjacent joint pairs x 2 x 36
    assert len(pairs) == 3 * 30 + 2 * 2 * 36
    assert not any({names[i][-1], names[j][-1]} == {"1", "3"} for i, j in pairs)
    net = spine_network(spine, None, 0.5, 0.02, lambda a, b: len(a) + len(b),
                        lambda a, b: 0.1)
    assert {(c.i, c.j) for c in net.couplings} == expected
    assert all(c.weight == len(names[c.i]) + len(names[c.j]) for c in net.couplings)


def test_three_segment_spine_is_all_to_all():
    assert len(shared_body_pairs(tetraspine3())) == 12 * 11  # every pair shares segment 1


def _class_key(name_i: str, name_j: str) -> tuple[int, frozenset[str]]:
    """The documented symmetry rule, from cable names ``<kind>_<joint>``."""
    kind_i, joint_i = name_i.rsplit("_", 1)
    kind_j, joint_j = name_j.rsplit("_", 1)
    return int(joint_i) - int(joint_j), frozenset((kind_i, kind_j))


def test_tetraspine3_has_57_coupling_classes_and_116_parameters():
    params = spine_parameters(tetraspine3())
    # 6 kinds per joint: C(6, 2) = 15 pairs at offset 0, 6·7/2 = 21 at each of offsets ±1
    assert len(params.classes) == 15 + 21 + 21 == 57
    assert params.size == len(params.names) == len(set(params.names)) == 116
    assert sum(n.startswith("weight/") for n in params.names) == 57
    assert sum(n.startswith("phase/") for n in params.names) == 57
    assert params.names[-2:] == ("amplitude", "frequency")
    assert len(params.edges) == 132
    # the implementation's partition of the 132 couplings equals the documented rule's
    names = params.oscillators
    by_rule: dict[tuple, set[tuple[int, int]]] = {}
    by_impl: dict[int, set[tuple[int, int]]] = {}
    for i, j, c, _ in params.edges:
        by_rule.setdefault(_class_key(names[i], names[j]), set()).add((i, j))
        by_impl.setdefault(c, set()).add((i, j))
    assert sorted(map(sorted, by_rule.values())) == sorted(map(sorted, by_impl.values()))


@pytest.mark.parametrize("segments", [4, 12])
def test_longer_spines_keep_116_parameters(segments):
    assert spine_parameters(tetraspine(segments)).size == 116


def test_shared_couplings_take_one_weight_and_consistent_phases():
    params = spine_parameters(tetraspine3())
    rng = np.random.default_rng(3)
    net = params.network(params.from_unit(rng.uniform(size=params.size)))
    index = {n: k for k, n in enumerate(net.names)}
    coupling = {(c.i, c.j): c for c in net.couplings}

    def get(a: str, b: str) -> Coupling:
        return coupling[index[a], index[b]]

    # same joint: a pair and its reverse share the weight, with opposite phase
    ab, ba = get("outer_top_1", "inner_left_1"), get("inner_left_1", "outer_top_1")
    assert ab.weight == ba.weight and ab.phase == -ba.phase != 0
    assert get("outer_top_2", "inner_left_2").weight == ab.weight  # same class, other joint
    # across joints: the kind pair is unordered, the joint offset is not
    rear = get("outer_top_2", "inner_left_1")
    assert get("inner_left_2", "outer_top_1").phase == rear.phase
    assert get("outer_top_1", "inner_left_2").weight != rear.weight


def test_unit_mapping_round_trip_and_bounds():
    params = spine_parameters(tetraspine3())
    u = np.random.default_rng(0).uniform(size=params.size)
    values = params.from_unit(u)
    assert np.all((values >= params.low) & (values <= params.high))
    np.testing.assert_allclose(params.to_unit(values), u, rtol=0, atol=1e-12)  # round-off
    np.testing.assert_array_equal(params.to_unit(params.low), 0.0)
    np.testing.assert_array_equal(params.to_unit(params.high), 1.0)
    assert np.all((params.nominal >= params.low) & (params.nominal <= params.high))
    with pytest.raises(ValueError, match="outside"):
        params.network(params.high + 1.0)
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        params.from_unit(np.full(params.size, 1.5))
    with pytest.raises(ValueError, match="shape"):
        params.to_unit(values[:-1])
    net = params.network(values)
    assert net.amplitude == (values[-2],) * 12 and net.frequency == (values[-1],) * 12
    assert params.as_dict(values)["frequency"] == values[-1]


# -- the controller -----------------------------------------------------------------------------


def test_controller_writes_the_integrated_table_by_cable_name():
    structure = tetraspine3()
    compiled = compile_structure(structure)
    # drive a subset, in an order unlike the structure's, to check the column mapping
    cables = ("inner_top_2", "outer_left_1", "outer_right_2")
    net = spine_network(structure, cables, 0.7, 0.01, 30.0, 0.5)
    controller = CPGController(net, impedance_controller(3), duration=0.5, sample_steps=2)
    with Simulation(compiled, controller=controller) as sim:
        drive = sim.drive
        assert drive.table_dt == pytest.approx(2 * sim.dt)
        t, v = integrate(net, 0.5, 2 * sim.dt)
        assert drive.target_velocity.shape == (t.size, compiled.n_cables)
        for k, name in enumerate(cables):
            np.testing.assert_array_equal(drive.target_velocity[:, sim.index.cable_id(name)],
                                          v[:, k])
        others = [sim.index.cable_id(n) for n in sim.index.cables if n not in cables]
        assert not drive.target_velocity[:, others].any()
        assert (drive.mode == MODE_IMPEDANCE).all()  # the impedance gains were configured
        sim.run(0.3)  # and the robot runs with it


def test_controller_refuses_cables_without_impedance_gains():
    net = CPGNetwork(("outer_top_1", "not_a_cable"), 1.0, 0.01)
    with pytest.raises(ValueError, match="impedance gains"):
        CPGController(net, impedance_controller(3), duration=1.0)
