"""``tensim render``: an MP4 video, rendered offscreen, of a fresh simulation or a recorded run."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from tensim.cli._common import (
    Progress,
    add_controller_option,
    add_world_options,
    count,
    finite,
    load_model,
    output_option,
    positive,
    world_from_args,
)

if TYPE_CHECKING:
    from tensim.viz.video import VideoResult, VideoSettings


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "render", help="write an MP4 video of a simulation or a recorded run (no screen needed)",
        description="Renders offscreen (EGL, else OSMesa; MUJOCO_GL=egl|osmesa picks one) with "
        "cables coloured by tension and slack ones drawn sagging. MODEL (a preset or structure "
        ".yaml file) is simulated afresh under its controller; RUN_DIR (a folder written by "
        "simulate or experiment) is replayed from its recorded poses, not re-simulated.")
    p.add_argument("source", metavar="MODEL|RUN_DIR",
                   help="preset name, structure .yaml file, or run folder")
    output_option(p, "--out", "file", required=True, metavar="FILE.mp4", help="video file to write")
    p.add_argument("--fps", type=count, default=60, help="frames per second (default 60)")
    p.add_argument("--camera", default="track", choices=("track", "top", "side", "fixed"),
                   help="track: follows the robot at 3/4 view (default); top: from above; "
                        "side: from the side; fixed: aimed at the start, never moves")
    p.add_argument("--azimuth", type=finite, default=None, help="camera azimuth [deg]")
    p.add_argument("--elevation", type=finite, default=None, help="camera elevation [deg]")
    p.add_argument("--distance", type=positive, default=None,
                   help="camera distance [m] (default 1.3 x the model's size)")
    p.add_argument("--size", default="640x480", metavar="WxH",
                   help="frame size in pixels, even numbers (default 640x480)")
    p.add_argument("--max-tension", type=positive, default=None, metavar="N",
                   help="tension drawn red [N] (default: a recorded run's highest "
                        "tension, or twice the pretension, rounded up to 1, 2 or 5 x 10^k N)")
    p.add_argument("--shadows", action="store_true",
                   help="draw shadows and reflections (slow without a GPU)")
    sim = p.add_argument_group("a fresh simulation (MODEL)")
    sim.add_argument("--duration", type=positive, default=10.0,
                     help="simulated time [s] (default 10)")
    add_world_options(sim)
    add_controller_option(sim)
    sim.add_argument("--load", action="append", default=[], metavar="NODE:FX,FY,FZ@T0-T1",
                     help="push a node, as `tensim simulate --load`")
    sim.add_argument("--loads", default=None, metavar="FILE",
                     help="loads file, e.g. a run folder's loads.yaml (a recorded run replays "
                          "its pushes with its poses)")
    run = p.add_argument_group("a recorded run (RUN_DIR)")
    run.add_argument("--start", type=finite, default=None, help="first recorded time shown [s]")
    run.add_argument("--stop", type=finite, default=None, help="last recorded time shown [s]")
    p.set_defaults(run=run_render)


def _settings(args: argparse.Namespace) -> VideoSettings:
    from tensim.viz.cables import TensionColors
    from tensim.viz.render import CameraView
    from tensim.viz.video import VideoSettings

    try:
        width, height = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        raise ValueError(f"--size must look like 640x480, got {args.size!r}") from None
    view = CameraView(args.camera, args.azimuth, args.elevation, args.distance)
    colors = TensionColors(args.max_tension) if args.max_tension is not None else None
    return VideoSettings(args.fps, width, height, view, args.shadows, colors=colors)


def run_render(args: argparse.Namespace) -> int:
    from tensim.limits import check_run
    from tensim.viz._gl import OffscreenUnavailable

    settings = _settings(args)
    source, out = Path(args.source), Path(args.out)
    _check_out(source, out, getattr(args, "controller", None))
    progress = Progress("render", args.quiet, unit="s video")
    start = time.perf_counter()
    try:
        if source.is_dir():
            if args.load or args.loads:
                raise ValueError(f"--load and --loads are for a fresh simulation; {source} is a "
                                 "recorded run, whose poses already show its loads")
            result = _render_run(args, source, out, settings, progress)
        else:
            check_run(args.duration, args.dt, force=args.force)
            result = _render_model(args, out, settings, progress)
    except OffscreenUnavailable as err:
        print(f"tensim: error: {err}", file=sys.stderr)
        return 1
    wall = time.perf_counter() - start
    print(f"wrote {result.path}: {result.frames} frames, {settings.width}x{settings.height} at "
          f"{result.fps} fps, {result.duration:.2f} s of video (rendered with {result.backend} "
          f"in {wall:.1f} s)")
    return 0


def _check_out(source: Path, out: Path, controller: str | None) -> None:
    """Refuses an ``--out`` that would overwrite what the video is made from: the model or
    controller file, or a file of the run folder other than a video.

    Raises:
        ValueError: naming the file.
    """
    target = out.resolve()
    inputs = [source] + ([Path(controller)] if controller else [])
    if any(p.exists() and target == p.resolve() for p in inputs):
        raise ValueError(f"--out {out}: is the input {out}; the video would overwrite it, "
                         "choose another file")
    if source.is_dir() and target.parent == source.resolve() and target.exists() \
            and target.suffix.lower() != ".mp4":
        raise ValueError(f"--out {out}: is the run's own {target.name}; the video would "
                         "overwrite it, choose another file (e.g. "
                         f"{source / 'video.mp4'})")


def _render_run(args: argparse.Namespace, folder: Path, out: Path, settings: VideoSettings,
                progress: Progress) -> VideoResult:
    from tensim.viz.replay import load_run
    from tensim.viz.video import render_run

    run = load_run(folder)
    span = None
    if args.start is not None or args.stop is not None:
        span = (args.start if args.start is not None else run.series.time[0],
                args.stop if args.stop is not None else run.series.time[-1])
    return render_run(run, out, settings, span=span, progress=progress)


def _render_model(args: argparse.Namespace, out: Path, settings: VideoSettings,
                  progress: Progress) -> VideoResult:
    from tensim.loads import check_loads, load_loads, parse_push
    from tensim.model import compile_structure
    from tensim.models import resolve_controller
    from tensim.viz.video import render_simulation

    structure = load_model(args.source)
    config = resolve_controller(args.source, structure, args.controller)
    loads = [*(load_loads(args.loads) if args.loads else []), *map(parse_push, args.load)]
    for note in check_loads(loads, structure, args.duration):
        print(f"tensim: note: {note}", file=sys.stderr)
    compiled = compile_structure(structure, world_from_args(args))
    controller = config.build(compiled.model.opt.timestep) if config else None
    return render_simulation(compiled, out, args.duration, settings, controller=controller,
                             loads=loads, progress=progress)
