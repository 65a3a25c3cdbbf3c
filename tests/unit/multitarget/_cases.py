"""Random cases shared by the multi-target tests: tracks, vehicles and detections from a seeded Generator."""

from __future__ import annotations

import numpy as np

from gcs.core.models.sensor import SensorModel

RANGE_BEARING = SensorModel.range_bearing(5.0, 0.01, 0.01)
RANGE_AZIMUTH = SensorModel(("range", "azimuth"), (5.0, 0.01))
BEARING_ONLY = SensorModel.bearing_only(0.01, 0.01)
AZIMUTH_ONLY = SensorModel.bearing_only(0.01)
SENSORS = (RANGE_BEARING, RANGE_AZIMUTH, BEARING_ONLY, AZIMUTH_ONLY)


def random_covariance(rng: np.random.Generator, stds: np.ndarray) -> np.ndarray:
    """A covariance with the given standard deviations and random correlations."""
    a = rng.normal(size=(stds.size, stds.size))
    corr = a @ a.T + stds.size * np.eye(stds.size)
    d = 1.0 / np.sqrt(np.diag(corr))
    return (d[:, None] * corr * d[None, :]) * np.outer(stds, stds)


def random_tracks(rng: np.random.Generator, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Means (T, 4) within 1.5 km of the origin and covariances (T, 4, 4) of metres to tens of metres."""
    mean = np.column_stack([rng.uniform(-1500, 1500, (count, 2)), rng.normal(0, 8, (count, 2))])
    cov = np.stack([random_covariance(rng, np.concatenate([rng.uniform(3, 40, 2), rng.uniform(1, 6, 2)]))
                    for _ in range(count)])
    return mean, cov


def random_vehicle(rng: np.random.Generator, sensor: SensorModel, targets: np.ndarray, clutter: int,
                   uncertain: bool) -> tuple[SensorModel, np.ndarray, np.ndarray, np.ndarray]:
    """One vehicle's detections of ``targets`` (k, 2) plus ``clutter`` false ones, shuffled: (sensor, z, xyz, pcov)."""
    vehicle = np.array([rng.uniform(-2500, 2500), rng.uniform(-2500, 2500), rng.uniform(150, 400)])
    points = np.vstack([targets + rng.normal(0, 15, targets.shape),
                        rng.uniform(-2000, 2000, (clutter, 2))])[rng.permutation(targets.shape[0] + clutter)]
    z = sensor.measure(points, vehicle[None, :]) + rng.normal(size=(points.shape[0], sensor.dim)) * np.array(sensor.std)
    xyz = np.tile(vehicle, (points.shape[0], 1))
    if uncertain:
        pcov = np.stack([random_covariance(rng, rng.uniform(0.5, 5.0, 3)) for _ in range(points.shape[0])])
    else:
        pcov = np.zeros((points.shape[0], 3, 3))
    return sensor, z, xyz, pcov
