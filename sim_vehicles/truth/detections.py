"""Detections of many ground targets by many vehicles, with missed detections and clutter (pure, seeded).

For the many-target trackers' tests and benches. One scan:

* truth ``j`` is detected by vehicle ``v`` with probability ``pd`` when it is within
  the sensor's field (slant range <= ``max_range_m``) and ``visible[v, j]`` (an
  occlusion mask, e.g. from the world's line of sight; all True when omitted);
* each vehicle also reports ``Poisson(clutter_rate)`` false detections, from points
  uniform over the ground disc its field covers: the points at the target height
  ``sensor.target_height_m`` within slant range ``max_range_m``, i.e. a disc of
  horizontal radius ``sqrt(max_range_m^2 - dz^2)`` under the vehicle;
* every detection is measured with this package's own formulas
  (:func:`~sim_vehicles.truth.sensor.exact_measurements`, never the filters'
  ``h(x)``; docs/design.md, the layers), plus Gaussian noise of the ``SensorModel``'s
  standard deviations (zuo2021 eq. 2 growth beyond ``reference_range_m`` at the true
  slant range when ``distance_dependent``); azimuth wrapped to (-pi, pi], elevation
  clipped to [-pi/2, pi/2], range floored at 0, as :class:`~sim_vehicles.truth.sensor.TargetSensor` does;
* each vehicle's list is shuffled and carries no identity: which truth (or clutter,
  -1) made each detection is returned apart, for scoring only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.models.sensor import SensorModel
from gcs.core.tracker import Detection
from sim_vehicles.truth.clutter import clutter_points, ground_disc_radius
from sim_vehicles.truth.sensor import exact_measurements, noisy_measurements

__all__ = ["CLUTTER", "Scan", "scan"]

CLUTTER = -1
"""The source index of a false detection."""


@dataclass(frozen=True)
class Scan:
    """One scan: per vehicle, its detections (shuffled) and, apart, the truth index of each (``CLUTTER`` for clutter)."""

    detections: tuple[list[Detection], ...]
    sources: tuple[NDArray[np.int64], ...]


def _measure(points_xy: NDArray[np.float64], vehicle: NDArray[np.float64], sensor: SensorModel,
             rng: np.random.Generator) -> NDArray[np.float64]:
    """Noisy measurements (k, m) of ground points (k, 2) from one vehicle (3,)."""
    points = np.column_stack([points_xy, np.full(len(points_xy), sensor.target_height_m)])
    exact = exact_measurements(points, np.broadcast_to(vehicle, points.shape))
    scale = np.ones(len(points))
    if sensor.distance_dependent:  # zuo2021 eq. (2) at the true slant range
        scale = np.maximum(exact[:, 0] / sensor.reference_range_m, 1.0)
    return noisy_measurements(exact, sensor.components, sensor.std, scale, rng)


def scan(truth_xy: ArrayLike, vehicle_xyz: ArrayLike, sensor: SensorModel, pd: float, clutter_rate: float,
         max_range_m: float, rng: np.random.Generator, visible: ArrayLike | None = None) -> Scan:
    """Detections of ground targets (N, 2) by vehicles (V, 3), ENU metres: see the module docstring.

    Parameters
    ----------
    truth_xy : array_like, shape (N, 2)
    vehicle_xyz : array_like, shape (V, 3)
    sensor : SensorModel
        Components, noise and target height of every vehicle's sensor.
    pd : float
        Probability of detection of a truth in the field and in sight, in [0, 1].
    clutter_rate : float
        Mean number of false detections per vehicle and scan (Poisson), >= 0.
    max_range_m : float
        Slant range of the sensor's field.
    rng : numpy.random.Generator
    visible : array_like of bool, shape (V, N), optional
        ``visible[v, j]``: vehicle ``v`` has a line of sight to truth ``j``.
    """
    truths = np.asarray(truth_xy, dtype=np.float64).reshape(-1, 2)
    vehicles = np.asarray(vehicle_xyz, dtype=np.float64).reshape(-1, 3)
    if not 0.0 <= pd <= 1.0 or clutter_rate < 0.0 or max_range_m <= 0.0:
        raise ValueError(f"need 0 <= pd <= 1, clutter_rate >= 0, max_range_m > 0; got {pd}, {clutter_rate}, {max_range_m}")
    sight = np.ones((len(vehicles), len(truths)), dtype=bool) if visible is None else np.asarray(visible, dtype=bool)
    if sight.shape != (len(vehicles), len(truths)):
        raise ValueError(f"visible must have shape (V, N) = {(len(vehicles), len(truths))}, got {sight.shape}")
    slant = np.sqrt(((truths[None, :, :] - vehicles[:, None, :2]) ** 2).sum(-1)
                    + (vehicles[:, None, 2] - sensor.target_height_m) ** 2)
    detected = sight & (slant <= max_range_m) & (rng.random(sight.shape) < pd)  # (V, N)
    radius = ground_disc_radius(vehicles, max_range_m, sensor.target_height_m)
    per_vehicle, sources = [], []
    for v, vehicle in enumerate(vehicles):
        clutter = clutter_points(vehicle[:2], float(radius[v]), clutter_rate, rng)
        k = len(clutter)
        seen = np.flatnonzero(detected[v])
        points = np.concatenate([truths[seen], clutter])
        source = np.concatenate([seen, np.full(k, CLUTTER)]).astype(np.int64)
        order = rng.permutation(len(points))
        values = _measure(points[order], vehicle, sensor, rng)
        per_vehicle.append([Detection(v, vehicle.copy(), z) for z in values])
        sources.append(source[order])
    return Scan(tuple(per_vehicle), tuple(sources))
