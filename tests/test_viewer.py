"""The viewer without a window: real-time pacing on a fake clock, keys, cable colours and drawings,
and one frame of the loop (state copy, mouse push, reset) against a stand-in window."""

from __future__ import annotations

import contextlib
import subprocess
import sys
from collections.abc import Callable

import mujoco
import numpy as np
import pytest

from tensim import Cable, Node, PointMass, Rod, Structure, WorldOptions, compile_structure
from tensim.cli import main
from tensim.viz import viewer
from tensim.viz.cables import SLACK_RGBA, CableArtist, TensionColors, sag_curve, sag_depth
from tensim.viz.pacing import (
    KEY_BACKSPACE,
    KEY_ENTER,
    KEY_RIGHT,
    KEY_SPACE,
    Pacer,
    ViewerControls,
)

DT = 1e-3
FRAME = 1 / 60


class FakeClock:
    """A wall clock that moves only when told to."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def stepper(clock: FakeClock, cost_per_step: float = 0.0) -> Callable[[int], None]:
    """A step function that costs ``cost_per_step`` seconds of (fake) wall time per step."""

    def step(n: int) -> None:
        clock.now += n * cost_per_step

    return step


def run_frames(pacer: Pacer, clock: FakeClock, controls: ViewerControls, frames: int,
               draw_s: float = FRAME, cost_per_step: float = 0.0) -> list[int]:
    """Steps per frame when each frame takes ``draw_s`` of wall time besides the stepping."""
    step = stepper(clock, cost_per_step)
    counts = []
    for _ in range(frames):
        clock.now += draw_s
        counts.append(pacer.advance(controls, step))
    return counts


# -- pacing ----------------------------------------------------------------------------------


def test_real_time_sim_time_follows_the_wall_clock() -> None:
    clock, controls = FakeClock(), ViewerControls()
    pacer = Pacer(DT, clock=clock)
    counts = run_frames(pacer, clock, controls, 600)  # 10 s of wall time at 60 Hz
    # one period per frame: 16 or 17 steps of 1 ms, 10 s of simulated time in all (the first
    # frame covers one period from the start, so the total is 10 s to within one step)
    assert set(counts) <= {16, 17}
    assert abs(sum(counts) * DT - 600 * FRAME) <= DT


def test_real_time_holds_when_drawing_is_slow() -> None:
    """Frames of 0.3 s (a slow window) still advance 0.3 s of simulated time each."""
    clock, controls = FakeClock(), ViewerControls()
    pacer = Pacer(DT, clock=clock)
    counts = run_frames(pacer, clock, controls, 20, draw_s=0.3)
    assert sum(counts) * DT == pytest.approx(20 * 0.3, abs=0.3)  # the first frame: one period
    assert all(c == pytest.approx(300, abs=1) for c in counts[1:])


def test_a_slow_simulation_never_spirals() -> None:
    """Steps costing 2 ms of wall time each (the simulation's own limit: 0.5x real time)."""
    clock, controls = FakeClock(), ViewerControls()
    pacer = Pacer(DT, clock=clock, budget=0.7)
    step = stepper(clock, cost_per_step=2e-3)
    spent = []
    for _ in range(300):
        clock.now += FRAME  # drawing
        start = clock.now
        pacer.advance(controls, step)
        spent.append(clock.now - start)
    # stepping stops once it used 70 % of the time since the last frame (at most one chunk of
    # 5 steps = 10 ms past it), so no frame takes longer than the one before: no spiral
    frame_gaps = np.array(spent[:-1]) + FRAME
    assert max(np.array(spent[1:]) - 0.7 * frame_gaps) <= 5 * 2e-3 + 1e-12
    assert 0.2 < pacer.speed < 0.5  # as fast as the budget allows, but below real time


def test_pause_single_step_and_resume_without_a_burst() -> None:
    clock, controls = FakeClock(), ViewerControls()
    pacer = Pacer(DT, clock=clock)
    run_frames(pacer, clock, controls, 10)
    controls.on_key(KEY_SPACE)
    assert run_frames(pacer, clock, controls, 300) == [0] * 300  # 5 s paused
    controls.on_key(KEY_RIGHT)
    controls.on_key(KEY_RIGHT)
    assert run_frames(pacer, clock, controls, 2) == [2, 0]
    controls.on_key(KEY_SPACE)
    # after 5 s of pause each frame steps one period, not the 5 s the clock moved
    assert set(run_frames(pacer, clock, controls, 3)) <= {16, 17}


def test_a_stall_is_dropped_not_caught_up() -> None:
    clock, controls = FakeClock(), ViewerControls()
    pacer = Pacer(DT, clock=clock, max_lag=1.0)
    run_frames(pacer, clock, controls, 10)
    clock.now += 5.0  # the process was stopped for 5 s
    assert run_frames(pacer, clock, controls, 1)[0] <= 17


def test_fast_mode_steps_for_its_budget_of_each_frame() -> None:
    """Stepping takes 70 % of each frame cycle: at 0.1 ms per 1 ms step, 0.7 x 10 = 7x."""
    clock, controls = FakeClock(), ViewerControls()
    pacer = Pacer(DT, clock=clock, budget=0.7, chunk_s=0.005)
    controls.on_key(KEY_ENTER)
    run_frames(pacer, clock, controls, 120, cost_per_step=1e-4)
    # the last chunk of 5 steps may overrun the budget: within 5 steps of ~390 per frame
    assert pacer.speed == pytest.approx(0.7 * DT / 1e-4, rel=0.03)


def test_keys() -> None:
    controls = ViewerControls()
    controls.on_key(KEY_RIGHT)  # not paused: ignored
    assert controls.take_steps() == 0
    controls.on_key(KEY_BACKSPACE)
    assert controls.take_reset() and not controls.take_reset()
    controls.on_key(KEY_ENTER)
    controls.on_key(ord("A"))  # other keys belong to MuJoCo's viewer
    assert controls.fast and not controls.paused


def test_waits_for_the_next_60_hz_frame() -> None:
    clock = FakeClock()
    pacer = Pacer(DT, clock=clock)
    clock.now += 0.004  # this frame took 4 ms
    assert pacer.wait() == pytest.approx(FRAME - 0.004)
    clock.now += 0.1  # a slow frame: no sleep, no catch-up frames
    assert pacer.wait() == 0.0
    clock.now += 0.005
    assert pacer.wait() == pytest.approx(FRAME - 0.005)


# -- colours and cable drawings --------------------------------------------------------------


def test_tension_colours_run_from_blue_to_red_and_slack_is_grey() -> None:
    colors = TensionColors(50.0)
    rgba = colors.rgba(np.array([-1.0, 0.0, 1e-6, 25.0, 50.0, 80.0]))
    assert np.allclose(rgba[:2], SLACK_RGBA)
    low, high = rgba[2], rgba[4]
    assert low[2] > low[0] and high[0] > high[2]  # blue when just taut, red at the limit
    assert np.allclose(rgba[5], rgba[4])  # clipped above max_tension
    assert not np.allclose(low, SLACK_RGBA)
    bar = colors.colorbar(100, 8)
    assert bar.shape == (8, 100, 3) and bar.dtype == np.uint8
    assert bar[0, 0, 2] > bar[0, 0, 0] and bar[0, -1, 0] > bar[0, -1, 2]



def test_tension_colours_are_matplotlibs_turbo_to_the_bit_without_loading_it() -> None:
    """The colour map is a copy of matplotlib's turbo (so that colouring a frame does not
    load matplotlib): the same table, and the same colour for every value, out of range and
    NaN included."""
    import matplotlib

    from tensim.viz._turbo import TURBO, turbo

    reference = matplotlib.colormaps["turbo"]
    assert np.array_equal(TURBO, np.array(reference.colors, dtype=float))
    x = np.concatenate([np.linspace(-0.1, 1.1, 10_001), np.arange(257) / 256,
                        [0.0, 1.0, np.nan, np.inf, -np.inf, np.nextafter(1.0, 0.0)]])
    assert np.array_equal(turbo(x), reference(x))
    tension = np.concatenate([np.linspace(-5.0, 80.0, 2001), [np.nan]])
    share = np.clip(tension / 50.0, 0.0, 1.0)
    expected = reference(0.1 + 0.85 * share)
    expected[tension <= 0] = SLACK_RGBA
    assert np.array_equal(TensionColors(50.0).rgba(tension), expected.astype(np.float32))
    probe = ("import sys, numpy as np; from tensim.viz.cables import TensionColors; "
             "TensionColors(50.0).rgba(np.ones(3)); print('matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "False"

def _polyline_length(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


@pytest.mark.parametrize("span, length", [(0.2, 0.21), (0.3, 0.5), (0.05, 0.4)])
def test_a_slack_cable_hangs_with_its_rest_length(span: float, length: float) -> None:
    start, end = np.array([0.1, 0.2, 0.5]), np.array([0.1 + span, 0.2, 0.5])
    curve = sag_curve(start, end, length, points=401)
    # a fine polyline's length is the arc length to O(1/n^2): well under 0.1 %
    assert _polyline_length(curve) == pytest.approx(length, rel=1e-3)
    assert np.allclose(curve[[0, -1]], [start, end])
    middle = curve[200]
    assert middle[2] < 0.5 and np.allclose(middle[:2], [0.1 + span / 2, 0.2])  # straight down


def test_sag_depth_matches_the_shallow_parabola_formula() -> None:
    """For a small slack L - x, L = x + 8 h^2 / (3 x) to leading order: h = sqrt(3 x (L-x) / 8)."""
    span, length = 0.3, 0.3003
    expected = np.sqrt(3 * span * (length - span) / 8)
    assert sag_depth(np.array(span), np.array(length)) == pytest.approx(expected, rel=1e-3)
    assert sag_depth(np.array([0.3, 0.3]), np.array([0.29, 0.3])).tolist() == [0.0, 0.0]


def test_sag_depths_of_many_cables_at_once_are_each_cables_root() -> None:
    """The depths found for many slack cables together are each the root of the arc-length
    equation, as scipy's brentq finds it for one cable (to 1e-12 of the length)."""
    from scipy.optimize import brentq

    from tensim.viz.cables import _parabola_length

    rng = np.random.default_rng(3)
    span = rng.uniform(0.01, 2.0, 200)
    length = span * (1 + rng.choice([1e-6, 1e-3, 0.1, 2.0, 50.0], span.size))
    length[:5] = span[:5]  # taut: no sag
    depth = sag_depth(span, length)
    assert np.all(depth[:5] == 0.0)
    for x, target, h in zip(span[5:], length[5:], depth[5:], strict=True):
        root = brentq(lambda d, x=x, t=target: _parabola_length(x, d) - t, 1e-12, target)
        assert abs(h - root) <= 1e-12 * target


def test_a_vertical_slack_cable_hangs_to_one_side() -> None:
    curve = sag_curve(np.zeros(3), np.array([0.0, 0.0, 0.2]), 0.3, points=201)
    assert _polyline_length(curve) == pytest.approx(0.3, rel=1e-3)
    assert np.abs(curve[100, :2]).max() > 0.05


def _two_cables(slack_rest: float = 0.6) -> Structure:
    """A rod hung from two fixed points: one cable taut, one with a long rest length (slack)."""
    return Structure(
        "two_cables",
        nodes=(Node("a", (0, 0, 1), fixed=True), Node("b", (0.4, 0, 1), fixed=True),
               Node("p", (0, 0, 0.6)), Node("q", (0.4, 0, 0.6))),
        rods=(Rod("bar", ("p", "q"), radius=0.01, linear_density=1.0),),
        cables=(Cable("taut", ("a", "p"), stiffness=500.0, rest_length=0.3),
                Cable("slack", ("b", "q"), stiffness=500.0, rest_length=slack_rest)),
        point_masses=(PointMass("p", 0.1), PointMass("q", 0.1)),
    )


def test_artist_draws_taut_cables_straight_and_slack_ones_dashed_and_sagging() -> None:
    compiled = compile_structure(_two_cables(), WorldOptions(ground=False))
    model = compiled.model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    scene = mujoco.MjvScene(model, 200)
    artist = CableArtist(compiled, TensionColors(50.0), width=0.004, segments=16)
    artist.draw(scene, data, tension=np.array([30.0, 0.0]), rest_length=np.array([0.3, 0.6]))
    assert scene.ngeom == 1 + 8  # one straight capsule; 8 dashes of 16 pieces
    taut, dashes = scene.geoms[0], [scene.geoms[i] for i in range(1, 9)]
    anchor = [data.site_xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, f"taut_{e}")]
              for e in (0, 1)]
    assert np.allclose(taut.pos, (anchor[0] + anchor[1]) / 2, atol=1e-6)
    assert taut.size[2] == pytest.approx(np.linalg.norm(anchor[1] - anchor[0]) / 2, rel=1e-5)
    assert not np.allclose(taut.rgba, SLACK_RGBA)
    assert all(np.allclose(g.rgba, SLACK_RGBA) for g in dashes)
    ends = [data.site_xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, f"slack_{e}")]
            for e in (0, 1)]
    axis = (ends[1] - ends[0]) / np.linalg.norm(ends[1] - ends[0])
    off_chord = [np.linalg.norm(np.cross(g.pos - ends[0], axis)) for g in dashes]
    # 0.6 m of cable between anchors 0.4 m apart hangs well away from the straight line
    assert max(off_chord) > 0.1


