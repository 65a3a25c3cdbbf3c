"""The multitarget bench's methods stepped alternately keep their own state: alternated, each gives the tracks it
gives run alone on the same scans, and one time per scan."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks import multitarget as mt
from benchmarks.multitarget_methods import run_methods

pytest.importorskip("stonesoup", reason="the peers need the 'peers' extra")


def test_alternated_methods_match_each_run_alone() -> None:
    from gcs.config.world import build_world
    from gcs.engine.tracker_factory import filter_sensor_models
    from gcs.scenarios import load_scenario

    scenario = load_scenario("wang2012_urban")
    world = build_world(scenario)
    sensor = filter_sensor_models(scenario)[0]
    config = mt.BenchConfig(targets=2, steps=12, warm_up=2)
    rng = np.random.default_rng(3)
    scene = mt.make_scene(world, [v.altitude_m for v in scenario.vehicles][:3], config, rng)
    scans = mt.make_scans(world, scene, sensor, scenario.sensor.max_range_m, config, rng)
    density = mt.clutter_density(world, scene, sensor, scenario.sensor.max_range_m, config.clutter)
    methods = ["jpda", "stonesoup_jpda", "stonesoup_gnn"]
    together = run_methods(scans, scene, config, methods, world, scenario, sensor.target_height_m, density)
    for name in methods:
        (alone,) = run_methods(scans, scene, config, [name], world, scenario, sensor.target_height_m,
                               density).values()
        assert together[name].track_ids == alone.track_ids, name
        for a, b in zip(together[name].track_xy, alone.track_xy):
            np.testing.assert_array_equal(a, b)
        assert len(together[name].seconds) == config.steps
    assert sum(len(ids) for ids in together["stonesoup_jpda"].track_ids) > 0  # the peer confirmed tracks
