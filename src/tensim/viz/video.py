"""Headless video: a fresh simulation or a recorded run, rendered offscreen to an H.264 MP4.

Frames come at fixed video times k / fps. A fresh simulation steps its fixed physics step up
to each frame time; a recorded run shows, at each frame time, the last sample recorded at or
before it (poses replayed, not re-simulated). Encoding is FFmpeg's libx264 through PyAV, whose
wheels ship FFmpeg; the file is written beside its target and renamed when complete.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Iterator, Sequence
from fractions import Fraction
from pathlib import Path

import numpy as np

from tensim._files import atomic_path
from tensim.model import CompiledModel
from tensim.sim import Controller, NodeLoad, Simulation
from tensim.viz.cables import TensionColors
from tensim.viz.render import CameraView, OffscreenRenderer
from tensim.viz.replay import PoseReplay, RecordedRun

Progress = Callable[[float, float], None]

MAX_SIDE = 8192  # largest frame side [px] (MuJoCo's offscreen buffer is allocated whole)


@dataclasses.dataclass(frozen=True)
class VideoSettings:
    """How a video looks.

    Attributes:
        fps: frames per second of video (and of simulated time: videos play in real time).
        width, height: frame size [px]; even, as H.264 in yuv420p needs.
        view: the camera.
        shadows: shadows and reflections (slow with software OpenGL).
        crf: x264 quality, 0 (lossless) to 51; 23 is FFmpeg's default.
        colors: the tension colour map (None: scaled to the run's highest tension, or for a
            fresh simulation to twice the pretension; see :class:`TensionColors`).
    """

    fps: int = 60
    width: int = 640
    height: int = 480
    view: CameraView = dataclasses.field(default_factory=CameraView)
    shadows: bool = False
    crf: int = 23
    colors: TensionColors | None = None

    def __post_init__(self) -> None:
        if not 1 <= self.fps <= 240:
            raise ValueError(f"fps must be a whole number in [1, 240], got {self.fps}")
        if self.width % 2 or self.height % 2 or min(self.width, self.height) < 16 \
                or max(self.width, self.height) > MAX_SIDE:
            raise ValueError(f"frame size must be even, at least 16 px and at most {MAX_SIDE} "
                             f"px a side, got {self.width} x {self.height}")
        if not 0 <= self.crf <= 51:
            raise ValueError(f"crf must be in [0, 51], got {self.crf}")

    def renderer(self, compiled: CompiledModel) -> OffscreenRenderer:
        """An offscreen renderer with these settings."""
        return OffscreenRenderer(compiled, self.width, self.height, self.view, self.colors,
                                 shadows=self.shadows)


@dataclasses.dataclass(frozen=True)
class VideoResult:
    """A written video.

    Attributes:
        path: the MP4 file.
        frames: number of frames.
        fps: frames per second.
        backend: the OpenGL backend that rendered it (egl, osmesa or glfw).
    """

    path: Path
    frames: int
    fps: int
    backend: str

    @property
    def duration(self) -> float:
        """Length of the video [s]."""
        return self.frames / self.fps


def write_video(frames: Iterable[np.ndarray], path: Path, fps: int, crf: int = 23) -> int:
    """Encodes (height, width, 3) uint8 RGB frames as an H.264 MP4, atomically.

    Returns:
        The number of frames written.

    Raises:
        ValueError: no frames.
    """
    import av

    count = 0
    with atomic_path(Path(path)) as tmp, av.open(str(tmp), mode="w", format="mp4") as container:
        stream = None
        for image in frames:
            if stream is None:
                stream = container.add_stream("libx264", rate=Fraction(fps))
                stream.height, stream.width = image.shape[:2]
                stream.pix_fmt = "yuv420p"
                stream.options = {"crf": str(crf)}
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24")
            container.mux(stream.encode(frame))
            count += 1
        if stream is None:
            raise ValueError(f"{path}: no frames to write")
        container.mux(stream.encode(None))  # flush the encoder
    return count


def frame_times(duration: float, fps: int) -> np.ndarray:
    """Video frame times k / fps for k = 0 .. floor(duration · fps) [s]."""
    return np.arange(math.floor(duration * fps + 1e-9) + 1) / fps


def simulation_frames(sim: Simulation, renderer: OffscreenRenderer, duration: float, fps: int,
                      progress: Progress | None = None) -> Iterator[np.ndarray]:
    """Steps ``sim`` for ``duration`` [s], yielding a frame at every video time."""
    steps_done = 0
    for t in frame_times(duration, fps):
        target = round(t / sim.dt)
        sim.step(target - steps_done)
        steps_done = target
        drive = sim.drive
        yield renderer.render(sim.data, drive.tension, drive.rest, f"t = {t:6.2f} s")
        if progress is not None:
            progress(float(t), duration)


def replay_frames(replay: PoseReplay, renderer: OffscreenRenderer, fps: int,
                  span: Sequence[float] | None = None,
                  progress: Progress | None = None) -> Iterator[np.ndarray]:
    """Replays recorded poses over ``span`` = (start, stop) [s] (all of it by default)."""
    start, stop = span if span is not None else (replay.time[0], replay.time[-1])
    start, stop = max(start, replay.time[0]), min(stop, replay.time[-1])
    if stop < start:
        raise ValueError(f"nothing recorded between {span[0]} s and {span[1]} s "  # type: ignore
                         f"(the run covers {replay.time[0]:g} to {replay.time[-1]:g} s)")
    for t in frame_times(stop - start, fps):
        k = replay.sample_at(start + t)
        data = replay.place(k)
        yield renderer.render(data, replay.tension[k], replay.rest_length[k],
                              f"t = {replay.time[k]:6.2f} s (recorded)")
        if progress is not None:
            progress(float(t), stop - start)


def render_simulation(compiled: CompiledModel, path: Path, duration: float,
                      settings: VideoSettings | None = None, *,
                      controller: Controller | None = None, loads: Sequence[NodeLoad] = (),
                      progress: Progress | None = None) -> VideoResult:
    """Simulates ``compiled`` from its build pose and writes the video.

    Raises:
        OffscreenUnavailable: no offscreen OpenGL backend works here.
        SimulationError: the run became unstable.
    """
    settings = settings or VideoSettings()
    with settings.renderer(compiled) as renderer, \
            Simulation(compiled, controller=controller, loads=loads) as sim:
        frames = simulation_frames(sim, renderer, duration, settings.fps, progress)
        count = write_video(frames, path, settings.fps, settings.crf)
        return VideoResult(Path(path), count, settings.fps, renderer.backend)


def render_run(run: RecordedRun, path: Path, settings: VideoSettings | None = None, *,
               span: Sequence[float] | None = None,
               progress: Progress | None = None) -> VideoResult:
    """Writes the video of a recorded run, replaying its stored poses.

    Raises:
        OffscreenUnavailable: no offscreen OpenGL backend works here.
    """
    settings = settings or VideoSettings()
    replay = PoseReplay(run)
    if settings.colors is None:  # the colour scale spans the run's own tensions
        settings = dataclasses.replace(settings, colors=TensionColors.for_run(replay.tension))
    with settings.renderer(run.compiled) as renderer:
        frames = replay_frames(replay, renderer, settings.fps, span, progress)
        count = write_video(frames, path, settings.fps, settings.crf)
        return VideoResult(Path(path), count, settings.fps, renderer.backend)
