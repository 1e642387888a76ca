"""Run folders: the recorded time series, a summary and figures, each written atomically."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tensim import __version__
from tensim._files import write_json
from tensim.sim import SimulationResult


def write_run(out: Path, result: SimulationResult, summary: dict[str, Any]) -> Path:
    """Writes ``trajectory.parquet`` then ``summary.json`` (last, so its presence means done)."""
    out.mkdir(parents=True, exist_ok=True)
    result.trajectory.to_parquet(out / "trajectory.parquet")
    write_json(out / "summary.json", {**summary, "tensim_version": __version__})
    return out
