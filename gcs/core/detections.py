"""What a decision step's sensing gives the trackers: the detections, who sensed, and a track's first fix.

* :class:`Detection`: one vehicle's measurement, with where the vehicle was and how well it knew it;
* :class:`Sensing`: every vehicle that sensed at the step, detections or not (negative information);
* :func:`stack_detections`: a step's detections grouped by sensor model, as the DUIF and the road
  tracker fuse them (wang2012 eq. 14: one information contribution per group);
* :func:`initial_estimate`: a track from one range detection, eq. (4) inverted.

:mod:`gcs.core.tracker` re-exports them: the loop's callers import them from there.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.estimate import GaussianEstimate
from gcs.core.models.sensor import AZIMUTH, ELEVATION, RANGE, DetectionGroup, SensorModel

__all__ = ["Detection", "Sensing", "stack_detections", "vehicle_covariances", "initial_estimate"]


@dataclass(frozen=True)
class Detection:
    """One vehicle's detection: its index in the roster, its position (3,) and the measurement (m,).

    ``vehicle_cov`` is the covariance of that position as the vehicle's navigation
    knows it, ENU m^2: (2, 2) horizontal (the vertical then counts as exact) or
    (3, 3); or a float, the variance ``s^2`` of an error of ``s`` on every axis (a
    report's ``vehicle_position_std_m``); None for an exactly known position. The
    DUIF then inflates the measurement noise by ``J_s P_s J_s^T``
    (:meth:`UnscentedInformationFilter.contribution`).
    """

    vehicle: int
    vehicle_xyz: NDArray[np.float64]
    values: NDArray[np.float64]
    vehicle_cov: NDArray[np.float64] | float | None = None

    def __post_init__(self) -> None:
        if isinstance(self.vehicle_cov, (float, int)):
            if not (math.isfinite(self.vehicle_cov) and self.vehicle_cov >= 0.0):
                raise ValueError(f"a per-axis vehicle variance must be finite and >= 0, got {self.vehicle_cov!r}")
            object.__setattr__(self, "vehicle_cov", float(self.vehicle_cov))
        elif self.vehicle_cov is not None:
            cov = np.asarray(self.vehicle_cov, dtype=np.float64)
            if cov.shape == (2, 2):
                cov = np.pad(cov, ((0, 1), (0, 1)))
            if cov.shape != (3, 3) or not math.isfinite(cov.sum()) or min(cov[0, 0], cov[1, 1], cov[2, 2]) < 0.0:
                raise ValueError(f"vehicle_cov must be a finite (2, 2) or (3, 3) covariance, got {self.vehicle_cov!r}")
            object.__setattr__(self, "vehicle_cov", 0.5 * (cov + cov.T))

    @property
    def position_cov(self) -> NDArray[np.float64]:
        """``vehicle_cov`` as (3, 3), zeros when the position is exact."""
        if self.vehicle_cov is None:
            return np.zeros((3, 3))
        if isinstance(self.vehicle_cov, float):
            return self.vehicle_cov * np.eye(3)
        return self.vehicle_cov


@dataclass(frozen=True)
class Sensing:
    """Every vehicle that sensed at a step, detections or not: where it was (V, 3) and whether it detected the
    target (V,). The road tracker's negative information: a vehicle that had a hypothesis in sight and
    detected nothing is evidence against it (:class:`gcs.core.roads.Looks`)."""

    vehicle_xyz: NDArray[np.float64]
    detected: NDArray[np.bool_]


def initial_estimate(detection: Detection, sensor: SensorModel, stamp_ns: int, position_std_m: float,
                     velocity_std_mps: float, state_dim: int) -> GaussianEstimate:
    """A track from one range/azimuth detection: the inverted measurement, velocity unknown (zero)."""
    if RANGE not in sensor.components:
        raise ValueError("initialising from a single detection needs a range measurement")
    values = dict(zip(sensor.components, detection.values))
    elevation = values.get(ELEVATION)
    if elevation is not None:
        ground = values[RANGE] * np.cos(elevation)
    else:
        ground = np.sqrt(max(values[RANGE] ** 2 - (detection.vehicle_xyz[2] - sensor.target_height_m) ** 2, 0.0))
    azimuth = values[AZIMUTH]
    mean = np.zeros(state_dim)
    mean[:2] = detection.vehicle_xyz[:2] + ground * np.array([np.cos(azimuth), np.sin(azimuth)])
    variances = np.full(state_dim, velocity_std_mps**2)
    variances[:2] = position_std_m**2
    return GaussianEstimate(mean, np.diag(variances), stamp_ns)


def stack_detections(sensors: Sequence[SensorModel], detections: Sequence[Detection]) -> list[DetectionGroup]:
    """The detections grouped by sensor model: ``(sensor, z (k, m), vehicle_xyz (k, 3), vehicle covariances)``."""
    groups: dict[SensorModel, list[Detection]] = {}
    for detection in detections:
        groups.setdefault(sensors[detection.vehicle], []).append(detection)
    return [(sensor, np.array([d.values for d in group]), np.array([d.vehicle_xyz for d in group]),
             vehicle_covariances(group)) for sensor, group in groups.items()]


def vehicle_covariances(group: Sequence[Detection]) -> NDArray[np.float64] | None:
    """The group's vehicle position uncertainty: None when every position is exact, per-axis
    variances (k,) when none has a matrix (exact ones count 0), else covariances (k, 3, 3)."""
    covs = [d.vehicle_cov for d in group]
    if all(c is None for c in covs):
        return None
    if all(c is None or isinstance(c, float) for c in covs):
        return np.array([0.0 if c is None else c for c in covs])
    return np.stack([d.position_cov for d in group])