# -- one frame of the loop against a stand-in window -----------------------------------------


class FakeWindow:
    """Stands in for MuJoCo's passive viewer handle; ``push`` is what the mouse applies."""

    def __init__(self, session: viewer.ViewerSession, push: np.ndarray | None = None):
        self.session, self.push = session, push
        self.user_scn = mujoco.MjvScene(session.model, 1000)
        self.texts: list = []
        self.syncs = 0

    def lock(self) -> contextlib.AbstractContextManager:
        return contextlib.nullcontext()

    def sync(self) -> None:  # as MuJoCo's passive sync: clear, then apply the perturbation
        self.syncs += 1
        data = self.session.data
        data.xfrc_applied[:] = 0.0
        if self.push is not None:
            data.xfrc_applied[1, :3] = self.push

    def is_running(self) -> bool:
        return self.syncs < 3

    def set_texts(self, texts: list) -> None:
        self.texts = texts


def _floating_rod() -> Structure:
    return Structure("rod", nodes=(Node("p", (0, 0, 1)), Node("q", (0.4, 0, 1))),
                     rods=(Rod("bar", ("p", "q"), radius=0.01, linear_density=2.0),))


def test_a_mouse_push_accelerates_the_body_as_f_over_m() -> None:
    """A 1.6 N push on a free 0.8 kg rod (no gravity, no ground): v = F t / m after t."""
    compiled = compile_structure(_floating_rod(), WorldOptions(gravity=(0, 0, 0), ground=False))
    clock = FakeClock()
    session = viewer.ViewerSession(compiled, pacer=Pacer(DT, clock=clock))
    window = FakeWindow(session, push=np.array([1.6, 0.0, 0.0]))
    session.frame(window)  # the push is picked up at this frame's sync
    steps_before = session.pacer.steps
    clock.now += 0.1
    session.frame(window)
    pushed = (session.pacer.steps - steps_before) * DT
    mass = compiled.model.body_mass[1]
    assert mass == pytest.approx(0.8)
    # semi-implicit Euler integrates a constant force exactly in velocity
    assert session.sim.data.qvel[0] == pytest.approx(1.6 * pushed / mass, rel=1e-9)
    assert session.data.time == session.sim.data.time  # the window shows the simulation's state
    session.close()


