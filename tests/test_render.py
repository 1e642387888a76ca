"""Offscreen rendering and video: backend choice and fallback, frames that show the robot and
change as it moves, replays that match the live simulation, and the ``render`` command."""

from __future__ import annotations

import itertools
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import mujoco
import numpy as np
import pytest

from tensim import CompiledModel, Node, Rod, Structure, WorldOptions, compile_structure
from tensim.cli import main
from tensim.sim import Simulation, SimulationResult, simulate
from tensim.viz import _gl
from tensim.viz.render import CameraView, OffscreenRenderer
from tensim.viz.replay import PoseReplay, RecordedRun, RunFolderError, load_run
from tensim.viz.video import VideoSettings, render_simulation


def _backend() -> str:
    try:
        return _gl.select_backend()
    except _gl.OffscreenUnavailable as err:
        pytest.skip(f"no offscreen OpenGL backend on this machine ({err}); to run these "
                    "tests: sudo apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri libosmesa6 "
                    "(as .ci/run does; see the README)")


def _falling_rod() -> Structure:
    """A rod dropped from 1 m: it falls, so successive frames must differ."""
    return Structure("falling_rod", nodes=(Node("p", (0, 0, 1.0)), Node("q", (0.3, 0.1, 1.2))),
                     rods=(Rod("bar", ("p", "q"), radius=0.02, linear_density=2.0),))


# -- backend choice --------------------------------------------------------------------------


def test_backend_order() -> None:
    assert _gl.backend_order({}) == ("egl", "osmesa")
    assert _gl.backend_order({"DISPLAY": ":0"}) == ("egl", "osmesa", "glfw")
    assert _gl.backend_order({"MUJOCO_GL": "OSMesa"}) == ("osmesa",)
    with pytest.raises(_gl.OffscreenUnavailable, match="MUJOCO_GL='wgl'"):
        _gl.backend_order({"MUJOCO_GL": "wgl"})


def test_select_backend_falls_back_in_order_and_explains_failure(monkeypatch) -> None:
    tried: list[str] = []

    def probe(backend: str) -> str | None:
        tried.append(backend)
        return None if backend == "osmesa" else f"{backend} broken"

    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(_gl, "probe", probe)
    _gl.select_backend.cache_clear()
    try:
        assert _gl.select_backend() == "osmesa" and tried == ["egl", "osmesa"]
        _gl.select_backend.cache_clear()
        monkeypatch.setattr(_gl, "probe", lambda backend: f"{backend} missing")
        with pytest.raises(_gl.OffscreenUnavailable, match=r"egl: egl missing; osmesa: osmesa "
                           r"missing.*apt-get install"):
            _gl.select_backend()
    finally:
        _gl.select_backend.cache_clear()


def test_a_broken_egl_falls_back_to_osmesa_for_real() -> None:
    """EGL with no vendor library fails; the choice, made in a fresh process, is then OSMesa."""
    if _gl.probe("osmesa") is not None:
        pytest.skip("OSMesa is not installed here; to run this test: sudo apt-get install "
                    "libosmesa6 (as .ci/run does; see the README)")
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY",
                                                            "WAYLAND_DISPLAY")}
    env["__EGL_VENDOR_LIBRARY_FILENAMES"] = os.devnull  # glvnd finds no EGL driver
    code = "from tensim.viz._gl import select_backend; print(select_backend())"
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "osmesa"


def test_rendering_then_loading_triton_does_not_crash() -> None:
    """Mesa's driver and Triton (PyTorch's CUDA builds) each carry an LLVM: driver first, then
    Triton crashed the process, so rendering then training a policy in one process died.
    The renderer loads Triton first where it is installed (only there can this be tried)."""
    import importlib.util

    if importlib.util.find_spec("triton") is None:
        pytest.skip("Triton is not installed (PyTorch's CPU build): nothing to load first")
    _backend()
    code = ("from tensim.viz._gl import gl_context; context, _ = gl_context(16, 16); "
            "import torch; torch.optim.Adam([torch.zeros(1, requires_grad=True)]); print('ok')")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().endswith("ok")


