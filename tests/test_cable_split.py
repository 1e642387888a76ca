"""The implicit law split by cable (``WorldOptions.split_margin``, tensim.model._split).

A bob of mass m on cables from fixed anchors through its centre: each cable's tendon Jacobian
is its unit direction e on the bob's translation, so W = J M^-1 J^T has w = 1/m on its
diagonal and e_1 . e_2 / m off it. Under the explicit law's (semi-implicit Euler) step, one
cable of stiffness k and damping b grows through the eigenvalue -1 at h = 2 / r with
r^2 = k w + r b w: r = (b w + sqrt((b w)^2 + 4 k w)) / 2. Two cables at right angles do not
couple (W diagonal); two cables along one line act as one of k_1 + k_2, b_1 + b_2.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from tensim.model import WorldOptions, compile_structure
from tensim.model._law_layout import implicit
from tensim.model._split import explicit_cables, own_bounds
from tensim.models import preset
from tensim.sim import (
    SimulationError,
    TimeSeries,
    Trial,
    compiled_available,
    ramp_hold_release,
    run_batch,
    simulate,
)
from tensim.structure import Cable, Node, PointMass, Structure
from test_implicit_law import assert_compiled_matches_python

MASS = 1.0  # kg
STIFF, STIFF_B = 1e6, 2e3  # N/m, N s/m: w0 = 1000 rad/s on the bob, critically damped
SOFT, SOFT_B = 100.0, 1.0  # N/m, N s/m


def _own_bound(k: float, b: float, m: float = MASS) -> float:
    """The explicit step bound [s] of one cable on a bob of mass m (the closed form above)."""
    w = 1 / m
    return 2 / ((b * w + math.sqrt((b * w) ** 2 + 4 * k * w)) / 2)


def _bob(cables: tuple[tuple[str, tuple[float, float, float], float, float, float], ...]
         ) -> Structure:
    """The bob 2 m up on ``cables`` (name, its anchor's offset from the bob [m], k, b, the
    rest length's shortfall from the build length [m])."""
    bob = (0.0, 0.0, 2.0)
    anchors = tuple(Node(f"{name}_anchor", tuple(np.add(bob, offset)), fixed=True)
                    for name, offset, *_ in cables)
    return Structure(
        "bob", (*anchors, Node("bob", bob)),
        cables=tuple(Cable(name, (f"{name}_anchor", "bob"), k, damping=b,
                           rest_length=float(np.linalg.norm(offset)) - short)
                     for name, offset, k, b, short in cables),
        point_masses=(PointMass("bob", MASS),))


SHIFT = 5e-5  # m: where the stiff pair holds the bob, off the middle
# the bob held between two stiff cables along x, pulled 1 mm (10 kN) past their rest lengths
# and a little more on the right (it settles SHIFT to the right), and a soft cable along y;
# no gravity: the stiff cables stay taut, and the soft one at right angles (W diagonal)
HELD = _bob((("left", (-1.0, 0.0, 0.0), STIFF, STIFF_B, 1e-3),
             ("right", (1.0, 0.0, 0.0), STIFF, STIFF_B, 1e-3 + 2 * SHIFT),
             ("soft", (0.0, 1.0, 0.0), SOFT, SOFT_B, 1e-2)))
CROSS = _bob((("stiff", (0.0, 0.0, 1.0), STIFF, STIFF_B, 0.0),
              ("soft", (1.0, 0.0, 0.0), SOFT, SOFT_B, 0.0)))


def _handed(structure: Structure, dt: float, margin: float = 4.0) -> np.ndarray:
    compiled = compile_structure(structure, WorldOptions(timestep=dt, cable_law="implicit",
                                                         split_margin=margin, ground=False))
    return implicit(compiled.model)[:compiled.n_cables]


def test_each_cable_is_handed_over_where_its_own_bound_is_under_the_margin():
    stiff, soft = _own_bound(STIFF, STIFF_B), _own_bound(SOFT, SOFT_B)
    # w = 1/m = 1: r = (2000 + sqrt(2000^2 + 4e6)) / 2 and (1 + sqrt(1 + 400)) / 2
    assert stiff == pytest.approx(2 / (1000 + 1000 * math.sqrt(2)), rel=1e-12)
    assert soft == pytest.approx(4 / (1 + math.sqrt(401)), rel=1e-12)
    w = np.eye(2) / MASS
    np.testing.assert_allclose(
        own_bounds(w, np.array([STIFF, SOFT]), np.array([STIFF_B, SOFT_B])), [stiff, soft],
        rtol=1e-12)
    # margin 4: the stiff cable stays explicit below stiff / 4, the soft one below soft / 4
    for dt, handed in ((0.9 * stiff / 4, [False, False]), (1.1 * stiff / 4, [True, False]),
                       (0.9 * soft / 4, [True, False]), (min(1.1 * soft / 4, 0.05), [True, True])):
        np.testing.assert_array_equal(_handed(CROSS, dt), handed, err_msg=f"dt {dt}")


def test_cables_along_one_line_are_bounded_together():
    """Two equal soft cables pulling the bob up side by side: each alone is bounded at
    h_1 = 2 / r_1, both together at the bound of one cable of twice k and b; between the two,
    one stays explicit and the other is handed over."""
    pair = _bob((("a", (0.0, 0.0, 1.0), SOFT, SOFT_B, 0.01),
                 ("b", (0.0, 0.0, 1.5), SOFT, SOFT_B, 0.01)))
    alone, together = _own_bound(SOFT, SOFT_B), _own_bound(2 * SOFT, 2 * SOFT_B)
    assert together < alone / math.sqrt(2) * 1.01  # the pair really is bounded tighter
    for dt, count in ((0.99 * together / 4, 0), ((together + alone) / 8, 1),
                      (min(1.01 * alone / 4, 0.05), 2)):
        assert _handed(pair, dt).sum() == count, dt
    w = np.ones((2, 2)) / MASS
    keep = explicit_cables(w, np.array([SOFT, SOFT]), np.array([SOFT_B, SOFT_B]),
                           (together + alone) / 8, 4.0)
    assert keep.sum() == 1


@pytest.mark.parametrize("name", ["tetraspine3", "superball", "three_bar"])
def test_all_cables_together_have_the_bound_tensim_check_prints(name):
    """The bound of every cable together, in the cables' coordinates from MuJoCo's mass matrix
    and tendon Jacobians, against tensim check's from the structure's stiffness and mass
    matrices: within 0.5 % (check also counts the tension across the cables, left out here)."""
    from tensim.design import step_bound, stiffness
    from tensim.experiments.laws import three_bar
    from tensim.model._split import cable_terms, explicit_rate

    structure = three_bar() if name == "three_bar" else preset(name).build()
    compiled = compile_structure(structure, WorldOptions(cable_law="implicit"))
    terms = cable_terms(compiled.model, 0, compiled.index.actuator)
    together = 2 / explicit_rate(*terms)
    assert together == pytest.approx(step_bound(stiffness(structure, count=False)).limit,
                                     rel=5e-3)
    assert together < own_bounds(*terms).min()  # the cables meet at the bodies


def test_a_split_with_every_cable_on_one_side_is_that_law_bit_for_bit():
    """Tetraspine3 at 1 ms keeps all its cables explicit (its cables' explicit bound is 6.3
    ms): the run is the explicit law's, on its Euler step; with a margin no step meets, every
    cable is handed over and the run is the implicit law's."""
    p = preset("tetraspine3")
    structure = p.build()
    push = ramp_hold_release("s2_tip", (0.0, 1.0, 0.5), 8.0, 0.1, 0.1, 0.1, 0.1)

    def run(**world: object) -> TimeSeries:
        compiled = compile_structure(structure, WorldOptions(**world))  # type: ignore[arg-type]
        return simulate(compiled, 0.5, controller=p.controller(), loads=(push,)).trajectory

    none = compile_structure(structure, WorldOptions(cable_law="implicit", split_margin=4.0))
    assert not implicit(none.model).any()
    assert none.model.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
    for split, pure in ((run(cable_law="implicit", split_margin=4.0), run()),
                        (run(cable_law="implicit", split_margin=1e4),
                         run(cable_law="implicit"))):
        for name, values in pure.channels.items():
            np.testing.assert_array_equal(split[name], values, err_msg=name)


def test_a_stiff_cable_handed_over_beside_a_soft_explicit_one_stays_stable():
    """At 4 ms the stiff pair's explicit step blows up (each cable's bound 0.83 ms); split,
    they are handed over and the soft cable stays explicit: the run settles where the pair
    holds the bob, and follows a 0.2 ms explicit run about as closely as the all-implicit run
    does (measured: the soft cable's slow swing, 0.89 mm across, within 56 um against the
    all-implicit 45 um; the pair's axis within 21 um under both)."""
    dt = 4e-3
    np.testing.assert_array_equal(_handed(HELD, dt), [True, True, False])
    free = {"ground": False, "gravity": (0.0, 0.0, 0.0)}
    with pytest.raises(SimulationError, match="unstable"):
        simulate(compile_structure(HELD, WorldOptions(timestep=dt, **free)), 1.0, record_dt=dt)
    fine = simulate(compile_structure(HELD, WorldOptions(timestep=2e-4, **free)), 1.0,
                    record_dt=dt).trajectory
    split, pure = (simulate(compile_structure(HELD, WorldOptions(
        timestep=dt, **free, cable_law="implicit", split_margin=margin)), 1.0,
        record_dt=dt).trajectory for margin in (4.0, 0.0))
    x = split["pos_x/bob"]
    assert abs(x[-1] - SHIFT) < 1e-3 * SHIFT  # settled where the pair holds it
    assert np.abs(x).max() < 10 * SHIFT  # no swing past the pair's stretch: they stay taut
    for axis in "xy":
        errors = [np.abs(run[f"pos_{axis}/bob"] - fine[f"pos_{axis}/bob"]).max()
                  for run in (split, pure)]
        assert errors[0] <= 1.3 * errors[1] + 1e-9, axis
    assert errors[0] < 0.1 * np.ptp(fine["pos_y/bob"])


def _mixed():
    """Tetraspine3 at 2 ms, split at margin 4: 5 of its 12 cables handed over."""
    compiled = compile_structure(preset("tetraspine3").build(), WorldOptions(
        cable_law="implicit", split_margin=4.0, timestep=0.002))
    handed = implicit(compiled.model)[:compiled.n_cables]
    assert 0 < handed.sum() < compiled.n_cables
    return compiled


@pytest.mark.skipif(not compiled_available(), reason="compiled cable callback not built")
def test_compiled_law_matches_the_reference_on_a_split_robot():
    assert_compiled_matches_python(_mixed())


def test_each_batch_trial_of_a_split_robot_equals_its_single_run_bit_for_bit():
    p = preset("tetraspine3")
    compiled = _mixed()
    push = ramp_hold_release("s2_tip", (0.0, 1.0, 0.5), 8.0, 0.2, 0.3, 0.4, 0.3)
    cases = [Trial(p.controller()), Trial(p.controller(), loads=(push,))]
    for case, trial in zip(cases, run_batch(compiled, cases, 1.0, threads=2), strict=True):
        assert trial.ok, trial.error
        single = simulate(compiled, 1.0, controller=case.controller, loads=case.loads)
        for name, values in single.trajectory.channels.items():
            np.testing.assert_array_equal(values, trial.result.trajectory[name], err_msg=name)
        np.testing.assert_array_equal(single.peak_tension, trial.result.peak_tension)


def test_warp_runs_a_split_robot_as_the_cpu_engine():
    """As tests/test_warp.py's implicit-law case (0.07 N there), on the split robot in free
    space."""
    pytest.importorskip("mujoco_warp", reason="MuJoCo Warp is not installed")
    p = preset("tetraspine3")
    compiled = compile_structure(p.build(), WorldOptions(
        cable_law="implicit", split_margin=4.0, timestep=0.002, ground=False,
        gravity=(0.0, 0.0, 0.0)))
    assert 0 < implicit(compiled.model)[:compiled.n_cables].sum() < compiled.n_cables
    push = ramp_hold_release("s2_tip", (0.0, 1.0, 0.5), 8.0, 0.1, 0.1, 0.1, 0.1)
    trial = [Trial(p.controller(), loads=(push,))]
    (w,), (c,) = (run_batch(compiled, trial, 0.5, backend="warp", device="cpu"),
                  run_batch(compiled, trial, 0.5))
    assert w.ok and c.ok, (w.error, c.error)
    a, b = c.result.trajectory.matrix("tension"), w.result.trajectory.matrix("tension")
    assert np.abs(a - b).max() < 0.07
    assert np.abs(a).max() > 20.0  # the push loads the cables


@pytest.mark.parametrize("margin", [-1.0, 0.5, math.nan, math.inf, True])
def test_a_bad_split_margin_is_refused(margin):
    with pytest.raises(ValueError, match="split_margin"):
        WorldOptions(cable_law="implicit", split_margin=margin)


def test_the_split_is_chosen_on_the_command_line_and_kept_by_the_run_folder(tmp_path):
    import json

    from tensim.cli import main
    from tensim.viz.replay import load_run

    out = tmp_path / "run"
    assert main(["--quiet", "simulate", "tetraspine3", "--cable-law", "implicit",
                 "--split-margin", "4", "--dt", "0.002", "--duration", "0.1", "--record-dt",
                 "0.02", "--no-figures", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["cable_law"], summary["split_margin"]) == ("implicit", 4.0)
    compiled = load_run(out).compiled
    np.testing.assert_array_equal(implicit(compiled.model), implicit(_mixed().model))


def test_the_command_line_refuses_a_split_it_cannot_run(tmp_path, capsys):
    from tensim.cli import main

    run = ["--quiet", "simulate", "prism3", "--duration", "0.01", "--no-figures", "--out",
           str(tmp_path / "run")]
    with pytest.raises(SystemExit):
        main([*run, "--cable-law", "implicit", "--split-margin", "0.5"])
    assert "argument --split-margin: expected 0 or a number >= 1" in capsys.readouterr().err
    assert main([*run, "--split-margin", "4"]) != 0  # the explicit law has nothing to split
    assert "give it with --cable-law implicit" in capsys.readouterr().err
