"""The pure reference laws (paper eq. 1-3 and the motor model) on random inputs.

Every expectation is written out here, element by element, straight from the definitions in
the paper and the motor's documented limits, and compared with the vectorised laws.
"""

from __future__ import annotations

import numpy as np
import pytest

from tensim.sim import cable_tension, impedance_rest_target, impedance_setpoint, motor_step

N = 2000
EPS = np.finfo(float).eps


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20150928)


# -- cable law (paper eq. 1-2) -----------------------------------------------------------------


def _cable_inputs(rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    rest = rng.uniform(0.05, 1.0, N)
    length = rest + rng.uniform(-0.2, 0.2, N)  # about half slack, half taut
    velocity = rng.uniform(-2.0, 2.0, N)
    stiffness = rng.uniform(10.0, 2000.0, N)
    damping = rng.uniform(0.0, 200.0, N)  # large enough that damping often pulls below zero
    return length, velocity, rest, stiffness, damping


def test_cable_tension_matches_hooke_with_damping_when_taut(rng):
    length, velocity, rest, k, b = _cable_inputs(rng)
    spring, applied = cable_tension(length, velocity, rest, k, b)
    for i in range(N):
        stretch = length[i] - rest[i]
        if stretch > 0:
            expected_spring = k[i] * stretch
            expected_applied = max(0.0, expected_spring + b[i] * velocity[i])
        else:
            expected_spring = expected_applied = 0.0
        # same arithmetic, so equal to rounding: a few ulp of the largest term involved
        scale = k[i] * abs(stretch) + b[i] * abs(velocity[i])
        assert spring[i] == pytest.approx(expected_spring, abs=8 * EPS * scale)
        assert applied[i] == pytest.approx(expected_applied, abs=8 * EPS * scale)


def test_cable_tension_is_zero_when_slack(rng):
    length, velocity, rest, k, b = _cable_inputs(rng)
    slack = length <= rest
    assert slack.any() and (~slack).any()  # the draw covers both cases
    spring, applied = cable_tension(length, velocity, rest, k, b)
    # exact: a slack cable carries nothing, whatever its velocity
    assert np.all(spring[slack] == 0.0)
    assert np.all(applied[slack] == 0.0)
    # a cable exactly at its rest length is slack too
    s, a = cable_tension(rest, velocity, rest, k, b)
    assert np.all(s == 0.0) and np.all(a == 0.0)


def test_cable_tension_clamps_negative_damped_force_to_zero(rng):
    length, velocity, rest, k, b = _cable_inputs(rng)
    spring, applied = cable_tension(length, velocity, rest, k, b)
    pulls_negative = (length > rest) & (k * (length - rest) + b * velocity < 0)
    assert pulls_negative.any()  # the draw exercises the clamp
    # exact: a cable can only pull; the clamp returns 0.0 itself
    assert np.all(applied[pulls_negative] == 0.0)
    assert np.all(applied >= 0.0)
    # the load-cell reading ignores damping: k max(0, x - l) even while the clamp acts
    expected = k * np.maximum(0.0, length - rest)
    # one multiplication on the same operands: equal to one rounding
    np.testing.assert_allclose(spring, expected, rtol=2 * EPS, atol=0)


# -- impedance law (paper eq. 3) ---------------------------------------------------------------


def test_impedance_setpoint_is_clamped_linear_law(rng):
    length = rng.uniform(0.1, 0.3, N)
    velocity = rng.uniform(-0.5, 0.5, N)
    t0 = rng.uniform(0.0, 30.0, N)
    gain_k = rng.uniform(0.0, 600.0, N)
    gain_b = rng.uniform(0.0, 200.0, N)
    target_length = rng.uniform(0.1, 0.3, N)
    target_velocity = rng.uniform(-0.5, 0.5, N)
    got = impedance_setpoint(length, velocity, t0, gain_k, gain_b, target_length,
                             target_velocity)
    negative = 0
    for i in range(N):
        linear = (t0[i] + gain_k[i] * (length[i] - target_length[i])
                  + gain_b[i] * (velocity[i] - target_velocity[i]))
        negative += linear < 0
        # same three terms summed: equal to a few ulp of the largest term
        scale = t0[i] + gain_k[i] * 0.4 + gain_b[i] * 2.0
        assert got[i] == pytest.approx(max(0.0, linear), abs=8 * EPS * scale)
    assert negative > 0  # the draw exercises the clamp
    assert np.all(got >= 0.0)


def test_impedance_rest_target_turns_static_tension_into_setpoint(rng):
    """Moving the rest length to the target makes a held cable's k (x - l) equal the setpoint."""
    rest = rng.uniform(0.1, 0.3, N)
    length = rest + rng.uniform(0.0, 0.05, N)  # taut
    k = rng.uniform(50.0, 1000.0, N)
    measured = k * (length - rest)
    setpoint = rng.uniform(0.0, 40.0, N)
    new_rest = impedance_rest_target(rest, setpoint, measured, k)
    # k (x - l_new) = k (x - l) + (T_set - T) = T_set; rounding of a few terms of size <= 60 N
    np.testing.assert_allclose(k * (length - new_rest), setpoint, rtol=0, atol=1e-11)


# -- motor -------------------------------------------------------------------------------------


def _motor_inputs(rng: np.random.Generator) -> dict[str, np.ndarray]:
    k = rng.uniform(50.0, 1000.0, N)
    min_rest = rng.uniform(0.0, 0.05, N)
    rest = min_rest + rng.uniform(0.0, 0.5, N)  # at or above its floor
    return {
        "rest_length": rest,
        "target": rest + rng.uniform(-0.01, 0.01, N) * rng.choice([1.0, 0.01], N),
        "length": rest + rng.uniform(-0.05, 0.1, N),
        "stiffness": k,
        "max_speed": rng.uniform(0.01, 0.2, N),
        "max_tension": rng.uniform(1.0, 60.0, N),
        "min_rest_length": min_rest,
        "min_length": rng.uniform(0.0, 0.3, N),
    }


def _motor_spec(rest, target, x, k, vmax, tmax, min_rest, min_length, dt) -> float:
    """The motor of the documentation, one cable, written independently as branches."""
    reach = vmax * dt
    if target >= rest:  # letting out (or holding): only the speed limit applies
        new = min(target, rest + reach)
    elif x <= min_length:  # too short to reel in
        new = rest
    else:  # reeling in: speed limit, and stop where the static tension reaches max_tension
        new = max(target, rest - reach, min(rest, x - tmax / k))
    return max(new, min_rest)


@pytest.mark.parametrize("dt", [1e-3, 1e-2, 0.5])
def test_motor_step_matches_documented_motor(rng, dt):
    p = _motor_inputs(rng)
    got = motor_step(**p, dt=dt)
    for i in range(N):
        want = _motor_spec(*(p[key][i] for key in p), dt)
        # rest + (target - rest) and rest + reach round once more than the spec's branches
        assert got[i] == pytest.approx(want, abs=4 * EPS * max(1.0, abs(want)))


@pytest.mark.parametrize("dt", [1e-3, 1e-2])
def test_motor_step_limits(rng, dt):
    p = _motor_inputs(rng)
    rest, target, x = p["rest_length"], p["target"], p["length"]
    new = motor_step(**p, dt=dt)
    tol = 4 * EPS  # a couple of roundings on quantities of order 1 m
    reach = p["max_speed"] * dt
    # speed limit (rest starts at or above its floor, so the floor never adds a jump)
    assert np.all(np.abs(new - rest) <= reach + tol)
    # never below the rest-length floor (exact: the floor is the last operation)
    assert np.all(new >= p["min_rest_length"])
    reel = target < rest
    force_floor = x - p["max_tension"] / p["stiffness"]
    # reeling in stops at the rest length where k (x - l) = max_tension ...
    assert np.all(new[reel] >= np.minimum(rest, force_floor)[reel] - tol)
    # ... but this rule never lets the cable out
    assert np.all(new[reel] <= rest[reel] + tol)
    # no reeling in at all once the cable is at or below min_length (exact: rest is kept)
    blocked = reel & (x <= p["min_length"])
    assert blocked.any()
    assert np.all(new[blocked] == np.maximum(rest, p["min_rest_length"])[blocked])


def test_motor_step_reaches_target_within_reach(rng):
    p = _motor_inputs(rng)
    dt = 1e-2
    rest, target, x = p["rest_length"], p["target"], p["length"]
    within = np.abs(target - rest) <= p["max_speed"] * dt
    free = (
        within
        & (target >= p["min_rest_length"])
        & ((target >= rest) | ((x > p["min_length"])
                               & (target >= x - p["max_tension"] / p["stiffness"])))
    )
    assert free.sum() > 100  # the draw has enough unconstrained moves
    new = motor_step(**p, dt=dt)
    # rest + (target - rest) lands on target up to one rounding
    np.testing.assert_allclose(new[free], target[free], rtol=2 * EPS, atol=0)


def test_motor_step_force_floor_is_exact_static_limit():
    """Reel in hard from a taut cable: the new rest gives exactly max_tension statically."""
    k, x, tmax = np.array([200.0]), np.array([0.5]), np.array([20.0])
    new = motor_step(np.array([0.45]), np.array([0.0]), x, k, np.array([10.0]), tmax,
                     np.array([0.0]), np.array([0.0]), 1.0)
    # k (x - l) = max_tension: l = 0.5 - 0.1 = 0.4; rounding of two operations
    assert new[0] == pytest.approx(0.4, abs=4 * EPS)
    assert k[0] * (x[0] - new[0]) == pytest.approx(tmax[0], rel=1e-12)  # rounding only
    # already beyond the limit (tension 30 N > 20 N): reeling in holds, it does not let out
    held = motor_step(np.array([0.35]), np.array([0.0]), x, k, np.array([10.0]), tmax,
                      np.array([0.0]), np.array([0.0]), 1.0)
    assert held[0] == 0.35  # exact: the rest length is kept as is


def test_a_compiled_part_that_cannot_be_loaded_falls_back_with_a_warning(tmp_path, monkeypatch,
                                                                          caplog):
    import importlib.machinery
    import importlib.util
    import logging

    from tensim._native import load_library

    damaged = tmp_path / "_cable.so"
    damaged.write_bytes(b"not a shared library")
    spec = importlib.machinery.ModuleSpec("tensim.sim._cable", None, origin=str(damaged))
    monkeypatch.setattr(importlib.util, "find_spec", lambda name: spec)
    with caplog.at_level(logging.WARNING, logger="tensim._native"):
        assert load_library("tensim.sim._cable", "compiled cable law",
                            "using the slower Python law") is None
    assert "compiled cable law" in caplog.text and str(damaged) in caplog.text
    assert "using the slower Python law" in caplog.text
    monkeypatch.setattr(importlib.util, "find_spec", lambda name: None)  # not built: quiet
    assert load_library("tensim.sim._cable", "x", "y") is None


READERS = ("rl/_worlds.py", "rl/_render.py", "inspect.py", "control/impedance.py",
           "experiments/drag.py")  # the five that each typed the tension law again


@pytest.mark.parametrize("reader", READERS)
def test_every_tension_reader_calls_the_one_law(reader):
    """Each of these reads a cable's tension through tensim.sim's law functions and does not
    type the law again (a stiffness times a clipped stretch): a copy kept the nominal
    stiffness when a randomisation changed the model's."""
    import re
    from pathlib import Path

    import tensim

    source = (Path(tensim.__file__).parent / reader).read_text()
    assert re.search(r"\b(load_cell_reading|load_cell_tension|cable_tension)\(", source), reader
    retyped = re.compile(r"stiffness\w*\s*\*\s*(np\.)?(maximum|clip)\(|"
                         r"(np\.)?(maximum|clip)\([^()]*(length|stretch)[^()]*\)\s*\*\s*\w*stiff|"
                         r"max(imum)?\(0(\.0)?,\s*[\w.\[\]]*stiffness\w*\s*\*|"
                         r"np\.where\([^,]*>[^,]*,\s*[\w.\[\]]*stiffness\w*\s*\*")
    assert not retyped.search(source), (reader, retyped.search(source))
