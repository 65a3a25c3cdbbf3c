"""The wang2012 closed loop in one process, through the engine: determinism, paired runs, honest sensing,
the vehicles flying the engine's plans, tracking."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.urban import run_closed_loop, with_vehicles
from gcs.config.world import build_world
from gcs.scenarios import load_scenario

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)


def _run(planner: str, seed: int = 7, duration: float = 40.0, **kw):
    return run_closed_loop(SCENARIO, WORLD, planner, seed, duration_s=duration, clock=None, **kw)


def test_runs_are_deterministic_without_a_clock() -> None:
    a = _run("ga_k5", generations=8)
    b = _run("ga_k5", generations=8)
    np.testing.assert_array_equal(a.seen, b.seen)
    np.testing.assert_array_equal(a.vehicle_xy, b.vehicle_xy)
    np.testing.assert_array_equal(a.errors_m, b.errors_m)


def test_paired_runs_share_the_target_path() -> None:
    runs = [_run(name, generations=5) for name in ("ga_k5", "ga_k0", "orbit", "pursuit")]
    for other in runs[1:]:
        np.testing.assert_array_equal(runs[0].target_xy, other.target_xy)
    assert not np.array_equal(runs[2].vehicle_xy, runs[3].vehicle_xy)


def test_detections_match_the_worlds_line_of_sight() -> None:
    record = _run("pursuit", duration=60.0)
    altitudes = np.array([v.altitude_m for v in SCENARIO.vehicles])
    vehicles = np.concatenate([record.vehicle_xy, np.broadcast_to(altitudes[:, None], record.vehicle_xy.shape[:-1] + (1,))], -1)
    target = np.concatenate([record.target_xy, np.zeros((len(record.target_xy), 1))], -1)[:, None, :]
    in_range = np.linalg.norm(vehicles - target, axis=-1) <= SCENARIO.sensor.max_range_m
    expected = WORLD.line_of_sight(np.broadcast_to(target, vehicles.shape), vehicles) & in_range
    np.testing.assert_array_equal(record.seen, expected)
    assert 0 < record.seen.sum() < record.seen.size  # the city does occlude


def test_white_noise_target_stays_on_open_ground_and_street_target_on_streets() -> None:
    free = _run("orbit", duration=120.0)
    assert not WORLD.buildings.contains_xy(free.target_xy).any()
    assert np.all((free.target_xy >= 0) & (free.target_xy <= 3000))
    streets = _run("orbit", duration=120.0, motion="streets")
    assert WORLD.streets.on_street(streets.target_xy).all()
    assert np.ptp(streets.target_xy, axis=0).max() > 300  # it drives somewhere


@pytest.mark.slow
def test_the_loop_tracks_the_target() -> None:
    record = _run("ga_k5", duration=60.0, generations=40)
    assert record.seen_any >= 54  # >= 90% of steps seen by at least one UAV
    assert record.rmse_m < 25.0
    baseline = _run("pursuit", duration=60.0)
    assert baseline.seen_any >= 54 and baseline.rmse_m < 25.0


def test_more_vehicles_are_added_on_a_ring() -> None:
    bigger = with_vehicles(SCENARIO, 6)
    assert [v.id for v in bigger.vehicles] == [f"uav{i}" for i in range(1, 7)]
    assert len({v.sysid for v in bigger.vehicles}) == 6
    record = run_closed_loop(bigger, WORLD, "orbit", 3, duration_s=10.0, clock=None)
    assert record.seen.shape == (10, 6)


def test_scenario_stall_setting_reaches_the_ga_and_can_be_overridden() -> None:
    import msgspec

    from benchmarks.urban import with_budget
    from gcs.engine.tracker_factory import tracker_config

    stalling = msgspec.structs.replace(SCENARIO, planner=msgspec.structs.replace(SCENARIO.planner, stall_generations=7))
    assert tracker_config(stalling, WORLD, "ga_k5").planner.stall == 7
    assert tracker_config(with_budget(stalling, stall=None), WORLD, "ga_k5").planner.stall is None
    assert tracker_config(with_budget(SCENARIO, generations=9), WORLD, "ga_k5").planner.generations == 9
    assert with_budget(SCENARIO) is SCENARIO
    assert tracker_config(SCENARIO, WORLD, "ga_k0").planner.stall is None
    assert tracker_config(SCENARIO, WORLD, "ga_k0").predict_ahead is False
