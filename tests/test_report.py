"""Run reports and run logs: the page's tables and figures, opened in a real headless browser,
and the progress bar's lines in the run folder's log."""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path

import pytest

from tensim.cli import main
from tensim.cli._common import Progress, _duration
from tensim.runs import RUN_LOG, finish_run
from tensim.viz import _gl
from tensim.viz.report import summary_tables, write_report


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short prism3 run written by the simulate command (progress is reported each second)."""
    out = tmp_path_factory.mktemp("report") / "prism"
    assert main(["--quiet", "simulate", "prism3", "--duration", "1", "--out", str(out)]) == 0
    return out


def test_summary_tables_group_per_cable_figures_and_keep_nested_ones() -> None:
    summary = {
        "model": "tetraspine3", "duration_s": 60.0, "com_displacement_m": [0.01, 0.0, -0.002],
        "max_tension_N": {"a_1": 11.5, "b_1": 20.25},
        "mean_tension_hold_N": {"a_1": 10.0, "b_1": 18.0},
        "change_percent": {"250": {"a_1": 2.0, "b_1": -1.0}, "4000": {"a_1": 0.5}},
        "odd": {"nested": {"deeper": {"x": 1}}},
        "figures": ["tensions.png"],
    }
    tables = {caption: (header, rows) for caption, header, rows in
              summary_tables(summary, cables=["a_1", "b_1"])}
    header, rows = tables["run"]
    assert rows[:3] == [["model", "tetraspine3"], ["duration_s", 60.0],
                        ["com_displacement_m", [0.01, 0.0, -0.002]]]
    assert rows[3] == ["odd", '{"nested": {"deeper": {"x": 1}}}']  # too deep: shown as JSON
    assert all(r[0] != "figures" for r in rows)
    header, rows = tables["per cable"]
    assert header == ["", "max_tension_N", "mean_tension_hold_N"]
    assert rows == [["a_1", 11.5, 10.0], ["b_1", 20.25, 18.0]]
    header, rows = tables["change_percent"]
    assert header == ["", "250", "4000"]
    assert rows == [["a_1", 2.0, 0.5], ["b_1", -1.0, ""]]


def test_report_holds_summary_figures_frame_and_log(run_folder: Path) -> None:
    page = (run_folder / "report.html").read_text()
    summary = json.loads((run_folder / "summary.json").read_text())
    assert f"{summary['max_system_tension_N']:.6g}" in page
    # simulate makes tensions.png and path.png; the report adds the rest lengths
    for figure in ("tensions.png", "lengths.png", "path.png"):
        assert (run_folder / figure).is_file() and f'src="{figure}"' in page
    try:
        _gl.select_backend()
    except _gl.OffscreenUnavailable:
        assert "No frame of the robot" in page and not (run_folder / "frame.png").exists()
    else:
        assert (run_folder / "frame.png").is_file() and 'src="frame.png"' in page
    log = (run_folder / "tensim.log").read_text()
    assert "prism3 [" in log and "done in" in log  # the progress bar's lines, even with --quiet
    assert "tensim.log" in page and "<details>" in page


def test_report_without_a_trajectory_or_backend(tmp_path: Path, monkeypatch) -> None:
    """A study folder (summary and a figure only), on a machine with no offscreen OpenGL."""
    import matplotlib.pyplot as plt

    def unavailable() -> str:
        raise _gl.OffscreenUnavailable("none here")

    monkeypatch.setattr(_gl, "select_backend", unavailable)
    monkeypatch.setattr(_gl, "start_server", unavailable)
    plt.imsave(tmp_path / "study.png", [[0.0, 1.0], [1.0, 0.0]])
    finish_run(tmp_path, {"experiment": "timestep", "max_change_percent": {"250": 2.0},
                          "figures": ["study.png"]})
    page = (tmp_path / "report.html").read_text()
    assert 'src="study.png"' in page and "timestep" in page
    assert "frame.png" not in page  # no trajectory: no frame to render, and no note either
    assert json.loads((tmp_path / "summary.json").read_text())["tensim_version"]


def test_frame_note_when_no_backend(run_folder: Path, tmp_path: Path, monkeypatch) -> None:
    def unavailable() -> str:
        raise _gl.OffscreenUnavailable("no offscreen OpenGL backend works here")

    monkeypatch.setattr(_gl, "select_backend", unavailable)
    monkeypatch.setattr(_gl, "start_server", unavailable)
    copy = tmp_path / "copy"
    shutil.copytree(run_folder, copy)
    (copy / "frame.png").unlink(missing_ok=True)
    page = write_report(copy).read_text()
    assert "No frame of the robot: no offscreen OpenGL backend" in page


def _chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    pytest.skip("no Chromium here; to run this test: sudo apt-get install chromium (as .ci/run "
                "does; see the README)")


def test_report_renders_in_a_headless_browser_with_its_images(run_folder: Path,
                                                              tmp_path: Path) -> None:
    playwright = pytest.importorskip("playwright.sync_api",
                                     reason="playwright is in the test extra: pip install -e "
                                            "'.[test]'")
    browser_path = _chromium()
    summary = json.loads((run_folder / "summary.json").read_text())
    with playwright.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=browser_path, args=["--no-sandbox"])
        try:
            page = browser.new_page(viewport={"width": 1200, "height": 900})
            page.goto((run_folder / "report.html").as_uri(), wait_until="load")
            images = page.eval_on_selector_all(
                "img", "els => els.map(e => [e.getAttribute('src'), e.complete, e.naturalWidth])")
            text = page.inner_text("body")
            page.screenshot(path=str(tmp_path / "report.png"), full_page=True)
        finally:
            browser.close()
    shown = {src for src, complete, width in images if complete and width > 0}
    assert {"tensions.png", "lengths.png", "path.png"} <= shown
    assert len(shown) == len(images)  # every image on the page loaded
    assert "tensim run: prism3" in text
    assert f"{summary['max_system_tension_N']:.6g}" in text
    assert (tmp_path / "report.png").stat().st_size > 10_000


def test_progress_lines_go_to_the_run_log_and_quiet_silences_the_bar(capsys) -> None:
    RUN_LOG.lines.clear()
    bar = Progress("trial", quiet=True)
    for k in range(1, 101):
        bar(k / 10, 10.0)
    assert capsys.readouterr().err == ""
    lines = [line for line in RUN_LOG.lines if "tensim.progress" in line]
    # a line every tenth of the work (give or take one where a tenth lands between calls)
    assert 9 <= len(lines) <= 11
    assert "10.0/10.0 s sim" in lines[-1] and "done in" in lines[-1]
    logging.getLogger("tensim.test").warning("a warning for the run log")
    assert "a warning for the run log" in RUN_LOG.lines[-1]
    RUN_LOG.lines.clear()


def test_progress_bar_shows_rate_and_time_left() -> None:
    bar = Progress("learn", unit="evals", rate_label=" evals/s")
    line = bar.line(25.0, 100.0, elapsed=50.0)
    # 25 evaluations in 50 s: 0.5 per second, 75 to go: 150 s
    assert "25.0/100.0 evals" in line and "0.5 evals/s" in line and "2 min 30 s left" in line
    assert _duration(7500) == "2 h 05 min" and _duration(12.34) == "12.3 s"


def test_no_figures_writes_the_folder_without_any_png(tmp_path: Path, capsys) -> None:
    out = tmp_path / "run"
    assert main(["--quiet", "simulate", "prism3", "--duration", "0.05", "--no-figures",
                 "--out", str(out)]) == 0
    assert f"wrote {out}/ (summary.json, trajectory.parquet, no figures)" in capsys.readouterr().out
    assert not list(out.glob("*.png"))  # neither the run's figures nor the report's frame
    assert (out / "report.html").is_file() and (out / "trajectory.parquet").is_file()
    assert json.loads((out / "summary.json").read_text())["figures"] == []
    # an experiment whose figures do not go through a drawer says so
    assert main(["experiment", "drag", "--no-figures", "--out", str(tmp_path / "d")]) == 2