# -- frames and videos -----------------------------------------------------------------------


def test_short_offscreen_video_has_frames_that_show_something_and_change(tmp_path) -> None:
    import av

    _backend()
    compiled = compile_structure(_falling_rod())
    # a camera that stays put, 2.5 m from the rod's start: the whole fall is in view
    settings = VideoSettings(fps=20, width=160, height=120,
                             view=CameraView("fixed", distance=2.5))
    result = render_simulation(compiled, tmp_path / "fall.mp4", 0.5, settings)
    assert result.frames == 11  # t = 0, 0.05, ..., 0.5 s
    with av.open(str(tmp_path / "fall.mp4")) as container:
        frames = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    assert len(frames) == 11 and frames[0].shape == (120, 160, 3)
    # the corners hold the time label and legend: compare the middle of the picture
    middle = [f[30:90, 40:120].astype(float) for f in frames]
    assert all(m.std() > 5 for m in middle)  # not blank: ground, sky and the rod
    # the rod falls 1 m in 0.45 s: the picture changes from frame to frame while it falls
    changes = [np.abs(b - a).mean() for a, b in itertools.pairwise(middle[:7])]
    assert min(changes) > 0.5


def test_replayed_poses_draw_the_same_picture_as_the_live_simulation(tmp_path) -> None:
    _backend()
    compiled = compile_structure(_falling_rod())
    result = simulate(compiled, 0.3, record_dt=0.01)
    replay = PoseReplay(_recorded(tmp_path, result, compiled))
    with OffscreenRenderer(compiled, 160, 120, CameraView("fixed")) as renderer, \
            Simulation(compiled) as sim:
        sim.step(200)  # t = 0.2 s, sample 20
        live = renderer.render(sim.data, sim.drive.tension, sim.drive.rest).astype(float)
        k = replay.sample_at(0.2)
        assert replay.time[k] == pytest.approx(0.2)
        again = renderer.render(replay.place(k), replay.tension[k],
                                replay.rest_length[k]).astype(float)
    # identical poses (recorded in double precision): at most a few pixels of rounding
    assert np.abs(live - again).mean() < 0.05


def _recorded(folder: Path, result: SimulationResult, compiled: CompiledModel) -> RecordedRun:
    """The run as a replay sees it, on the same compiled model."""
    return RecordedRun(folder, {}, result.trajectory, compiled)


def test_replay_picks_the_last_sample_at_or_before_a_time(tmp_path) -> None:
    compiled = compile_structure(_falling_rod())
    result = simulate(compiled, 0.1, record_dt=0.01)
    replay = PoseReplay(_recorded(tmp_path, result, compiled))
    assert [replay.sample_at(t) for t in (-1.0, 0.0, 0.015, 0.02, 5.0)] == [0, 0, 1, 2, 10]
    data = replay.place(10)
    body = compiled.index.body[0]
    recorded = [result.trajectory[f"pos_{a}/{compiled.index.bodies[0]}"][10] for a in "xyz"]
    assert np.allclose(data.xpos[body], recorded)


def test_run_folder_errors_name_the_file(tmp_path) -> None:
    with pytest.raises(RunFolderError, match=r"summary\.json: no such file"):
        load_run(tmp_path)
    (tmp_path / "summary.json").write_text(json.dumps({"model": "tetraspine3"}))
    with pytest.raises(RunFolderError, match=r"trajectory\.parquet: no such file"):
        load_run(tmp_path)


# -- the command -----------------------------------------------------------------------------


def test_render_command_replays_a_run_folder(tmp_path, capsys) -> None:
    _backend()
    run = tmp_path / "run"
    assert main(["--quiet", "simulate", "prism3", "--duration", "0.3", "--out", str(run)]) == 0
    out = tmp_path / "prism.mp4"
    assert main(["--quiet", "render", str(run), "--out", str(out), "--fps", "10",
                 "--size", "160x120"]) == 0
    assert "4 frames, 160x120 at 10 fps" in capsys.readouterr().out  # t = 0, 0.1, 0.2, 0.3 s
    assert out.stat().st_size > 0


