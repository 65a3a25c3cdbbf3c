"""gcs-bench sharing's loop: what it counts as a target in a UAV's field, and where its UAVs fly."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks import multitarget as mt
from benchmarks import sharing
from gcs.config.world import build_world
from gcs.engine.tracker_factory import tracker_config
from gcs.scenarios import load_scenario

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)
CONFIG = tracker_config(SCENARIO, WORLD, "sight")
ALTITUDES = np.array([v.altitude_m for v in SCENARIO.vehicles])
SHORT = sharing.SharingConfig(mt.BenchConfig(targets=3, steps=24, warm_up=4))


def test_the_orbit_mode_counts_the_steps_each_target_is_in_range_and_in_sight() -> None:
    run = sharing.fly_run("orbit", WORLD, SCENARIO, 5, SHORT)
    scene = mt.make_scene(WORLD, list(ALTITUDES), SHORT.scene, np.random.default_rng(5))
    height = CONFIG.sensors[0].target_height_m
    expected_targets, expected_uavs = np.zeros(3, dtype=int), np.zeros(3, dtype=int)
    for k in range(SHORT.scene.warm_up, SHORT.scene.steps):
        field = np.zeros((3, 3), dtype=bool)
        for v, uav in enumerate(scene.vehicle_xyz[k]):
            for j, (x, y) in enumerate(scene.truth_xy[k]):
                ground = np.array([x, y, height + 1.0])
                near = np.linalg.norm(uav - np.array([x, y, height])) <= CONFIG.max_range_m
                field[v, j] = near and bool(WORLD.line_of_sight(uav, ground))
        expected_targets += field.any(axis=0)
        expected_uavs += field.any(axis=1)
    np.testing.assert_array_equal(run.target_steps, expected_targets)
    np.testing.assert_array_equal(run.uav_steps, expected_uavs)
    assert run.plan_seconds == ()


@pytest.mark.parametrize("mode", ["sum", "assign"])
def test_planned_modes_plan_in_the_steps_they_have_a_track(mode) -> None:
    run = sharing.fly_run(mode, WORLD, SCENARIO, 5, SHORT)
    assert 0 < len(run.plan_seconds) <= SHORT.scene.steps - 1
    assert np.all(run.target_steps <= SHORT.scene.steps - SHORT.scene.warm_up)
    assert np.isfinite(run.gospa_m) and run.gospa_m >= 0.0


def test_an_unknown_mode_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown mode 'circle'"):
        sharing.fly_run("circle", WORLD, SCENARIO, 5, SHORT)


def test_the_loop_counts_every_detection_the_tracker_took_and_times_every_step() -> None:
    run = sharing.fly_run("assign", WORLD, SCENARIO, 5, SHORT)
    assert len(run.scan_seconds) == len(run.decision_seconds) == SHORT.scene.steps
    assert np.all(np.asarray(run.decision_seconds) >= np.asarray(run.scan_seconds))
    total = sum(run.decision_seconds) - sum(run.scan_seconds)
    assert total == pytest.approx(sum(run.plan_seconds), rel=1e-9, abs=1e-12)
    # each in-field target-step after the warm-up gives some UAV's detection with probability >= pd
    assert run.detections >= 0.5 * SHORT.scene.pd * run.target_steps.sum()


def test_more_uavs_than_the_fixed_orbits_fly_on_a_ring_around_the_city() -> None:
    orbits = mt.orbits(10)
    assert orbits[:3] == mt.ORBITS and len(orbits) == 10 and len(set(orbits)) == 10
    centres = np.array(orbits[3:])[:, :2]
    np.testing.assert_allclose(np.hypot(*(centres - 1500.0).T), mt.RING_RADIUS_M)
    assert mt.orbits(2) == mt.ORBITS[:2]
