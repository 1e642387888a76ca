"""The benchmark's machinery (its figures are printed by `tensim bench`, never asserted here)."""

from __future__ import annotations

import math

from tensim.bench import bench_model
from tensim.terrain import Rough


def test_a_bench_case_runs_on_a_terrain_and_names_it():
    ground = Rough(roughness=0.005, correlation=0.1, seed=2, size=1.0, resolution=0.05)
    case = bench_model("prism3", duration=0.05, repeats=1, terrain=ground)
    assert case.name == "prism3 on rough"
    for figure in (case.real_time_factor, case.engine_alone_real_time_factor,
                   case.us_per_step, case.engine_us_per_step):
        assert math.isfinite(figure) and figure > 0
    assert bench_model("prism3", 0.05, 1, controlled=False).name == "prism3 (passive)"