def test_render_command_without_a_backend_says_what_to_install(tmp_path, monkeypatch,
                                                               capsys) -> None:
    def unavailable() -> str:
        raise _gl.OffscreenUnavailable("no offscreen OpenGL backend works here (...); install")

    monkeypatch.setattr(_gl, "select_backend", unavailable)
    assert main(["render", "prism3", "--duration", "0.1", "--out", str(tmp_path / "v.mp4")]) == 1
    assert "no offscreen OpenGL backend" in capsys.readouterr().err
    assert not (tmp_path / "v.mp4").exists()


def test_bad_video_settings_are_refused() -> None:
    with pytest.raises(ValueError, match="even"):
        VideoSettings(width=161)
    with pytest.raises(ValueError, match="camera must be one of"):
        CameraView("orbit")
    assert main(["render", "prism3", "--size", "big", "--out", "x.mp4"]) == 2


def test_renderer_needs_no_model_change_but_its_buffer() -> None:
    compiled = compile_structure(_falling_rod(), WorldOptions())
    tendon_rgba = compiled.model.tendon_rgba.copy()
    _backend()
    with OffscreenRenderer(compiled, 800, 600) as renderer:
        data = mujoco.MjData(compiled.model)
        mujoco.mj_forward(compiled.model, data)
        image = renderer.render(data, np.zeros(0), np.zeros(0))
    assert image.shape == (600, 800, 3)
    assert np.array_equal(compiled.model.tendon_rgba, tendon_rgba)


def test_the_painting_process_draws_what_this_process_draws() -> None:
    """frame.png is painted by a child (the backend's trial, kept): the same scene, cables and
    legend as the in-process renderer, pixel for pixel, with MuJoCo's multisampled buffer and
    without (the run folder's frame); a model with cables and a ground."""
    from tensim.models import preset
    from tensim.viz.render import FrameScene
    from tensim.viz.report import FRAME_SAMPLES

    _backend()
    compiled = compile_structure(preset("prism3").build())
    painted = {}
    with Simulation(compiled) as sim, _gl.start_server() as server:
        sim.step(300)
        tension, rest = sim.drive.tension.copy(), sim.drive.rest.copy()
        for samples in (None, FRAME_SAMPLES):
            with OffscreenRenderer(compiled, 200, 150, samples=samples) as renderer:
                here = renderer.render(sim.data, tension, rest, "t = 0.30 s")
            job = FrameScene(compiled, 200, 150, samples=samples).job(sim.data, tension, rest,
                                                                      "t = 0.30 s")
            assert len(job["geoms"]) > 6  # the grid and every cable were sent, not only MuJoCo's
            there = painted[samples] = server.paint(job)
            assert there.shape == (150, 200, 3)
            assert np.array_equal(here, there)
    assert compiled.model.vis.quality.offsamples == 4  # the model is left as it was
    # without the multisampled buffer the edges differ (the option reaches the painter)
    assert not np.array_equal(painted[None], painted[FRAME_SAMPLES])
    with pytest.raises(ValueError, match="samples must be 0 or more"):
        FrameScene(compiled, samples=-1)


def test_the_painting_process_loads_mujocos_bindings_without_its_package() -> None:
    """The painting child loads MuJoCo's compiled bindings, not the mujoco package's
    ``__init__`` (GLFW, the Python renderer) nor tensim's, and still has every name it paints
    with."""
    from tensim.viz import _glchild

    probe = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(Path(_glchild.__file__).parent)!r})
        import _glchild
        _glchild.register_bare()
        import mujoco
        from tensim.viz import _glserver
        model = mujoco.MjModel.from_xml_string("<mujoco/>")
        scene = mujoco.MjvScene(model, 10)
        print(sorted(m for m in ("glfw", "mujoco.rendering", "tensim.sim", "tensim.model")
                     if m in sys.modules), mujoco.mjtFontScale.mjFONTSCALE_100.value,
              callable(mujoco.mjr_render), scene.maxgeom)
        """)
    out = subprocess.run([sys.executable, "-P", "-c", probe], capture_output=True, text=True,
                         check=True).stdout
    assert out.split() == ["[]", "100", "True", "10"]