def test_frame_draws_cables_and_reset_starts_again() -> None:
    compiled = compile_structure(_two_cables())
    clock = FakeClock()
    session = viewer.ViewerSession(compiled, pacer=Pacer(DT, clock=clock))
    window = FakeWindow(session)
    for _ in range(30):
        clock.now += FRAME
        session.frame(window)
    assert session.sim.time == pytest.approx(30 * FRAME, abs=2 * DT)
    capsules = [window.user_scn.geoms[i] for i in range(window.user_scn.ngeom)
                if window.user_scn.geoms[i].type == mujoco.mjtGeom.mjGEOM_CAPSULE]
    assert len(capsules) >= 2  # the taut cable and at least the slack one's dashes
    assert any("real time" in t[2] for t in window.texts)
    session.controls.on_key(KEY_BACKSPACE)
    session.frame(window)
    assert session.sim.time <= 2 * FRAME  # a fresh simulation: one frame's steps at most
    session.close()


# -- no display ------------------------------------------------------------------------------


def test_without_a_display_it_says_so_and_points_to_render(monkeypatch, capsys) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(viewer.DisplayUnavailable, match="tensim render"):
        viewer.check_display()
    assert main(["view", "tetraspine3"]) == 1
    assert "tensim render" in capsys.readouterr().err
