"""The estimators compared: the scenario's own target estimator, and the road trackers of :mod:`gcs.core.roads`.

Each runs a :class:`~benchmarks.roads.scene.Run` step by step as the ground
station would: fuse the step's detections (the track starts at the first
range detection, :func:`gcs.core.tracker.initial_estimate`), then predict the
k+1..k+n horizon the planner would be given. Recorded per step: the point
estimate (the moment-matched mean for the road trackers, the DUIF's mean for the
baseline: the same kind of point for every method) and its covariance, the
time to fuse and the time to predict the horizon (wall clock, ``time.perf_counter``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.uif import NS_PER_S
from gcs.core.roads import RoadGraph, roads_from_street_grid
from gcs.core.roads.mixture import RoadMixtureFilter
from gcs.core.roads.particle import RoadParticleFilter
from gcs.core.roads.sensing import Looks, table_sees
from gcs.core.tracker import Detection, fuse, initial_estimate, prediction
from gcs.engine.tracker_factory import filter_sensor_models, scenario_planner, tracker_config
from benchmarks.roads.scene import Run, Scene

__all__ = ["Trace", "ESTIMATORS", "run_estimator"]

SIGHT_REACH_M = 600.0
"""How far the filters' sight table looks for roofs (the table's default)."""


@dataclass(frozen=True)
class Trace:
    """Per step (K): mean (K, 4) and covariance (K, 4, 4), NaN before the track starts; seconds to fuse and to
    predict the horizon (NaN before the track starts)."""

    mean: NDArray[np.float64]
    cov: NDArray[np.float64]
    fuse_s: NDArray[np.float64]
    horizon_s: NDArray[np.float64]


def _empty(steps: int) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    return (np.full((steps, 4), np.nan), np.full((steps, 4, 4), np.nan), np.full(steps, np.nan),
            np.full(steps, np.nan))


def run_baseline(scene: Scene, run: Run) -> Trace:
    """What :func:`gcs.core.tracker.fuse` and :func:`gcs.core.tracker.prediction` give for the scenario."""
    scenario = scene.scenario
    config = tracker_config(scenario, None, scenario_planner(scenario))
    mean, cov, fuse_s, horizon_s = _empty(len(run.truth_xy))
    estimate = None
    for k, step in enumerate(run.detections):
        stamp = int(round(k * run.step_s * NS_PER_S))
        detections = [Detection(v, run.vehicle_xyz[k, v], z) for v, z in step]
        started = time.perf_counter()
        estimate = fuse(config, estimate, stamp, detections)
        fused = time.perf_counter()
        if estimate is None:
            continue
        prediction(config, estimate)
        horizon_s[k], fuse_s[k] = time.perf_counter() - fused, fused - started
        mean[k], cov[k] = estimate.mean[:4], estimate.cov[:4, :4]
    return Trace(mean, cov, fuse_s, horizon_s)


def run_road(scene: Scene, run: Run, make: Callable[[RoadGraph], object], negative: bool = True) -> Trace:
    """A road tracker (``make(graph)``) on the city's street graph; ``negative`` uses the looks."""
    scenario, world = scene.scenario, scene.world
    graph = world.roads if getattr(world, "roads", None) is not None else roads_from_street_grid(world.streets)
    tracker = make(graph)
    sensors = filter_sensor_models(scenario)
    altitude = min(v.altitude_m for v in scenario.vehicles)
    max_range = min(scenario.sensor_for(v).max_range_m for v in scenario.vehicles)
    sees = table_sees(world.sight_table(altitude, sensors[0].target_height_m, SIGHT_REACH_M), max_range)
    estimator = scenario.estimator
    horizon = scenario.planner.sight.horizon_steps
    rng = np.random.default_rng([run.seed, 3])
    mean, cov, fuse_s, horizon_s = _empty(len(run.truth_xy))
    estimate = None
    for k, step in enumerate(run.detections):
        stamp = int(round(k * run.step_s * NS_PER_S))
        started = time.perf_counter()
        groups: dict = {}
        for v, z in step:
            groups.setdefault(sensors[v], []).append((z, run.vehicle_xyz[k, v]))
        stacked = [(s, np.array([z for z, _ in g]), np.array([x for _, x in g]), None) for s, g in groups.items()]
        looks = Looks(run.vehicle_xyz[k], run.seen[k], sees) if negative else None
        if estimate is None:
            if not step:
                continue
            first = Detection(step[0][0], run.vehicle_xyz[k, step[0][0]], step[0][1])
            initial = initial_estimate(first, sensors[first.vehicle], stamp, estimator.initial_position_std_m,
                                       estimator.initial_velocity_std_mps, 4)
            estimate = tracker.update(tracker.start(initial, rng), stacked, looks, rng)
        else:
            estimate = tracker.step(estimate, stamp, stacked, looks, rng)
        fused = time.perf_counter()
        tracker.horizon(estimate, run.step_s, horizon, rng)
        horizon_s[k], fuse_s[k] = time.perf_counter() - fused, fused - started
        mean[k], cov[k] = estimate.mean[:4], estimate.cov[:4, :4]
    return Trace(mean, cov, fuse_s, horizon_s)


ESTIMATORS: dict[str, Callable[[Scene, Run], Trace]] = {
    "duif": run_baseline,
    "road_pf": lambda scene, run: run_road(scene, run, RoadParticleFilter),
    "road_gm": lambda scene, run: run_road(scene, run, RoadMixtureFilter),
    "road_pf_no_looks": lambda scene, run: run_road(scene, run, RoadParticleFilter, negative=False),
}
"""The scenario's estimator (``duif`` in all three) and the candidates; ``road_pf_no_looks`` is the particle
filter without negative information, to measure what the looks bring."""


def run_estimator(name: str, scene: Scene, run: Run) -> Trace:
    """Run the estimator ``name`` of :data:`ESTIMATORS`."""
    return ESTIMATORS[name](scene, run)
