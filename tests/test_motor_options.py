"""The motor options labs use, against closed forms: a first-order lag (``Motor.lag_time``) on
a held cable, a saturating force cap (``Motor.saturate``) on a hanging mass."""

from __future__ import annotations

import numpy as np
import pytest

from tensim.model import WorldOptions, compile_structure
from tensim.model import _law_layout as layout
from tensim.sim import Simulation, compiled_available
from tensim.structure import Cable, Motor, Node, Structure, StructureError

BACKENDS = [
    "python",
    pytest.param("compiled", marks=pytest.mark.skipif(
        not compiled_available(), reason="compiled cable callback not built for this MuJoCo")),
]
LAG, DT = 0.25, 1e-3  # s


def _held(motor: Motor, law: str = "explicit"):
    """One cable between two world-fixed nodes 0.5 m apart, rest length 0.45 m."""
    s = Structure("held", (Node("a", (0.0, 0.0, 1.0), fixed=True),
                           Node("b", (0.5, 0.0, 1.0), fixed=True)),
                  cables=(Cable("c", ("a", "b"), 100.0, rest_length=0.45, motor=motor),))
    return compile_structure(s, WorldOptions(timestep=DT, ground=False, cable_law=law))


@pytest.mark.parametrize("law", ["explicit", "implicit"])
@pytest.mark.parametrize("backend", BACKENDS)
def test_a_lagged_motor_approaches_its_command_exponentially(backend, law):
    """Let out toward 0.55 m, fast enough that the speed limit never binds: the rest length
    is l(t) = l* + (l0 - l*) exp(-t / lag_time) at every step, exactly so for the discrete
    update (the share 1 - exp(-dt / lag_time) a step)."""
    compiled = _held(Motor(max_speed=10.0, lag_time=LAG), law)
    assert compiled.model.actuator_biasprm[0, layout.B_LAG_TIME] == LAG
    with Simulation(compiled, backend=backend) as sim:
        sim.drive.rest_command[0] = 0.55
        ts = sim.run(1.0)
    # the sample at t = j dt shows j updates toward the new command (the simulation's update
    # at t = 0 ran, at its start, toward the build rest length)
    steps = np.rint(ts.time / DT)
    expected = 0.55 + (0.45 - 0.55) * np.exp(-steps * DT / LAG)
    # rounding of a running sum of 1000 updates of ~1e-4 m
    np.testing.assert_allclose(ts["rest_length/c"], expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_speed_limit_still_caps_a_lagged_motor(backend):
    """The first step would move 0.1 (1 - exp(-0.004)) = 4e-4 m; at 0.05 m/s it moves 5e-5 m,
    and the lag takes over only once the remaining way is short."""
    compiled = _held(Motor(max_speed=0.05, lag_time=LAG))
    with Simulation(compiled, backend=backend) as sim:
        sim.drive.rest_command[0] = 0.55
        sim.step(1)
        assert sim.drive.rest[0] == pytest.approx(0.45 + 0.05 * DT, abs=1e-15)


def test_no_lag_is_the_motor_as_before_and_a_negative_lag_is_refused():
    a, b = (Simulation(_held(Motor(max_speed=1e3, lag_time=t))) for t in (0.0, 1e-9))
    with a, b:
        a.drive.rest_command[0] = b.drive.rest_command[0] = 0.55
        a.step(1)
        b.step(1)
        assert a.drive.rest[0] == 0.55 and b.drive.rest[0] == pytest.approx(0.55, abs=1e-15)
    with pytest.raises(StructureError, match="lag_time"):
        Motor(lag_time=-0.1)


def test_lag_and_saturation_survive_the_structure_file_and_are_not_written_when_off(tmp_path):
    from tensim.structure import load_structure, save_structure

    for lag, written in ((0.2, True), (0.0, False)):
        s = _held(Motor(lag_time=lag, saturate=written)).structure
        save_structure(s, tmp_path / "s.yaml")
        text = (tmp_path / "s.yaml").read_text()
        assert ("lag_time" in text) is written and ("saturate" in text) is written
        assert load_structure(tmp_path / "s.yaml") == s


# -- a saturating force cap (Motor.saturate) ---------------------------------------------------

G, MASS, CAP = 9.81, 2.0, 12.0  # m/s^2, kg, N: the bob weighs 19.6 N, more than the cap


def _hanging(law: str, saturate: bool):
    from tensim.structure import PointMass

    s = Structure("bob", (Node("top", (0.0, 0.0, 2.0), fixed=True),
                          Node("bob", (0.0, 0.0, 1.5))),
                  cables=(Cable("c", ("top", "bob"), 1000.0, rest_length=0.48,
                                motor=Motor(max_tension=CAP, saturate=saturate)),),
                  point_masses=(PointMass("bob", MASS),))
    return compile_structure(s, WorldOptions(timestep=DT, ground=False, cable_law=law))


@pytest.mark.parametrize("law", ["explicit", "implicitfast"])
@pytest.mark.parametrize("backend", BACKENDS)
def test_a_saturating_motor_holds_max_tension_and_lets_the_load_descend(backend, law):
    """A 2 kg bob on an undamped cable whose motor saturates at 12 N: each step the motor pays
    out to where the static tension is 12 N, so the bob falls at g - 12 N / m exactly; the
    discrete (semi-implicit Euler) fall is z_n = z_0 - a dt^2 n (n + 1) / 2."""
    z0 = 1.5  # built at rest, 2 cm over its rest length: 20 N, over the cap
    with Simulation(_hanging(law, True), backend=backend, record_dt=DT) as sim:
        for _ in range(200):
            sim.step(1)
            # the load cell, from the step's length and rest length, reads the cap
            assert sim.drive.tension[0] == pytest.approx(CAP, abs=1e-9)
        n, a = round(sim.data.time / DT), G - CAP / MASS  # steps taken from the build pose
        # rounding of ~200 steps' positions near 1.5 m
        assert sim.data.qpos[2] == pytest.approx(z0 - a * DT * DT * n * (n + 1) / 2, abs=1e-12)
        assert z0 - sim.data.qpos[2] > 0.07  # it did descend
    # without saturation the motor only stops reeling in: the bob hangs at 19.6 N
    with Simulation(_hanging(law, False), backend=backend, record_dt=DT) as sim:
        sim.run(1.0)
        assert sim.drive.tension[0] > CAP
