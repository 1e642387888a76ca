"""Self-contained HTML reports (figures inlined) and the run folders of compare and sysid."""

from __future__ import annotations

import base64
import html
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from tensim import __version__
from tensim._files import write_json, write_text
from tensim.hardware.compare import CableErrors, Comparison
from tensim.hardware.plots import plot_overlay, plot_system
from tensim.hardware.sensor import save_measurement
from tensim.hardware.sysid import SysidResult
from tensim.structure import save_structure

_STYLE = """body{font-family:sans-serif;max-width:1300px;margin:2em auto;color:#222}
table{border-collapse:collapse;margin:1em 0;font-size:14px}
th,td{border:1px solid #bbb;padding:3px 8px;text-align:right}
th{background:#eee}td:first-child,th:first-child{text-align:left}
.headline{font-size:20px;margin:0.5em 0}img{max-width:100%}"""

_ERROR_COLUMNS = (("max_error_percent", "max-tension error [%]"),
                  ("max_hardware_N", "max hardware [N]"), ("max_simulated_N", "max sim [N]"),
                  ("rmse_N", "RMSE [N]"), ("correlation", "correlation"),
                  ("pretension_offset_N", "pretension offset [N]"),
                  ("amplitude_ratio", "amplitude ratio sim/hw"))


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return "-" if value != value else f"{value:.4g}"
    return html.escape(str(value))


def table(headers: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    """An HTML table."""
    head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{_cell(v)}</td>" for v in row) + "</tr>"
                   for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def error_table(comparison: Comparison) -> str:
    """The system row, then one row per cable, of the error figures."""

    def row(name: str, e: CableErrors) -> list[Any]:
        return [name, *(getattr(e, key) for key, _ in _ERROR_COLUMNS)]

    rows = [row("system (max over cables)", comparison.system_errors())]
    rows += [row(c, e) for c, e in comparison.cable_errors().items()]
    return table(["cable", *(label for _, label in _ERROR_COLUMNS)], rows)


def headline(comparison: Comparison) -> str:
    """The paper's figure in one line."""
    e = comparison.system_errors()
    return (f"<p class='headline'>Error on the maximum system tension: "
            f"<b>{e.max_error_percent:+.2f} %</b> (hardware {e.max_hardware_N:.2f} N, "
            f"simulation {e.max_simulated_N:.2f} N); RMSE {e.rmse_N:.3f} N, correlation "
            f"{e.correlation:.3f}; time offset {comparison.offset_s * 1000:.1f} ms</p>")


def image(path: Path, alt: str) -> str:
    """An <img> with the PNG inlined, so the page stands alone."""
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f"<img alt='{html.escape(alt)}' src='data:image/png;base64,{data}'>"


def page(title: str, sections: Sequence[str]) -> str:
    """A complete HTML document."""
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}"
            f"</title><style>{_STYLE}</style></head><body><h1>{html.escape(title)}</h1>"
            + "\n".join(sections)
            + f"<p style='color:#777'>tensim {__version__}</p></body></html>\n")


def comparison_section(comparison: Comparison, out: Path, stem: str, title: str) -> str:
    """Headline, error table and overlay figures of one comparison (figures written to out)."""
    overlay = plot_overlay(comparison, out / f"{stem}.png", title=title)
    system = plot_system(comparison, out / f"{stem}_system.png", title=title)
    return (f"<h2>{html.escape(title)}</h2>{headline(comparison)}{error_table(comparison)}"
            f"<p>Hardware in red, simulation in black, hardware setpoint in blue.</p>"
            f"{image(system, 'max system tension')}{image(overlay, 'tension per cable')}")


