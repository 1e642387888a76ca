"""docs/gpu.md's throughput table is what ``tensim bench --backend warp`` printed for the JSON
committed beside it (the run needs a GPU, so the page cannot be rerun here; this test keeps
the page and the measured figures from drifting apart)."""

from __future__ import annotations

import json
import re
from pathlib import Path

from tensim.benchmarks.warp import format_row

ROOT = Path(__file__).resolve().parent.parent


def test_the_gpu_table_is_the_benchmark_output():
    page = (ROOT / "docs" / "gpu.md").read_text()
    block = re.search(r"<!-- gpu-bench-h200 -->\n```\n(.*?)```", page, re.S)
    assert block is not None
    report = json.loads((ROOT / "docs" / "figures" / "gpu_bench_h200.json").read_text())
    printed = [format_row(row) for row in report["rows"]]
    printed.append(f"device: {report['device']}; CPU engine on {report['host_cores']} cores")
    assert block.group(1).rstrip("\n").split("\n") == printed
