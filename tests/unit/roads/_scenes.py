"""Shared pieces of the road-tracker tests: a T-junction, both trackers, and detections made with the simulator's
own measurement formulas (sim_vehicles.truth.sensor, never the filters' h(x))."""

from __future__ import annotations

import numpy as np

from gcs.core.filters.estimate import GaussianEstimate
from gcs.core.models.sensor import SensorModel
from gcs.core.roads import RoadGraph
from gcs.core.roads.mixture import RoadMixtureFilter
from gcs.core.roads.particle import RoadParticleFilter
from sim_vehicles.truth.sensor import exact_measurements, noisy_measurements

SENSOR = SensorModel.range_bearing(10.0, 0.05, 0.05)
BEARINGS = SensorModel.bearing_only(0.02, 0.02)
T_JUNCTION = RoadGraph.from_segments([(0.0, -300.0), (0.0, 0.0), (0.0, 0.0)], [(0.0, 0.0), (-300.0, 0.0), (300.0, 0.0)])
"""A stem from the south meets an east-west road at the origin."""
TRACKERS = {
    "particle": lambda graph: RoadParticleFilter(graph, particles=2000),
    "mixture": lambda graph: RoadMixtureFilter(graph),
}


def edge_of(graph: RoadGraph, a, b) -> int:
    tail, head = graph.nodes[graph.tail], graph.nodes[graph.head]
    return int(np.flatnonzero(np.all(np.isclose(tail, a), axis=1) & np.all(np.isclose(head, b), axis=1))[0])


def mass_on(estimate, edge: int) -> float:
    edges, weights = estimate.branch_weights()
    return float(weights[edges == edge].sum())


def detections(target_xy, vehicles_xyz, sensor: SensorModel, rng: np.random.Generator):
    """One group ``(sensor, z (V, m), xyz (V, 3), None)`` of every vehicle's noisy detection of the target."""
    vehicles = np.asarray(vehicles_xyz, dtype=np.float64)
    target = np.broadcast_to(np.append(np.asarray(target_xy, dtype=np.float64), sensor.target_height_m), vehicles.shape)
    values = noisy_measurements(exact_measurements(target, vehicles), sensor.components, sensor.std,
                                np.ones(len(vehicles)), rng)
    return [(sensor, values, vehicles, None)]


def on_stem(stamp_ns: int = 0) -> GaussianEstimate:
    """A car 100 m south of the junction driving north at 10 m/s, known well."""
    return GaussianEstimate(np.array([0.0, -100.0, 0.0, 10.0]), np.diag([9.0, 9.0, 0.25, 0.25]), stamp_ns)