def write_comparison(out: Path, comparison: Comparison, info: dict[str, Any], title: str,
                     mocap: dict[str, float] | None = None) -> dict[str, Any]:
    """Writes ``report.html``, the figures and ``summary.json`` (last) into ``out``.

    Args:
        out: output folder.
        comparison: the aligned tensions.
        info: settings to record (log, model, controller, ...).
        title: page title.
        mocap: node -> RMS displacement error [m], for logs with motion capture.

    Returns:
        The summary written.
    """
    out.mkdir(parents=True, exist_ok=True)
    sections = [comparison_section(comparison, out, "overlay", title)]
    if mocap:
        sections += ["<h2>Motion capture</h2>", table(
            ["node", "RMS displacement error [mm]"], [[n, 1000 * e] for n, e in mocap.items()])]
    sections += ["<h2>Setup</h2>", table(["setting", "value"], [[k, v] for k, v in info.items()])]
    write_text(out / "report.html", page(title, sections))
    summary = {**info, **comparison.summary(), "tensim_version": __version__,
               "files": ["report.html", "overlay.png", "overlay_system.png", "summary.json"]}
    if mocap:
        summary["mocap_displacement_rmse_m"] = mocap
    write_json(out / "summary.json", summary)
    return summary


def parameter_table(parameters: dict[str, dict[str, Any]]) -> str:
    """Fitted against nominal values, with standard errors and bounds."""
    rows = []
    for name, p in parameters.items():
        change = (100.0 * (p["fitted"] - p["nominal"]) / p["nominal"]) if p["nominal"] else None
        rows.append([name, p["unit"], p["kind"], p["nominal"], p["start"], p["fitted"],
                     "-" if p["stderr"] is None else p["stderr"],
                     "-" if change is None else f"{change:+.1f} %",
                     f"[{p['bounds'][0]:.4g}, {p['bounds'][1]:.4g}]"])
    return table(["parameter", "unit", "kind", "nominal", "start", "fitted", "std. error",
                  "fitted vs nominal", "bounds"], rows)


def write_sysid(out: Path, result: SysidResult, sources: Sequence[str], info: dict[str, Any]
                ) -> dict[str, Any]:
    """Writes the fitted model, the report and ``summary.json`` (last) into ``out``.

    Args:
        out: output folder.
        result: the fit.
        sources: the logs' names, in ``result`` order.
        info: settings to record (model, controller, ...).

    Returns:
        The summary written.
    """
    out.mkdir(parents=True, exist_ok=True)
    save_structure(result.structure, out / "fitted_structure.yaml")
    save_measurement(out / "measurement.json", result.sensor, result.vstar_scale)
    summary = result.summary()
    v = summary["validation"]
    verdict = (f"<p>RMSE on the validation samples ({v['window_s']}): nominal "
               f"{v['nominal_rmse_N']:.4g} N, fitted {v['fitted_rmse_N']:.4g} N."
               + (" The fit is worse there: the nominal model was written.</p>"
                  if result.kept_nominal else "</p>"))
    gap = verdict + table(
        ["", "RMSE [N]", "max-system-tension error [%], whole run (abs, mean over logs)",
         "the same after settling"],
        [["nominal model", summary["rmse_before_N"],
          summary["max_system_tension_error_before_percent"],
          summary["max_settled_system_tension_error_before_percent"]],
         ["fitted model", summary["rmse_after_N"],
          summary["max_system_tension_error_after_percent"],
          summary["max_settled_system_tension_error_after_percent"]]])
    sections = ["<h2>Parameters</h2>", parameter_table(summary["parameters"]),
                "<p>Standard errors: the larger of the independent-sample and the "
                "per-reading error, counted over the effective sample size n_eff = T / "
                "(2 tau) of the residuals' correlation time tau (residuals are correlated "
                "in time, so counting every sample as independent understates the "
                "uncertainty); intervals use Student's t.</p>",
                "<h2>The gap before and after</h2>", gap]
    for k, (source, before, after) in enumerate(zip(sources, result.before, result.after,
                                                    strict=True), start=1):
        sections.append(comparison_section(before, out, f"before_{k}",
                                           f"log {k} ({Path(source).name}): nominal model"))
        sections.append(comparison_section(after, out, f"after_{k}",
                                           f"log {k} ({Path(source).name}): fitted model"))
    sections += ["<h2>Setup</h2>", table(["setting", "value"], [[k, v] for k, v in info.items()])]
    write_text(out / "report.html", page("System identification", sections))
    summary = {**info, **summary, "tensim_version": __version__,
               "files": ["fitted_structure.yaml", "measurement.json", "report.html",
                         "summary.json"]}
    write_json(out / "summary.json", summary)
    return summary
