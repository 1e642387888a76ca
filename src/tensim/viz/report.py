"""A one-page HTML report of a run folder, built from whatever the folder holds.

The page shows the summary as tables (headline figures; per-cable figures side by side), the
folder's figures (tension plots measured and commanded, cable and rest lengths, the top view of
the path, any others; made from ``trajectory.parquet`` where the run did not make them), a
rendered frame of the robot at the end of the run (when an offscreen OpenGL backend works), the
folder's files and its log. Images are referenced relatively, so the folder can be moved or
archived as a whole; the page needs no network.
"""

from __future__ import annotations

import concurrent.futures
import datetime
import html
import json
import logging
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tensim._files import atomic_path, run_folder_name, write_text
from tensim.sim import TimeSeries

if TYPE_CHECKING:
    from tensim.model import CompiledModel
    from tensim.viz._gl import GLServer
    from tensim.viz.drawing import FigureDrawer

log = logging.getLogger(__name__)

CAPTIONS = {
    "tensions.png": "Cable tensions over time: measured (load cell, black) and commanded "
                    "(impedance setpoint T_set, dashed)",
    "lengths.png": "Cable lengths (anchor to anchor) and motor rest lengths",
    "path.png": "Top view of the path: each rigid body's and the centre of mass's (x, y); "
                "circles mark the start",
    "frame.png": "The robot at the end of the run (cables coloured by tension; grey dashed: "
                 "slack)",
}
_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1200px; color: #222;
padding: 0 1.5em; } * { box-sizing: border-box; }
h1 { font-size: 1.5em; margin-bottom: 0.2em; } h2 { font-size: 1.2em; margin-top: 1.6em; }
.meta { color: #666; margin-top: 0; }
table { border-collapse: collapse; margin: 0.6em 0 1.2em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
th { background: #f2f2f2; } caption { text-align: left; font-weight: 600; padding: 0.3em 0; }
figure { margin: 1em 0 2em; } figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { color: #555; font-size: 0.9em; } pre { background: #f7f7f7; padding: 0.8em;
overflow-x: auto; font-size: 0.8em; } .note { color: #8a5a00; }
"""


def write_report(out: Path, summary: dict[str, Any] | None = None, *,
                 series: TimeSeries | None = None, frame: bool = True,
                 drawer: FigureDrawer | None = None, compiled: CompiledModel | None = None
                 ) -> Path:
    """Writes ``out/report.html`` (atomically) and any figures it needs.

    Args:
        out: the run folder.
        summary: the run's summary (default: the folder's summary.json, if any).
        series: the run's trajectory (default: the folder's trajectory.parquet, if any).
        frame: render a frame of the robot (needs an offscreen OpenGL backend; skipped with a
            note on the page when none works).
        drawer: draws some of the folder's figures meanwhile (its pending ones are not drawn
            here); the page is written once it has finished. A disabled drawer (a run without
            figures) means no figures and no frame here either.
        compiled: the robot the run simulated, for the frame (None: compiled again from the
            folder, :func:`tensim.viz.replay.recorded_run`).

    Returns:
        The report's path.
    """
    from tensim.viz import _gl

    out = Path(out)
    if summary is None:
        path = out / "summary.json"
        summary = json.loads(path.read_text()) if path.is_file() else {}
    if series is None:
        series = _trajectory(out)
    if drawer is not None and not drawer.enabled:
        frame = False
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        # the child that paints the frame starts (and tries the backends) while the figures
        # are drawn, unless the command started it before it simulated
        backend = pool.submit(_gl.take_server) if frame and series is not None else None
        if drawer is None or drawer.enabled:
            _figures(out, series, drawer.pending if drawer is not None else frozenset())
        note = _frame(out, summary, series, backend, compiled) \
            if backend is not None and series is not None else None
    if drawer is not None:
        drawer.wait()
    figures = figure_names(out, summary)
    frames = ["frame.png"] if backend is not None and note is None else []
    page = _page(out, summary, frames + figures, [note] if note else [],
                 series.items("tension") if series is not None else [])
    write_text(out / "report.html", page)
    return out / "report.html"


def _trajectory(out: Path) -> TimeSeries | None:
    path = out / "trajectory.parquet"
    return TimeSeries.from_parquet(path) if path.is_file() else None


def _figures(out: Path, series: TimeSeries | None, pending: frozenset[str]) -> None:
    """Draws the standard figures the run did not make (and is not making: ``pending``)."""
    if series is None:
        return
    missing = [(quantity, name) for quantity, name in (("tension", "tensions.png"),
                                                       ("rest_length", "lengths.png"),
                                                       ("pos_x", "path.png"))
               if series.items(quantity) and name not in pending and not (out / name).exists()]
    if not missing:
        return  # matplotlib is not even loaded
    from tensim.viz.plots import plot_cable_tensions, plot_lengths, plot_path

    for _, name in missing:
        if name == "tensions.png":
            plot_cable_tensions(series, out / name, title="cable tensions")
        elif name == "lengths.png":
            plot_lengths(series, out / name)
        else:
            plot_path(series, out / name)


def figure_names(out: Path, summary: dict[str, Any]) -> list[str]:
    """The folder's figures in page order: the summary's ``figures`` first, then the standard
    ones, then any others (the rendered frame.png is not among them)."""
    listed = [str(f) for f in summary.get("figures", []) if isinstance(f, str)]
    standard = ["tensions.png", "lengths.png", "path.png"]
    others = sorted(p.name for p in out.glob("*.png") if p.name != "frame.png")
    order = dict.fromkeys([*listed, *standard, *others])
    return [name for name in order if (out / name).is_file()]


# frame.png has no multisampled buffer: with Mesa's software OpenGL, MuJoCo's default (4
# samples a pixel) took half the painting child's time and 17 MiB of its memory, for edges a
# little smoother
FRAME_SAMPLES = 0


def _frame(out: Path, summary: dict[str, Any], series: TimeSeries,
           server: concurrent.futures.Future[GLServer],
           compiled: CompiledModel | None = None) -> str | None:
    """Renders ``frame.png`` at the last recorded sample (painted by the OpenGL child of
    :class:`tensim.viz._gl.GLServer`, :data:`FRAME_SAMPLES`); a note for the page if it
    cannot."""
    from PIL import Image

    from tensim.viz._gl import OffscreenUnavailable
    from tensim.viz.cables import TensionColors
    from tensim.viz.render import FrameScene
    from tensim.viz.replay import PoseReplay, RunFolderError, recorded_run

    try:
        with server.result() as painter:
            replay = PoseReplay(recorded_run(out, summary, series, compiled))
            k = replay.time.size - 1
            scene = FrameScene(replay.compiled, colors=TensionColors.for_run(replay.tension),
                               samples=FRAME_SAMPLES)
            image = painter.paint(scene.job(replay.place(k), replay.tension[k],
                                            replay.rest_length[k], f"t = {replay.time[k]:.2f} s"))
    except (OffscreenUnavailable, RunFolderError) as err:
        log.info("report without a frame of the robot: %s", err)
        return f"No frame of the robot: {err}"
    with atomic_path(out / "frame.png") as tmp:
        Image.fromarray(image).save(tmp, format="png", compress_level=3)  # as the figures
    return None


def _page(out: Path, summary: dict[str, Any], figures: list[str], notes: list[str],
          cables: list[str]) -> str:
    name = run_folder_name(out)  # not the hidden staging folder it is written in
    title = " ".join(str(summary[k]) for k in ("experiment", "model") if k in summary) \
        or name
    when = datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
    parts = [f"<h1>tensim run: {_e(title)}</h1>",
             f'<p class="meta">folder {_e(name)}, tensim '
             f"{_e(summary.get('tensim_version', ''))}, report written {_e(when)}</p>",
             "<h2>Summary</h2>", *(_table(*t) for t in summary_tables(summary, cables))]
    if figures:
        parts.append("<h2>Figures</h2>")
    for name in figures:
        caption = CAPTIONS.get(name, name)
        parts.append(f'<figure><img src="{_e(name)}" alt="{_e(caption)}">'
                     f"<figcaption>{_e(caption)}</figcaption></figure>")
    parts += [f'<p class="note">{_e(n)}</p>' for n in notes]
    parts += _videos(out) + _files(out) + _log(out)
    return ('<!doctype html>\n<html lang="en"><head><meta charset="utf-8">'
            f"<title>tensim run: {_e(title)}</title><style>{_STYLE}</style></head>\n<body>\n"
            + "\n".join(parts) + "\n</body></html>\n")


def summary_tables(summary: dict[str, Any], cables: list[str] | tuple[str, ...] = ()
                   ) -> list[tuple[str, list[str], list[list[Any]]]]:
    """The summary as (caption, header, rows) tables.

    Scalars (and lists of them) form one table of name and value; mappings of scalars that
    share their keys (e.g. per-cable figures) form one table with a column each; a mapping of
    mappings (e.g. per-rate, per-cable figures) forms its own table. Anything deeper is shown
    as JSON.
    """
    scalars: list[list[Any]] = []
    groups: dict[tuple[str, ...], dict[str, dict[str, Any]]] = {}
    tables: list[tuple[str, list[str], list[list[Any]]]] = []
    for key, value in summary.items():
        if key == "figures":
            continue
        if _is_scalar(value) or (isinstance(value, list) and all(map(_is_scalar, value))):
            scalars.append([key, value])
        elif isinstance(value, dict) and value and all(map(_is_scalar, value.values())):
            groups.setdefault(tuple(value), {})[key] = value
        elif isinstance(value, dict) and value and all(
                isinstance(v, dict) and all(map(_is_scalar, v.values())) for v in value.values()):
            rows = list(dict.fromkeys(k for v in value.values() for k in v))
            tables.append((key, ["", *value], [[r, *(v.get(r, "") for v in value.values())]
                                              for r in rows]))
        else:
            scalars.append([key, json.dumps(value)])
    result = [("run", ["name", "value"], scalars)] if scalars else []
    for keys, columns in groups.items():
        caption = "per cable" if cables and set(keys) <= set(cables) else ", ".join(columns)
        result.append((caption, ["", *columns], [[k, *(c[k] for c in columns.values())]
                                                for k in keys]))
    return result + tables


def _is_scalar(value: Any) -> bool:
    return value is None or isinstance(value, str | int | float | bool)


def _cell(value: Any) -> str:
    if isinstance(value, float) and math.isfinite(value):
        return f'<td class="num">{value:.6g}</td>'
    if isinstance(value, int | float) and not isinstance(value, bool):
        return f'<td class="num">{value}</td>'
    if isinstance(value, list):
        text = ", ".join(f"{v:.6g}" if isinstance(v, float) else str(v) for v in value)
        return f"<td>{_e(text)}</td>"
    return f"<td>{_e(value)}</td>"


def _table(caption: str, header: list[str], rows: list[list[Any]]) -> str:
    head = "".join(f"<th>{_e(h)}</th>" for h in header)
    body = "".join("<tr>" + f"<th>{_e(r[0])}</th>" + "".join(_cell(v) for v in r[1:]) + "</tr>"
                   for r in rows)
    return f"<table><caption>{_e(caption)}</caption><tr>{head}</tr>{body}</table>"


def _videos(out: Path) -> list[str]:
    videos = sorted(p.name for p in out.glob("*.mp4"))
    if not videos:
        return []
    return ["<h2>Videos</h2>", *(f'<p><video controls width="640" src="{_e(v)}"></video>'
                                  f"<br>{_e(v)}</p>" for v in videos)]


def _files(out: Path) -> list[str]:
    """Links to the folder's files (summary.json included: it is written after the page)."""
    sizes = {p.name: f" ({p.stat().st_size:,} bytes)" for p in out.iterdir()
             if p.is_file() and not p.name.startswith(".")}
    sizes.setdefault("summary.json", "")
    sizes.setdefault("report.html", "")
    rows = "".join(f'<li><a href="{_e(name)}">{_e(name)}</a>{size}</li>'
                   for name, size in sorted(sizes.items()))
    return ["<h2>Files</h2>", f"<ul>{rows}</ul>"]


def _log(out: Path) -> list[str]:
    path = out / "tensim.log"
    if not path.is_file():
        return []
    return ["<h2>Log</h2>", f"<details><summary>tensim.log</summary><pre>"
            f"{_e(path.read_text())}</pre></details>"]


def _e(value: Any) -> str:
    return html.escape(str(value), quote=True)
