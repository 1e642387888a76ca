"""The benchmark's machinery (its figures are printed by `tensim bench`, never asserted here)."""

from __future__ import annotations

import math

from tensim.bench import Timing, bench_model
from tensim.cli.bench import format_table
from tensim.terrain import Rough


def test_a_bench_case_runs_on_a_terrain_and_names_it():
    ground = Rough(roughness=0.005, correlation=0.1, seed=2, size=1.0, resolution=0.05)
    case = bench_model("prism3", duration=0.05, repeats=2, terrain=ground)
    assert case.name == "prism3 on rough"
    assert len(case.tensim.cpu) == len(case.engine.wall) == 2  # every run kept
    for figure in case.figures().values():
        assert math.isfinite(figure) and figure > 0
    assert bench_model("prism3", 0.05, 1, controlled=False).name == "prism3 (passive)"
    assert "prism3 on rough" in format_table([{"name": case.name, **case.figures()}], 2)


def test_a_bench_case_with_contact_cables_names_them():
    case = bench_model("prism3", duration=0.05, repeats=1, controlled=False,
                       contact_tags=("bottom",))
    assert case.name == "prism3 (passive), contact cables bottom"
    assert all(math.isfinite(f) and f > 0 for f in case.figures().values())


def test_timings_give_best_and_median_per_kind():
    timing = Timing(cpu=(30.0, 10.0, 20.0), wall=(12.0, 40.0, 11.0))
    assert timing.best() == 10.0 and timing.median() == 20.0
    assert timing.best("wall") == 11.0 and timing.median("wall") == 12.0
