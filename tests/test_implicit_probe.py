"""The implicit law's probe (tensim.experiments.implicit_probe): its explicit mode is tensim's
explicit law, and its coupled solve is MuJoCo's discrete step for a cable it would hand over."""

import mujoco
import numpy as np

from tensim.control.rest import RestCommand
from tensim.experiments.implicit_probe import Probe, cable_tensions, own_solve, velocity_jumps
from tensim.experiments.laws import three_bar
from tensim.model import WorldOptions, compile_structure
from tensim.sim import COM, simulate

HANG = """<mujoco><option timestep="0.01" integrator="{integrator}" tolerance="1e-15"/>
<worldbody><site name="top" pos="0 0 1"/>
<body pos="0.1 0 0.2"><joint type="slide" axis="1 0 0"/><joint type="slide" axis="0 1 0"/>
<joint type="slide" axis="0 0 1"/><geom size="0.05" mass="2" contype="0" conaffinity="0"/>
<site name="end"/></body></worldbody>
<tendon><spatial name="cable" {spring}><site site="top"/><site site="end"/></spatial></tendon>
<actuator><motor tendon="cable"/></actuator></mujoco>"""


def test_explicit_probe_is_the_explicit_law() -> None:
    structure = three_bar()
    wound = ("bottom_0", "vertical_1")
    command = RestCommand(wound, tuple(0.75 * structure.rest_length(structure.cable(n))
                                       for n in wound))
    law = simulate(compile_structure(structure, WorldOptions(timestep=5e-4)), 0.2,
                   controller=command, record_dt=0.02)
    probe = own_solve(Probe(structure, 0.2, wound=tuple((n, 0.75) for n in wound)), 5e-4)
    assert probe is not None
    ts = law.trajectory
    com = np.stack([ts[f"pos_{a}/{COM}"] for a in "xyz"], axis=1)
    assert len(probe["time"]) == 10 and np.ptp(com[:, 2]) > 1e-3  # it moves
    np.testing.assert_allclose(probe["time"], ts.time[:10], atol=1e-12)
    np.testing.assert_allclose(probe["com"], com[:10], rtol=0, atol=1e-12)


def test_coupled_solve_is_the_discrete_step() -> None:
    """A stiff damped cable holding a mass at 10 ms: the law's own backward-Euler solve
    (theta = 1) applied to an Euler step moves the mass as MuJoCo's discrete step does with
    the cable as a tendon spring in its metric (no contact, no Coriolis: nothing is lagged)."""
    k, b, rest = 1e4, 100.0, 0.8
    spring = f'stiffness="{k}" damping="{b}" springlength="{rest} {rest}"'
    discrete = mujoco.MjModel.from_xml_string(HANG.format(integrator="discrete", spring=spring))
    euler = mujoco.MjModel.from_xml_string(HANG.format(integrator="Euler", spring=""))
    dd, de = mujoco.MjData(discrete), mujoco.MjData(euler)
    mujoco.mj_forward(euler, de)
    last = (de.qacc.copy(), np.zeros(1))
    tendons = np.array([0])
    for _ in range(50):
        mujoco.mj_step(discrete, dd)
        mujoco.mj_fwdPosition(euler, de)
        mujoco.mj_fwdVelocity(euler, de)
        assert de.ten_length[0] > rest  # taut: the solve is never clamped
        explicit = k * (de.ten_length[:1] - rest) + b * de.ten_velocity[:1]
        tension, pull = cable_tensions("coupled", 1.0, 0.01, euler, de, tendons, explicit,
                                       np.array([k]), np.array([b]), np.array([True]), last)
        de.ctrl[0] = -tension[0]
        mujoco.mj_step(euler, de)
        last = (de.qacc + pull, tension)
        # MuJoCo solves its step iteratively (to its tolerance); the probe directly
        np.testing.assert_allclose(de.qpos, dd.qpos, rtol=0, atol=1e-12)
    assert np.abs(de.qpos).max() > 1e-3  # it moved


def test_explicit_tension_is_not_the_discrete_step() -> None:
    """The check above has teeth: the explicit tension (theta = 0) misses the discrete step."""
    k, b, rest = 1e4, 100.0, 0.8
    spring = f'stiffness="{k}" damping="{b}" springlength="{rest} {rest}"'
    discrete = mujoco.MjModel.from_xml_string(HANG.format(integrator="discrete", spring=spring))
    euler = mujoco.MjModel.from_xml_string(HANG.format(integrator="Euler", spring=""))
    dd, de = mujoco.MjData(discrete), mujoco.MjData(euler)
    for _ in range(5):
        mujoco.mj_step(discrete, dd)
        mujoco.mj_fwdPosition(euler, de)
        mujoco.mj_fwdVelocity(euler, de)
        de.ctrl[0] = -(k * (de.ten_length[0] - rest) + b * de.ten_velocity[0])
        mujoco.mj_step(euler, de)
    assert np.abs(de.qpos - dd.qpos).max() > 1e-5  # far beyond the tolerance above


def test_velocity_jumps_counts_the_samples_off_the_reference() -> None:
    """Closed form: on a finer reference grid, two cables whose rates equal the reference's
    but for a 6 mm/s jump of one cable in 3 of the 10 samples inside the window (and one
    outside it, and one of 4 mm/s, below the 5 mm/s threshold): 3 / 10."""
    reference_time = np.linspace(0.0, 2.0, 2001)
    reference = np.stack([np.sin(reference_time), np.cos(reference_time)], axis=1)
    time = np.arange(0.0, 2.0, 0.1)
    rates = np.stack([np.sin(time), np.cos(time)], axis=1)
    rates[[11, 14, 17], 1] += 6e-3  # inside [1.0, 2.0): jumps
    rates[12, 0] -= 4e-3  # inside, below the threshold
    rates[3, 0] += 6e-3  # outside the window
    share = velocity_jumps(time, rates, reference_time, reference, window=(1.0, 2.0))
    assert share == 3 / 10
    # the reference itself has none
    assert velocity_jumps(reference_time, reference, reference_time, reference,
                          window=(0.0, 2.0)) == 0.0
