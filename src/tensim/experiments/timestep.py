"""How much the physics step and the contact solver change the predicted cable forces.

The disturbance test runs at 250, 1000 and 4000 Hz; each cable's maximum tension is compared
with the 1000 Hz run. The same comparison at 1000 Hz, varying the contact time constant, gives
the sensitivity to the contact solver's settings.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from tensim.experiments.disturbance import DURATION, run_disturbance
from tensim.model import WorldOptions
from tensim.runs import finish_run
from tensim.viz.plots import save_figure

RATES_HZ = (250, 1000, 4000)
REFERENCE_HZ = 1000
CONTACT_TIMECONSTS_S = (0.01, 0.02, 0.04)  # 0.02 s is the default


def _percent_change(values: np.ndarray, reference: np.ndarray) -> np.ndarray:
    return 100.0 * (values - reference) / reference


def run_timestep_study(announce: Callable[[str], None] | None = None, *,
                       duration: float = DURATION,
                       progress: Callable[[float, float], None] | None = None
                       ) -> dict[str, Any]:
    """Runs the study and returns its summary (JSON-ready).

    Args:
        announce: called with a line naming each run as it starts.
        duration: simulated time of each of the five disturbance runs [s].
        progress: called as progress(done_s, total_s) over all five runs' simulated time.
    """
    runs = len(RATES_HZ) + len(CONTACT_TIMECONSTS_S) - 1
    done = [0.0]

    def run(**kwargs: Any) -> tuple[Any, dict[str, Any]]:
        def each(t: float, _: float) -> None:
            if progress:
                progress(done[0] + t, runs * duration)

        outcome = run_disturbance(duration=duration, progress=each, **kwargs)
        done[0] += duration
        return outcome

    peaks: dict[str, np.ndarray] = {}
    cables: tuple[str, ...] = ()
    rtf: dict[str, float] = {}
    reference_summary: dict[str, Any] = {}
    for hz in RATES_HZ:
        if announce:
            announce(f"disturbance test at {hz} Hz")
        result, summary = run(dt=1.0 / hz)
        peaks[str(hz)], cables, rtf[str(hz)] = result.peak_tension, result.cables, \
            result.real_time_factor
        if hz == REFERENCE_HZ:
            reference_summary = summary
    contact: dict[str, np.ndarray] = {}
    for tc in CONTACT_TIMECONSTS_S:
        if tc == WorldOptions().contact_timeconst:
            contact[str(tc)] = peaks[str(REFERENCE_HZ)]
            continue
        if announce:
            announce(f"disturbance test with contact time constant {tc} s")
        result, _ = run(world=WorldOptions(contact_timeconst=tc))
        contact[str(tc)] = result.peak_tension
    reference = peaks[str(REFERENCE_HZ)]
    per_cable = {hz: _percent_change(p, reference) for hz, p in peaks.items()
                 if hz != str(REFERENCE_HZ)}
    per_contact = {tc: _percent_change(p, reference) for tc, p in contact.items()
                   if tc != str(WorldOptions().contact_timeconst)}

    def named(values: np.ndarray) -> dict[str, float]:
        return {c: round(float(v), 4) for c, v in zip(cables, values, strict=True)}

    return {
        "experiment": "timestep",
        "model": "tetraspine3",
        "reference_hz": REFERENCE_HZ,
        # the headline keys describe the reference run; the per-rate figures follow
        **{key: reference_summary[key] for key in ("duration_s", "dt_s", "wall_s",
                                                   "max_tension_N", "max_system_tension_N",
                                                   "com_displacement_m", "real_time_factor")},
        "max_tension_by_rate_N": {hz: named(p) for hz, p in peaks.items()},
        "change_percent": {hz: named(v) for hz, v in per_cable.items()},
        "max_change_percent": {hz: round(float(np.abs(v).max()), 4)
                               for hz, v in per_cable.items()},
        "contact_timeconst_change_percent": {tc: named(v) for tc, v in per_contact.items()},
        "contact_max_change_percent": {tc: round(float(np.abs(v).max()), 4)
                                       for tc, v in per_contact.items()},
        "max_system_tension_by_rate_N": {hz: round(float(p.max()), 4)
                                         for hz, p in peaks.items()},
        "real_time_factor_by_rate": {hz: round(v, 2) for hz, v in rtf.items()},
    }


def timestep_figure(summary: dict[str, Any]) -> Figure:
    """A bar chart of each cable's max-tension change against the reference rate."""
    changes = summary["change_percent"]
    cables = list(next(iter(changes.values())))
    x = np.arange(len(cables))
    fig = Figure(figsize=(10, 3.5))
    ax = fig.subplots()
    width = 0.8 / len(changes)
    for k, (hz, values) in enumerate(changes.items()):
        ax.bar(x + k * width, [values[c] for c in cables], width, label=f"{hz} Hz")
    ax.axhline(0, color="black", lw=0.6)
    ax.set_xticks(x + width / 2, cables, rotation=45, ha="right", fontsize=8)
    ax.set_ylabel(f"max tension change vs {summary['reference_hz']} Hz [%]")
    ax.legend()
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return fig


def write_timestep_study(out: Path, summary: dict[str, Any]) -> Path:
    """Writes ``summary.json`` and :func:`timestep_figure`."""
    out.mkdir(parents=True, exist_ok=True)
    save_figure(timestep_figure(summary), out / "timestep.png")
    finish_run(out, {**summary, "figures": ["timestep.png"]})  # log, report, summary.json
    return out
