"""The urban bench's timing table: the two planners alternated step by step fly what each flies alone, and every
time is given with its spread."""

from __future__ import annotations

from benchmarks.urban import run_closed_loop, with_vehicles
from benchmarks.urban_timing import SCALING_PLANNERS, scaling_lines, scaling_row
from gcs.config.world import build_world
from gcs.scenarios import load_scenario

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)


def test_alternated_planners_fly_as_alone_and_report_median_iqr_p99() -> None:
    row = scaling_row(SCENARIO, WORLD, 3, seed=4, duration_s=8.0, motion=None)
    for name in SCALING_PLANNERS:
        alone = run_closed_loop(with_vehicles(SCENARIO, 3), WORLD, name, 4, duration_s=8.0, stall=None, clock=None)
        assert row[name]["seen_any"] == alone.seen_any, name
        timing = row[name]
        assert 0.0 < timing["decision_ms_p25"] <= timing["decision_ms_median"] <= timing["decision_ms_p75"]
        assert timing["decision_ms_p75"] <= timing["decision_ms_p99"]
    assert 0.0 < row["ga_over_sight_p25"] <= row["ga_over_sight"] <= row["ga_over_sight_p75"]
    text = "\n".join(scaling_lines([row]))
    assert "alternated" in text and f"{row['ga_over_sight']:.1f}" in text
